"""Observer-side track metrics (helixd.recorder.track): numbers worked out by hand."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.frames import MissionFrame, NedPose
from helixd.base.geometry import NonFiniteError
from helixd.recorder.track import (
    NE,
    TrackPoint,
    distance_to_polyline_m,
    distance_to_segment_m,
    mission_window,
    planned_polyline_ned,
    track_metrics,
)

SQUARE_XY = [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]  # config/missions/square.yaml


def test_segment_distance_inside_beyond_the_ends_and_degenerate() -> None:
    a, b = (0.0, 0.0), (10.0, 0.0)
    assert distance_to_segment_m((5.0, 3.0), a, b) == pytest.approx(3.0)
    assert distance_to_segment_m((-3.0, 4.0), a, b) == pytest.approx(5.0)  # past a: to a
    assert distance_to_segment_m((13.0, -4.0), a, b) == pytest.approx(5.0)  # past b: to b
    assert distance_to_segment_m((3.0, 4.0), a, a) == pytest.approx(5.0)


def test_polyline_distance_is_to_the_nearest_leg() -> None:
    poly = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]
    assert distance_to_polyline_m((9.0, 5.0), poly) == pytest.approx(1.0)  # leg 2
    assert distance_to_polyline_m((5.0, -2.0), poly) == pytest.approx(2.0)  # leg 1
    assert distance_to_polyline_m((1.0, 1.0), [(0.0, 0.0)]) == pytest.approx(math.sqrt(2))
    with pytest.raises(ValueError, match="empty"):
        distance_to_polyline_m((0.0, 0.0), [])


def test_square_in_the_start_frame_is_counter_clockwise_in_ned() -> None:
    """Facing North at (2, 3): x forward = North, y left = West (−East)."""
    frame = MissionFrame.start_at(NedPose(2.0, 3.0, 0.0))
    poly = planned_polyline_ned(SQUARE_XY, frame, (2.0, 3.0))
    expected = [(2.0, 3.0), (12.0, 3.0), (12.0, -7.0), (2.0, -7.0), (2.0, 3.0)]
    assert poly == [pytest.approx(p) for p in expected]
    east = MissionFrame.start_at(NedPose(0.0, 0.0, math.pi / 2))  # facing East: left = North
    assert planned_polyline_ned([(10.0, 10.0)], east, (0.0, 0.0))[1] == pytest.approx((10.0, 10.0))


def _track(points: list[tuple[float, float, float]]) -> list[TrackPoint]:
    return [TrackPoint(t, n, e) for t, n, e in points]


def test_window_cuts_rest_before_and_after() -> None:
    track = _track(
        [(0, 0, 0), (1, 0, 0), (2, 0.01, 0), (3, 1, 0), (4, 2, 0), (5, 3, 0), (6, 3, 0.02)]
    )
    assert mission_window(track, 0.05) == (2, 5)
    still = _track([(0, 0, 0), (1, 0, 0.01)])
    assert mission_window(still, 0.05) == (0, 1)


def test_metrics_of_a_hand_made_track() -> None:
    """Along leg 1 (0,0)→(10,0) with lateral offsets 0, 1, −1, 0 at 1 s spacing, then rest."""
    poly = [(0.0, 0.0), (10.0, 0.0)]
    track = _track(
        [(0, 0, 0), (1, 0, 0), (2, 3, 1), (3, 6, -1), (4, 9.5, 0), (5, 9.5, 0), (6, 9.5, 0)]
    )
    m = track_metrics(track, poly)
    assert m is not None
    assert m.samples == 4  # t = 1 .. 4
    # time weights: ½, 1, 1, ½ over 3 s: (0 + 1 + 1 + 0) / 3
    assert m.cross_track_rms_m == pytest.approx(math.sqrt(2.0 / 3.0))
    assert m.cross_track_max_m == pytest.approx(1.0)
    assert m.final_error_m == pytest.approx(0.5)
    assert m.elapsed_s == pytest.approx(3.0)
    assert "rms 0.816 m max 1.000 m, final error 0.500 m, 3.0 s" in m.line()


def test_rms_is_time_weighted_not_sample_weighted() -> None:
    """A dense burst of samples at 1 m off does not outweigh a long stretch on the line."""
    poly = [(0.0, 0.0), (100.0, 0.0)]
    sparse = [(float(t), float(t), 0.0) for t in range(0, 11)]  # on the line, 1 Hz
    dense = [(10.0 + k / 100, 10.0 + k / 100, 1.0) for k in range(1, 101)]  # 1 s, 1 m off
    m = track_metrics(_track(sparse + dense), poly, rest_tolerance_m=0.0)
    assert m is not None
    assert m.cross_track_rms_m == pytest.approx(math.sqrt(1.0 / 11.0), rel=0.05)


def test_no_metrics_without_samples_or_plan_and_non_finite_raises() -> None:
    assert track_metrics([], [(0.0, 0.0)]) is None
    assert track_metrics(_track([(0, 0, 0)]), [(0.0, 0.0)]) is None
    assert track_metrics(_track([(0, 0, 0), (1, 1, 0)]), []) is None
    with pytest.raises(NonFiniteError):
        track_metrics(_track([(0, 0, 0), (1, math.nan, 0)]), [(0.0, 0.0)])
    with pytest.raises(NonFiniteError):
        track_metrics(_track([(0, 0, 0), (1, 1, 0)]), [(math.inf, 0.0)])


finite = st.floats(-1e4, 1e4, allow_nan=False)


@given(
    st.lists(st.tuples(finite, finite), min_size=2, max_size=30),
    st.lists(st.tuples(finite, finite), min_size=1, max_size=6),
)
def test_metrics_are_finite_and_ordered(pts: list[tuple[float, float]], poly: list[NE]) -> None:
    track = [TrackPoint(float(i), n, e) for i, (n, e) in enumerate(pts)]
    m = track_metrics(track, poly)
    assert m is not None
    values = (m.cross_track_rms_m, m.cross_track_max_m, m.final_error_m, m.elapsed_s)
    assert all(math.isfinite(v) and v >= 0.0 for v in values)
    assert m.cross_track_rms_m <= m.cross_track_max_m * (1 + 1e-9) + 1e-9


def test_sitl_square_metrics_take_the_start_frame_where_the_rover_left_its_rest() -> None:
    """tests/sitl's observer computation: facing East at (5, 5), waits, then drives the square
    (x forward = East, y left = North) exactly; then rests. Zero cross-track, 40 s."""
    from tests.support.skid_setup import square_metrics

    corners = [(5.0, 5.0), (5.0, 15.0), (15.0, 15.0), (15.0, 5.0), (5.0, 5.0)]  # (n, e)
    track = [TrackPoint(float(t), 5.0, 5.0) for t in range(3)]
    t = 2.0
    for (n0, e0), (n1, e1) in itertools.pairwise(corners):
        for k in range(1, 11):  # 1 m/s
            t += 1.0
            track.append(TrackPoint(t, n0 + (n1 - n0) * k / 10, e0 + (e1 - e0) * k / 10))
    track += [TrackPoint(t + 1.0, 5.0, 5.0), TrackPoint(t + 2.0, 5.0, 5.0)]
    m = square_metrics(track, lambda t_s: math.pi / 2)
    assert m is not None
    assert m.cross_track_max_m == pytest.approx(0.0, abs=1e-9)
    assert m.final_error_m == pytest.approx(0.0, abs=1e-9)
    assert m.elapsed_s == pytest.approx(40.0)
    facing_north = square_metrics(track, lambda t_s: 0.0)  # the wrong heading shows
    assert facing_north is not None and facing_north.cross_track_max_m > 5.0
    assert square_metrics(track, lambda t_s: None) is None  # no ATTITUDE yet: no metrics
