"""helixd.prepare.plan_report: what `helixd check` prints — the operator's waypoints numbered
from 1, via points as such, the path and the estimate of the route as flown, the margin."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.config.root import HelixdConfig
from helixd.mission.judge import patrol_times_s, plan_time_estimate
from helixd.mission.model import load_mission
from helixd.mission.validate import apply_mission_limits, plan_for_check
from helixd.planning.mapfile import load_map
from helixd.prepare.plan_report import check_lines, estimate_line, waypoint_table
from helixd.prepare.planned import plan_loaded
from tests.support.paths import REPO_ROOT

CFG = HelixdConfig()
MISSIONS = REPO_ROOT / "config" / "missions"


def pond_lines() -> list[str]:
    path = MISSIONS / "pond-crossing.yaml"
    msn = load_mission(path)
    occupancy = load_map(REPO_ROOT / "config" / "maps" / "pond.yaml", CFG.planning.max_cells)
    planned, route = plan_loaded(CFG, msn, path, occupancy)
    return check_lines(CFG, msn, path, "(built-in defaults)", planned, route)


def test_the_planned_route_is_estimated_with_its_detours_and_a_margin() -> None:
    """The field engineer's pond crossing: "path 55.4 m … estimate 94 s" for a route of
    119.6 m that took 229 s; now the route as flown, from where it is planned (with the
    default corner arcs: 211.4 s estimated, 217.2 s flown with --sim --sim-speedup 10)."""
    lines = pond_lines()
    path = next(line for line in lines if line.startswith("path    :"))
    assert path.startswith("path    : 119.6 m from planning.start_ne_m, planned around obstacles")
    estimate = next(line for line in lines if line.startswith("estimate:"))
    seconds = float(estimate.split()[1])
    assert seconds == pytest.approx(217.2, rel=0.10)
    assert "limit safety.mission_time_limit_s = 1800 s, margin 1589" in estimate


def test_waypoints_are_numbered_from_1_and_via_points_are_shown_as_such() -> None:
    lines = pond_lines()
    table = lines[lines.index(next(x for x in lines if x.strip().startswith("#"))) + 1 :]
    labels = [row[:7].strip() for row in table[:12]]
    assert labels == ["via → 1"] * 6 + ["1", "2"] + ["via → 3"] * 3 + ["3"]
    assert any("waypoints numbered from 1, 9 via points inserted" in x for x in lines)
    assert "  leg start → wp 1: 56.4 m (6 intermediate, straight 40.0 m)" in lines


def test_the_square_estimate_counts_acceleration_braking_and_pivots() -> None:
    msn = load_mission(MISSIONS / "square.yaml")
    pivots = CFG.model_copy(
        update={"control": CFG.control.model_copy(update={"corner_error_m": 0.0})}
    )
    lines = check_lines(pivots, msn, Path("square.yaml"), "x", msn, None)
    assert "path    : 40.0 m at 0.60 m/s" in lines
    estimate = next(line for line in lines if line.startswith("estimate:"))
    assert estimate.startswith("estimate: 83 s (1.4 min: 79 s driving, 5 s in 3 turns in place)")
    assert estimate.endswith("margin 1717 s (21.6× the estimate)")
    # with the default corner arcs: no turn in place (flown: 71.8–72.1 s)
    lines = check_lines(CFG, msn, Path("square.yaml"), "x", msn, None)
    estimate = next(line for line in lines if line.startswith("estimate:"))
    assert estimate.startswith("estimate: 71 s (1.2 min: 71 s driving);")
    plan, _ = plan_for_check(msn, CFG)
    assert waypoint_table(plan)[1].strip().startswith("1 ")


def test_the_margin_names_the_missions_own_time_limit() -> None:
    msn = load_mission(MISSIONS / "square.yaml").model_copy(update={"time_limit_s": 90.0})
    plan, _ = plan_for_check(msn, CFG)
    cfg = apply_mission_limits(CFG, msn)
    line = estimate_line(plan_time_estimate(plan, cfg), cfg, msn, "")
    assert "limit the mission's time_limit_s = 90 s, margin 19 s (1.3× the estimate)" in line


def test_check_counts_the_ground_the_mission_declares() -> None:
    """The circle declares the simulator's hard ground, where the scroll axis gets 45 % (90 %
    with the feed-forward): 37 s estimated, flown in 37.5–37.8 s; without it 33 s."""
    msn = load_mission(MISSIONS / "circle.yaml")
    assert msn.ground is not None and msn.ground.scroll_fraction == 0.45
    cfg = apply_mission_limits(CFG, msn)
    lines = check_lines(cfg, msn, Path("circle.yaml"), "x", msn, None)
    estimate = next(line for line in lines if line.startswith("estimate:"))
    assert estimate.startswith("estimate: 37 s (0.6 min: 36 s driving, 1 s in 1 turns in place)")
    assert (
        "ground  : the mission's ground: roll 0.95, scroll 0.45, yaw 0.85 of the command; with "
        "the slip feed-forward (at most 2×) scroll drives at 0.90 and turns at 1.00 of the "
        "navigator's command, counted in the estimate"
    ) in lines
    bare = msn.model_copy(update={"ground": None})
    lines = check_lines(CFG, bare, Path("circle.yaml"), "x", bare, None)
    estimate = next(line for line in lines if line.startswith("estimate:"))
    assert estimate.startswith("estimate: 33 s")
    assert any(
        line.startswith("ground  : no slip assumed (control.slip.ground_* = 1)") for line in lines
    )


def test_check_warns_that_a_fenced_mission_must_start_inside_its_fence(tmp_path: Path) -> None:
    """Before: `check` passed a survey that `run` then refused (the start outside the
    survey's fence); `check` now says it before `run` does."""
    path = tmp_path / "fenced.yaml"
    path.write_text(
        "name: fenced\nmode: scroll\nframe: global\n"
        "waypoints:\n  - {lat: 53.52330, lon: -113.52630}\n  - {lat: 53.52340, lon: -113.52630}\n"
        "geofence_polygon:\n  - [53.52320, -113.52640]\n  - [53.52350, -113.52640]\n"
        "  - [53.52350, -113.52620]\n  - [53.52320, -113.52620]\n"
    )
    msn = load_mission(path)
    lines = check_lines(CFG, msn, path, "x", msn, None)
    warning = [line for line in lines if line.startswith("warning :")]
    assert warning == [
        "warning : the rover must start inside the mission's geofence_polygon: run refuses a "
        "start outside it (a survey's fence is its area grown by --margin-m)"
    ]
    plain = load_mission(MISSIONS / "pond-crossing.yaml")
    assert not [
        line
        for line in check_lines(CFG, plain, path, "x", plain, None)
        if line.startswith("warning :")
    ]


def test_a_patrol_whose_planned_laps_end_before_its_limit_says_it_then_holds() -> None:
    """A plan holds at most so many steps: a short loop under a long limit runs out of planned
    laps first, and the estimate says the rover then holds, not that the limit ends it."""
    msn = load_mission(MISSIONS / "square.yaml")
    jump = msn.waypoints[0].model_validate({"command": "DO_JUMP", "item": 1, "repeat": -1})
    loop = [*msn.waypoints, jump]
    msn = msn.model_copy(update={"waypoints": loop, "time_limit_s": 86_400.0})
    plan, _ = plan_for_check(msn, CFG)
    cfg = apply_mission_limits(CFG, msn)
    estimate = plan_time_estimate(plan, cfg)
    line = estimate_line(estimate, cfg, msn, "", patrol_times_s(plan, estimate))
    assert line.startswith("estimate: a patrol, flown until stopped: first lap done at "), line
    assert ", then it holds where it is until stopped or limit the mission's" in line, line
