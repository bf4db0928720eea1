"""tools/navmetrics.py: cross-track of a path to the planned polygon, frame recovery, effort."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.frames import MissionFrame, NedPose
from tests.support.tools import load_tool

nm = load_tool("navmetrics")

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]


def test_segment_distance_inside_and_beyond_the_ends() -> None:
    assert nm.segment_distance_m((0.0, 0.0), (10.0, 0.0), (5.0, 2.0)) == pytest.approx(2.0)
    assert nm.segment_distance_m((0.0, 0.0), (10.0, 0.0), (5.0, -2.0)) == pytest.approx(2.0)
    assert nm.segment_distance_m((0.0, 0.0), (10.0, 0.0), (13.0, 4.0)) == pytest.approx(5.0)
    assert nm.segment_distance_m((0.0, 0.0), (10.0, 0.0), (-3.0, 4.0)) == pytest.approx(5.0)
    assert nm.segment_distance_m((1.0, 1.0), (1.0, 1.0), (4.0, 5.0)) == pytest.approx(5.0)
    assert math.isnan(nm.segment_distance_m((0.0, 0.0), (1.0, 0.0), (math.nan, 0.0)))


def test_polyline_distance_takes_the_nearest_leg() -> None:
    assert nm.polyline_distance_m(SQUARE, (5.0, 1.0)) == pytest.approx(1.0)
    assert nm.polyline_distance_m(SQUARE, (9.0, 5.0)) == pytest.approx(1.0)
    assert nm.polyline_distance_m(SQUARE, (5.0, 5.0)) == pytest.approx(5.0)
    assert nm.polyline_distance_m(SQUARE, (11.0, 11.0)) == pytest.approx(math.sqrt(2.0))
    assert nm.polyline_distance_m([(1.0, 1.0)], (1.0, 3.0)) == pytest.approx(2.0)
    assert math.isnan(nm.polyline_distance_m(SQUARE, (math.inf, 0.0)))
    with pytest.raises(ValueError):
        nm.polyline_distance_m([], (0.0, 0.0))


def test_path_metrics_rms_max_final() -> None:
    path = [(0.0, 0.0), (5.0, 1.0), (10.0, 3.0), (math.nan, 1.0), (1.0, 0.0)]
    m = nm.path_metrics(path, SQUARE)
    # distances 0, 1, 0, (skipped), 0 -> but (1, 0) is on the first leg
    assert m.samples == 4
    assert m.xt_max_m == pytest.approx(1.0)
    assert m.xt_rms_m == pytest.approx(math.sqrt(1.0 / 4))
    assert m.final_error_m == pytest.approx(1.0)
    empty = nm.path_metrics([(math.nan, math.nan)], SQUARE)
    assert empty == nm.PathMetrics(0, None, None, None)
    with pytest.raises(ValueError):
        nm.path_metrics(path, [(0.0, math.nan)])


@given(
    st.floats(-50, 50), st.floats(-50, 50), st.floats(-math.pi, math.pi),
    st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), min_size=1, max_size=20),
)  # fmt: skip
def test_frame_is_recovered_from_the_recorded_pose(
    on: float, oe: float, oyaw: float, pts: list[tuple[float, float]]
) -> None:
    frame = MissionFrame.start_at(NedPose(on, oe, oyaw))
    ned = [frame.to_ned(x, y) for x, y in pts]
    yaw_ned = [0.3 * i for i in range(len(pts))]
    yaw = [
        frame.to_mission(NedPose(n, e, yn)).yaw_rad for (n, e), yn in zip(ned, yaw_ned, strict=True)
    ]
    got = nm.frame_from_flight(
        [n for n, _ in ned], [e for _, e in ned], yaw_ned,
        [x for x, _ in pts], [y for _, y in pts], yaw,
    )  # fmt: skip
    assert got is not None
    for x, y in [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0)]:
        assert got.to_ned(x, y) == pytest.approx(frame.to_ned(x, y), abs=1e-6)


def test_enu_frame_is_recovered_and_non_finite_rows_are_skipped() -> None:
    enu = MissionFrame.enu()
    pose = enu.to_mission(NedPose(3.0, 4.0, 0.5))
    got = nm.frame_from_flight(
        [3.0, math.nan], [4.0, 1.0], [0.5, 0.0], [pose.x_m, 0.0], [pose.y_m, 0.0],
        [pose.yaw_rad, 0.0],
    )  # fmt: skip
    assert got is not None
    assert got.to_ned(7.0, -2.0) == pytest.approx(enu.to_ned(7.0, -2.0))
    assert nm.frame_from_flight([math.nan], [0.0], [0.0], [0.0], [0.0], [0.0]) is None
    assert nm.frame_from_flight([], [], [], [], [], []) is None


def test_planned_polyline_in_ned() -> None:
    frame = MissionFrame.start_at(NedPose(1.0, 2.0, 0.0))  # facing North: x = N, y = West
    poly = nm.planned_polyline_ned(frame, (0.0, 0.0), [(10.0, 0.0), (10.0, 10.0)])
    flat = [v for point in poly for v in point]
    assert flat == pytest.approx([1.0, 2.0, 11.0, 2.0, 11.0, -8.0])


def test_scroll_effort_integrates_abs_fractions() -> None:
    t = [0.0, 1.0, 1.0, 3.0, 2.0, 4.0]  # a repeated and a backwards step are skipped
    full = [1.0, 1.0, 9.0, 9.0, 9.0, 0.0]
    rev = [-0.5, -0.5, 9.0, math.nan, 9.0, 0.0]
    zero = [0.0] * 6
    # 0..1: |1| + |-0.5| = 1.5; 1..3 (row 2 held): 9 + 9 = 18 * 2 = 36; 3->2 skipped;
    # 2..4: row 4 = 9 + 9 = 18 * 2 = 36
    assert nm.scroll_effort(t, [full, rev, zero, zero]) == pytest.approx(1.5 + 36 + 36)
    assert nm.scroll_effort([0.0], [[1.0]]) is None
    with pytest.raises(ValueError):
        nm.scroll_effort([0.0, 1.0], [[1.0]])


def test_clip_and_ratio() -> None:
    samples = [(0.5, 1.0, 1.0), (1.0, 2.0, 2.0), (2.0, 3.0, 3.0), (2.5, 4.0, 4.0)]
    assert nm.clip_to_window(samples, 1.0, 2.0) == [(2.0, 2.0), (3.0, 3.0)]
    assert nm.ratio(1.0, 4.0) == pytest.approx(0.25)
    assert nm.ratio(None, 4.0) is None
    assert nm.ratio(1.0, 0.0) is None
    assert nm.ratio(math.nan, 1.0) is None


point = st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3))


@given(st.lists(point, min_size=1, max_size=8), point, st.floats(0.0, 1.0))
def test_polyline_distance_is_bounded_and_zero_on_the_path(
    poly: list[tuple[float, float]], p: tuple[float, float], frac: float
) -> None:
    d = nm.polyline_distance_m(poly, p)
    assert 0.0 <= d <= min(math.hypot(p[0] - q[0], p[1] - q[1]) for q in poly) + 1e-9
    a, b = poly[0], poly[min(1, len(poly) - 1)]
    on = (a[0] + frac * (b[0] - a[0]), a[1] + frac * (b[1] - a[1]))
    assert nm.polyline_distance_m(poly, on) <= 1e-6 * (1.0 + math.hypot(*on))
