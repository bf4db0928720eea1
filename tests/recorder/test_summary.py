"""SummaryBuilder maths against hand-computed values."""

from __future__ import annotations

import math

import pytest

from helixd import __version__
from helixd.recorder.rows import nan_row
from helixd.recorder.summary import RunSummary, SummaryBuilder


def row(t: float, x: float, y: float, xt: float, d: float = math.nan, fresh: bool = True):  # type: ignore[no-untyped-def]
    return nan_row(t_mono_s=t, x_m=x, y_m=y, cross_track_m=xt, distance_error_m=d, pose_fresh=fresh)


def test_hand_computed_summary() -> None:
    b = SummaryBuilder("square", "roll", 4, final_xy_m=(6.0, 9.0), path_min_step_m=0.1)
    b.add(row(10.0, 0.0, 0.0, 0.3))
    b.add(row(10.5, 3.0, 4.0, -0.4))  # 5 m
    b.add(row(11.0, 3.0, 4.05, math.nan))  # 5 cm jitter: below the step, not yet counted
    b.add(row(11.5, 50.0, 50.0, 0.0, fresh=False))  # stale pose: ignored for the path
    b.add(row(12.0, 6.0, 8.0, 1.2, d=2.5))  # 5 m from the last counted point (3, 4)
    b.arrival(0, 101.5, 0.8)
    b.arrival(0, 101.6, 0.7)  # duplicate notice: the first counts
    b.arrival(1, 103.0, 0.9)
    s = b.build(completed=False, fault="stall: no motion", exit_code=4)
    assert s.path_length_m == pytest.approx(10.0)
    # cross-track over finite samples: 0.3, -0.4, 0.0, 1.2
    assert s.cross_track_rms_m == pytest.approx(math.sqrt((0.09 + 0.16 + 0.0 + 1.44) / 4))
    assert s.cross_track_max_m == pytest.approx(1.2)
    assert s.duration_s == pytest.approx(2.0)
    assert s.final_error_m == pytest.approx(1.0)  # (6, 8) → (6, 9)
    assert s.waypoints_reached == 2 and s.waypoints_total == 4
    assert [(a.index, a.t_boot_s, a.error_m) for a in s.arrivals] == [
        (0, 101.5, 0.8),
        (1, 103.0, 0.9),
    ]
    assert s.rows == 5 and s.fault == "stall: no motion" and s.exit_code == 4
    assert s.helixd_version == __version__ and s.mission_name == "square" and s.mode == "roll"


def test_final_error_without_final_point_uses_last_distance_error() -> None:
    b = SummaryBuilder("m", "omni", 1)
    b.add(row(0.0, 0.0, 0.0, 0.0, d=3.0))
    b.add(row(1.0, 0.5, 0.0, 0.0, d=2.5))
    b.add(row(2.0, 0.5, 0.0, 0.0))  # NaN distance: keeps the last known
    assert b.build(False, None, 5).final_error_m == pytest.approx(2.5)


def test_residual_short_step_counts_at_the_end() -> None:
    b = SummaryBuilder("m", "roll", 1, path_min_step_m=1.0)
    b.add(row(0.0, 0.0, 0.0, 0.0))
    b.add(row(1.0, 0.6, 0.0, 0.0))
    assert b.build(True, None, 0).path_length_m == pytest.approx(0.6)


def test_empty_run_and_overrides() -> None:
    s = SummaryBuilder().build(
        False, "link", 6, mission_name="x", mode="scroll", waypoints_total=3, wall_duration_s=4.5
    )
    assert s.rows == 0 and s.duration_s == 0.0 and s.path_length_m == 0.0
    assert s.cross_track_rms_m is None and s.cross_track_max_m is None and s.final_error_m is None
    assert (s.mission_name, s.mode, s.waypoints_total, s.wall_duration_s) == ("x", "scroll", 3, 4.5)


def test_json_round_trip() -> None:
    b = SummaryBuilder("square", "roll", 4, (0.0, 0.0))
    b.set_origin(47.1, 8.5)
    b.add(row(0.0, 1.0, 1.0, 0.2))
    b.arrival(3, 9.0, 0.5)
    s = b.build(True, None, 0)
    text = s.to_json()
    assert '"fault": null' in text
    assert RunSummary.from_json(text) == s
    assert RunSummary.from_json(text).origin_latlon_deg == (47.1, 8.5)


