"""helixd.planning core: grid search, inflation, line of sight, routes around keep-out shapes.

Pure: numbers in, numbers out. Oracles are deliberately naive (BFS, Dijkstra in Python,
brute-force inflation) so that they can be trusted by reading them.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections import deque

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.planning.grid import GridFrame, build_grid, inflate, segment_is_free
from helixd.planning.obstacles import (
    KeepOutCircle,
    ObstacleError,
    Obstacles,
    clearance_m,
    rover_half_width_m,
    with_geofence,
)
from helixd.planning.route import PlanningError, plan_mission, plan_route
from helixd.planning.search import Cell, grid_path

STEPS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def _cell_path_length(path: list[Cell]) -> float:
    """Length in cell units (1 straight, √2 diagonal)."""
    if len(path) < 2:
        return 0.0
    d = np.abs(np.diff(np.asarray(path, dtype=np.float64), axis=0))
    return float(np.hypot(d[:, 0], d[:, 1]).sum())


def _step_ok(free: np.ndarray, a: tuple[int, int], dr: int, dc: int) -> bool:
    r, c = a[0] + dr, a[1] + dc
    rows, cols = free.shape
    if not (0 <= r < rows and 0 <= c < cols) or not free[r, c]:
        return False
    return not (dr and dc) or bool(free[a[0] + dr, a[1]] and free[a[0], a[1] + dc])


def bfs_reachable(free: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> bool:
    if not (free[s] and free[g]):
        return False
    seen = {s}
    todo = deque([s])
    while todo:
        a = todo.popleft()
        if a == g:
            return True
        for dr, dc in STEPS:
            b = (a[0] + dr, a[1] + dc)
            if b not in seen and _step_ok(free, a, dr, dc):
                seen.add(b)
                todo.append(b)
    return False


def dijkstra_length(free: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> float:
    dist = {s: 0.0}
    heap = [(0.0, s)]
    while heap:
        d, a = heapq.heappop(heap)
        if a == g:
            return d
        if d > dist[a]:
            continue
        for dr, dc in STEPS:
            b = (a[0] + dr, a[1] + dc)
            if _step_ok(free, a, dr, dc):
                nd = d + (math.sqrt(2.0) if dr and dc else 1.0)
                if nd < dist.get(b, math.inf):
                    dist[b] = nd
                    heapq.heappush(heap, (nd, b))
    return math.inf


# -- the TurtleBot report's worked example ------------------------------------------------------


def test_report_five_by_five_example_gives_the_same_shortest_path() -> None:
    """The TurtleBot report's 5 × 5 example: S(1, 2), E(3, 2), a wall across row 2 open
    only at column 4. Its A* answer S(1,2), (1,3), (1,4), (2,4), (3,4), (3,3), E(3,2) has
    length 6; squeezing diagonally past the wall's end (1,3)→(2,4) is corner cutting and is
    not allowed."""
    free = np.ones((5, 5), dtype=bool)
    free[2, 0:4] = False
    path = grid_path(free, (1, 2), (3, 2))
    assert path == [(1, 2), (1, 3), (1, 4), (2, 4), (3, 4), (3, 3), (3, 2)]
    assert _cell_path_length(path) == pytest.approx(6.0)


def test_blocked_or_outside_end_cell_has_no_path() -> None:
    free = np.ones((4, 4), dtype=bool)
    free[0, 0] = False
    assert grid_path(free, (0, 0), (3, 3)) is None
    assert grid_path(free, (1, 1), (4, 3)) is None
    assert grid_path(free, (2, 2), (2, 2)) == [(2, 2)]


# -- random maps against the oracles -----------------------------------------------------------


@st.composite
def random_maps(draw: st.DrawFn) -> tuple[np.ndarray, tuple[int, int], tuple[int, int]]:
    rows = draw(st.integers(2, 14))
    cols = draw(st.integers(2, 14))
    density = draw(st.floats(0.0, 0.6))
    seed = draw(st.integers(0, 2**31 - 1))
    free = np.random.default_rng(seed).random((rows, cols)) >= density
    s = (draw(st.integers(0, rows - 1)), draw(st.integers(0, cols - 1)))
    g = (draw(st.integers(0, rows - 1)), draw(st.integers(0, cols - 1)))
    return free, s, g


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_maps())
def test_random_maps_path_exists_iff_bfs_finds_one_and_is_shortest(
    case: tuple[np.ndarray, tuple[int, int], tuple[int, int]],
) -> None:
    free, s, g = case
    path = grid_path(free, s, g)
    assert (path is not None) == bfs_reachable(free, s, g)
    if path is None:
        return
    assert path[0] == s and path[-1] == g
    for a, b in itertools.pairwise(path):
        dr, dc = b[0] - a[0], b[1] - a[1]
        assert max(abs(dr), abs(dc)) == 1
        assert _step_ok(free, a, dr, dc), f"step {a}→{b} enters or cuts an inflated cell"
    # 70/99 integer costs: within 0.01 % of the true octile shortest length
    assert _cell_path_length(path) == pytest.approx(dijkstra_length(free, s, g), rel=1e-4)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_maps(), st.sampled_from([1.1, 1.25, 2.0]))
def test_weighted_search_is_valid_and_within_its_bound(
    case: tuple[np.ndarray, tuple[int, int], tuple[int, int]], weight: float
) -> None:
    free, s, g = case
    path = grid_path(free, s, g, weight)
    assert (path is not None) == bfs_reachable(free, s, g)
    if path is None:
        return
    for a, b in itertools.pairwise(path):
        assert _step_ok(free, a, b[0] - a[0], b[1] - a[1])
    bound = max(round(70 * weight) / 70, round(99 * weight) / 99) * (1 + 1e-4)
    assert _cell_path_length(path) <= bound * dijkstra_length(free, s, g) + 1e-9


@settings(max_examples=150, deadline=None)
@given(
    st.integers(0, 2**31 - 1),
    st.floats(0.0, 0.15),
    st.floats(0.05, 1.5),
)
def test_random_shapes_routes_never_cross_an_inflated_cell(
    seed: int, density: float, clearance: float
) -> None:
    """Random blocked cells on a 12 m × 12 m grid at 0.25 m: every leg of a route is checked
    by sampling it densely, and a route exists exactly when the grid search says so."""
    rng = np.random.default_rng(seed)
    frame = GridFrame(0.0, 0.0, 0.25, 48, 48)
    base = rng.random((48, 48)) < density / 10.0
    grid = build_grid(frame, Obstacles(), clearance, base)
    a = (float(rng.uniform(0.1, 11.9)), float(rng.uniform(0.1, 11.9)))
    b = (float(rng.uniform(0.1, 11.9)), float(rng.uniform(0.1, 11.9)))
    try:
        route = plan_route([a, b], Obstacles(), clearance, occupancy=_Occ(frame, base))
    except PlanningError:
        reachable = (
            not grid.inflated[frame.cell_of(a)]
            and not grid.inflated[frame.cell_of(b)]
            and bfs_reachable(grid.free, frame.cell_of(a), frame.cell_of(b))
        )
        assert not reachable
        return
    for p, q in zip(route.polyline_ne_m()[:-1], route.polyline_ne_m()[1:], strict=True):
        for t in np.linspace(0.0, 1.0, 400):
            pt = (p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]))
            assert not route.grid.inflated[frame.cell_of(pt)], f"{pt} on leg {p}→{q}"
    # and the clearance holds in metres: distance from every sample to every blocked square
    blocked = np.argwhere(base)
    if len(blocked):
        for p, q in zip(route.polyline_ne_m()[:-1], route.polyline_ne_m()[1:], strict=True):
            for t in np.linspace(0.0, 1.0, 60):
                pt = np.array([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]) / 0.25
                d = np.maximum(np.abs(pt - (blocked + 0.5)) - 0.5, 0.0)
                assert np.hypot(d[:, 0], d[:, 1]).min() * 0.25 >= clearance - 1e-9


class _Occ:
    """A stand-in OccupancyMap (same attributes) for grids made in tests."""

    def __init__(self, frame: GridFrame, blocked: np.ndarray) -> None:
        self.frame = frame
        self.blocked = blocked
        self.source = None


# -- inflation ----------------------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 5.0))
def test_inflation_matches_brute_force_square_distance(seed: int, radius: float) -> None:
    rng = np.random.default_rng(seed)
    blocked = rng.random((13, 11)) < 0.04
    want = blocked.copy()  # an obstacle cell stays blocked even with no clearance
    for i, j in np.argwhere(blocked):
        for r in range(13):
            for c in range(11):
                if math.hypot(max(abs(r - i) - 1, 0), max(abs(c - j) - 1, 0)) < radius:
                    want[r, c] = True
    assert (inflate(blocked, radius) == want).all()


def test_inflating_the_walls_keeps_the_corridor_the_robot_fits_through() -> None:
    """The report's failure: it grew the robot by its radius and a margin of cells, and paths
    vanished. A 2.5 m gap between two walls, clearance 0.93 m: the point-robot path fits."""
    frame = GridFrame(0.0, 0.0, 0.1, 100, 100)
    base = np.zeros((100, 100), dtype=bool)
    base[50:52, :40] = True
    base[50:52, 65:] = True  # gap: columns 40..64 = 2.5 m
    route = plan_route([(1.0, 5.2), (9.0, 5.2)], Obstacles(), 0.93, occupancy=_Occ(frame, base))
    assert len(route.legs) == 1
    # 2.5 m gap - 2 × 0.93 m leaves 0.64 m of free centre line: the path goes through it
    for _n, e in route.legs[0].points_ne_m[1:-1]:
        assert 4.0 + 0.93 <= e <= 6.5 - 0.93


# -- keep-out shapes -----------------------------------------------------------------------------


def _samples(route_pts: list[tuple[float, float]], n: int = 200) -> list[tuple[float, float]]:
    out = []
    for p, q in itertools.pairwise(route_pts):
        out.extend(
            (p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])) for t in np.linspace(0, 1, n)
        )
    return out


def _dist_to_polygon(pt: tuple[float, float], poly: list[tuple[float, float]]) -> float:
    from matplotlib.path import Path as MplPath

    if MplPath(np.asarray(poly)).contains_point(pt):
        return 0.0
    best = math.inf
    for a, b in zip(poly, poly[1:] + poly[:1], strict=True):
        ax, ay, bx, by = *a, *b
        t = ((pt[0] - ax) * (bx - ax) + (pt[1] - ay) * (by - ay)) / (
            (bx - ax) ** 2 + (by - ay) ** 2
        )
        t = min(max(t, 0.0), 1.0)
        best = min(best, math.hypot(pt[0] - ax - t * (bx - ax), pt[1] - ay - t * (by - ay)))
    return best


def test_leg_through_a_keep_out_polygon_is_routed_around_it() -> None:
    poly = [(10.0, -6.0), (10.0, 4.0), (13.0, 4.0), (13.0, -6.0)]
    route = plan_route([(0.0, 0.0), (25.0, 0.0)], Obstacles(polygons_ne_m=(tuple(poly),)), 0.93)
    leg = route.legs[0]
    assert not leg.straight and 2 <= len(leg.points_ne_m) - 2 <= 6  # a few long legs
    assert min(_dist_to_polygon(p, poly) for p in _samples(list(leg.points_ne_m))) >= 0.93
    # the short way round (east edge at +4 m is nearer than the west one at -6 m)
    assert max(e for _, e in leg.points_ne_m) > 4.0
    assert leg.length_m < 25.0 + 2 * 5.5


def test_keep_out_circle_and_inclusion_polygon() -> None:
    fence = ((-5.0, -5.0), (-5.0, 8.0), (30.0, 8.0), (30.0, -5.0))
    obs = with_geofence(
        Obstacles(), exclusion_circles=[KeepOutCircle(12.0, 0.0, 3.0)], inclusion_ne_m=fence
    )
    route = plan_route([(0.0, 0.0), (25.0, 0.0)], obs, 0.93)
    pts = _samples(list(route.legs[0].points_ne_m))
    assert min(math.hypot(n - 12.0, e) for n, e in pts) >= 3.0 + 0.93
    assert all(-5 + 0.93 <= e <= 8 - 0.93 and -5 + 0.93 <= n <= 30 - 0.93 for n, e in pts)
    # circle widened to the fence on the east and west: no way round
    blocked = with_geofence(
        Obstacles(), exclusion_circles=[KeepOutCircle(12.0, 1.5, 9.0)], inclusion_ne_m=fence
    )
    with pytest.raises(PlanningError, match="leg waypoint 1 → waypoint 2: unreachable"):
        plan_route([(0.0, 0.0), (25.0, 0.0)], blocked, 0.93, first_index=0)


def test_waypoint_inside_an_inflated_obstacle_is_named() -> None:
    obs = Obstacles(circles=(KeepOutCircle(10.0, 0.0, 2.0),))
    with pytest.raises(PlanningError) as err:
        plan_route([(0.0, 0.0), (10.0, 2.5), (20.0, 0.0)], obs, 0.93)
    assert err.value.problems == [
        "waypoint 1 (north 10.00 m, east 2.50 m) lies inside the 0.93 m clearance of an obstacle "
        "(inflated by rover half-width + planning.margin_m)"
    ]


def test_segment_is_free_checks_every_cell_the_segment_crosses() -> None:
    frame = GridFrame(0.0, 0.0, 1.0, 5, 5)
    blocked = np.zeros((5, 5), dtype=bool)
    blocked[2, 3] = True
    grid = build_grid(frame, Obstacles(), 0.0, blocked)
    assert not segment_is_free(grid, (0.5, 0.5), (4.5, 4.5 + 1.2))  # passes through (2, 3)?
    assert segment_is_free(grid, (0.5, 0.5), (4.5, 4.5))  # diagonal, misses (2, 3)
    assert not segment_is_free(grid, (2.5, 0.5), (2.5, 4.5))
    assert not segment_is_free(grid, (0.5, 0.5), (0.5, 5.5))  # leaves the grid


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(ObstacleError, match="exclusion polygon 0: a polygon needs at least 3"):
        with_geofence(Obstacles(), exclusion_polygons_ne_m=[[(0.0, 0.0), (1.0, 1.0)]])
    with pytest.raises(ObstacleError, match="exclusion circle 0"):
        with_geofence(Obstacles(), exclusion_circles=[KeepOutCircle(0.0, math.nan, 1.0)])


# -- the mission hook ---------------------------------------------------------------------------


def test_plan_mission_inserts_waypoints_and_uses_the_vehicle_width() -> None:
    cfg = HelixdConfig.model_validate(
        {"planning": {"keep_out_polygons_ne_m": [[[8, -3], [8, 3], [10, 3], [10, -3]]]}}
    )
    assert clearance_m(cfg) == pytest.approx(0.508 / 2 + 0.175 + 0.5)
    assert rover_half_width_m(cfg) == pytest.approx(0.429)
    msn = Mission.model_validate(
        {
            "name": "t",
            "mode": "roll",
            "frame": "local_ned",
            "waypoints": [{"north": 18, "east": 0, "tolerance_m": 0.8}, {"north": 18, "east": 5}],
        }
    )
    planned, route = plan_mission(msn, cfg)
    assert len(planned.waypoints) > 2
    assert planned.waypoints[-2:] == msn.waypoints  # the second leg is straight
    inserted = planned.waypoints[:-2]
    assert all(w.tolerance_m == pytest.approx(0.3) for w in inserted)
    assert len(route.legs) == 2 and route.legs[1].straight


def test_plan_mission_refuses_start_frame_missions() -> None:
    msn = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": [{"x": 5, "y": 0}]}
    )
    with pytest.raises(PlanningError, match="needs a local_ned mission"):
        plan_mission(msn, HelixdConfig())