def test_duration_is_autopilot_time_unless_it_stepped_back() -> None:
    # simulator at 5× speed-up: 1 s of wall time is 5 s on the autopilot's clock
    b = SummaryBuilder()
    for k in range(11):
        b.add(_boot_row(100.0 + 0.1 * k, 20.0 + 0.5 * k))
    s = b.build(True, None, 0)
    assert s.duration_s == pytest.approx(5.0) and s.duration_clock == "autopilot"
    assert s.duration_mono_s == pytest.approx(1.0)  # both clocks over the same span
    assert s.start_t_boot_s == pytest.approx(20.0)
    b.add(_boot_row(101.1, 1.0))  # autopilot rebooted: fall back to the monotonic clock
    s = b.build(False, "x", 4)
    assert s.duration_s == pytest.approx(1.1) and s.duration_clock == "monotonic"
    assert s.duration_mono_s == pytest.approx(1.1)


def test_summary_json_from_before_the_clock_fields_still_reads() -> None:
    s = SummaryBuilder("sq", "roll", 4).build(True, None, 0)
    data = s.model_dump(mode="json")
    for key in ("duration_clock", "duration_mono_s", "start_t_boot_s"):
        del data[key]
    old = RunSummary.model_validate(data)
    assert old.duration_clock == "autopilot" and old.duration_mono_s is None


def _boot_row(t_mono_s: float, t_boot_s: float):  # type: ignore[no-untyped-def]
    import dataclasses

    return dataclasses.replace(row(t_mono_s, 0.0, 0.0, 0.0), t_boot_s=t_boot_s)


def test_via_points_are_not_counted_as_the_operators_waypoints() -> None:
    """A 3-waypoint mission planned with 9 via points is "3/3 waypoints", not "12/12"."""
    b = SummaryBuilder("pond", "roll", 3, via_points_total=9)
    numbers = [1, 1, 1, 1, 2, 2, 2, 3, 3, 3, 3, 3]
    vias = [True, True, True, False, True, True, False, True, True, True, True, False]
    for i, (number, via) in enumerate(zip(numbers, vias, strict=True)):
        b.arrival(i, 100.0 + i, 0.1, number=number, via=via)
    assert b.waypoints_reached == 3
    s = b.build(True, None, 0)
    assert (s.waypoints_reached, s.waypoints_total) == (3, 3)
    assert (s.via_points_reached, s.via_points_total) == (9, 9)
    assert [a.number for a in s.arrivals if not a.via] == [1, 2, 3]
    assert RunSummary.from_json(s.to_json()) == s


def test_a_resumed_runs_approach_is_not_cross_track_error() -> None:
    """Until the rover is on the interrupted leg (within join_m of it) or reaches a waypoint,
    its distance from the leg is the approach, not the mission's error."""
    b = SummaryBuilder("lane", "roll", 2, join_m=0.1)
    b.add(row(0.0, 0.0, 0.0, 5.25))  # the approach from where the rover stood
    b.add(row(1.0, 0.0, 0.0, 2.0))
    b.add(row(2.0, 0.0, 0.0, 0.05))  # on the leg: counted from here
    b.add(row(3.0, 0.0, 0.0, -0.2))
    s = b.build(True, None, 0)
    assert s.cross_track_max_m == pytest.approx(0.2)
    assert s.cross_track_rms_m == pytest.approx(math.sqrt((0.05**2 + 0.2**2) / 2))
    fresh = SummaryBuilder("lane", "roll", 2)  # a fresh run counts from its first row
    fresh.add(row(0.0, 0.0, 0.0, 5.25))
    assert fresh.build(True, None, 0).cross_track_max_m == pytest.approx(5.25)
    arrived = SummaryBuilder("lane", "roll", 2, join_m=0.1)
    arrived.add(row(0.0, 0.0, 0.0, 3.0))
    arrived.arrival(0, 1.0, 0.2)  # a waypoint reached: the approach is over
    arrived.add(row(1.0, 0.0, 0.0, 0.5))
    assert arrived.build(True, None, 0).cross_track_max_m == pytest.approx(0.5)
