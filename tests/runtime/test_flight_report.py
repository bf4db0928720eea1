"""What a control step becomes once its command has left, in numbers: its flight.csv row (the
target, the command, the pose, the medium under it) and the operator's progress line, from a
real navigator step on a resolved plan. (The batching :class:`StepJournal`:
tests/runtime/test_flight.py.)"""

from __future__ import annotations

import math

import pytest

from helixd.base.frames import NedPose
from helixd.base.geometry import BodyVelocity, Pose2D
from helixd.base.plan import Numbering, Plan
from helixd.config.root import HelixdConfig
from helixd.control.navigator import Navigator
from helixd.control.slip import SlipEstimate
from helixd.link.vehicle import PoseSample
from helixd.mission.model import Mission
from helixd.mission.resolve import resolve_plan
from helixd.runtime.flight import PoseRejectedReport, StepOutput, StepReport
from helixd.runtime.flight_report import flight_row, rejected_progress, step_progress

CFG = HelixdConfig()


def plan_of(*points: tuple[float, float]) -> Plan:
    wps = [{"x": x, "y": y} for x, y in points]
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": wps}
    )
    return resolve_plan(mission, CFG.control, CFG.mission, None)


def report_at(plan: Plan, x_m: float, y_m: float, *, now_s: float = 5.0) -> StepReport:
    """One step at mission-frame (x_m, y_m) facing +x, moving north-east at (0.3, 0.4) m/s."""
    nav = Navigator(plan, CFG.control).step(Pose2D(x_m, y_m, 0.0), now_s)
    step = StepOutput(
        fractions=(0.1, -0.2, 0.3, -0.4),
        nav=nav,
        command=BodyVelocity(0.25, 0.0, 0.05),
        mpose=Pose2D(x_m, y_m, 0.0),
        slip=SlipEstimate(0.9, 1.0, 0.8),
        motion_mode="roll",
    )
    sample = PoseSample(NedPose(y_m, x_m, math.pi / 2), 12_345, now_s, 0.3, 0.4, 0.0)
    pwm = (1600, 1400, 1700, 1300)
    return StepReport(sample, step, pwm, now_s, 2.5, True, "MANUAL", True, True)


def test_the_row_carries_the_target_the_command_and_the_pose() -> None:
    plan = plan_of((10.0, 0.0), (10.0, 10.0))
    report = report_at(plan, 2.0, 0.0)
    row = flight_row(report, plan)
    assert (row.t_boot_s, row.t_mono_s) == (12.345, 5.0)
    assert (row.north_m, row.east_m, row.x_m, row.y_m) == (0.0, 2.0, 2.0, 0.0)
    assert (row.target_index, row.target_x_m, row.target_y_m) == (0, 10.0, 0.0)
    assert row.distance_error_m == pytest.approx(8.0)
    nav = report.step.nav.command  # the navigator's command, before the slip feed-forward
    assert (row.vx_cmd_mps, row.vy_cmd_mps, row.wz_cmd_radps) == (
        nav.vx_mps,
        nav.vy_mps,
        nav.wz_radps,
    )
    assert row.nav_state == report.step.nav.state.value
    assert row.speed_meas_mps == pytest.approx(0.5)  # hypot(0.3, 0.4)
    assert (row.scroll1, row.scroll4, row.pwm2_us, row.pwm3_us) == (0.1, -0.4, 1400, 1700)
    assert (row.slip_vx_frac, row.slip_w_frac) == (0.9, 0.8)
    assert (row.mode, row.armed, row.motion_mode, row.medium) == ("MANUAL", True, "roll", "")


def test_the_row_names_the_medium_under_the_pose() -> None:
    plan = plan_of((10.0, 0.0))
    asked: list[tuple[float, float]] = []

    def medium_at(north_m: float, east_m: float) -> str:
        asked.append((north_m, east_m))
        return "water" if east_m > 1.0 else "hard"

    assert flight_row(report_at(plan, 2.0, 0.0), plan, medium_at).medium == "water"
    assert flight_row(report_at(plan, 0.5, 0.0), plan, medium_at).medium == "hard"
    assert asked == [(0.0, 2.0), (0.0, 0.5)]  # asked in NED, where the rover is


def test_progress_is_numbered_as_the_operator_numbers_waypoints() -> None:
    plan = plan_of((10.0, 0.0), (10.0, 10.0))
    numbering = Numbering.of([True, False], first=3, total=5)  # a via point, then waypoint 3
    got = step_progress(report_at(plan, 2.0, 0.0), numbering)
    assert (got.waypoint_index, got.waypoints_total, got.via) == (3, 5, True)
    assert got.distance_to_go_m == pytest.approx(8.0)
    assert got.speed_mps == pytest.approx(0.5)
    assert (got.phase, got.pose_fresh, got.elapsed_s) == ("fly", True, 2.5)


def test_progress_while_the_pose_is_rejected_says_nothing_it_cannot_know() -> None:
    numbering = Numbering.of([False, False])
    got = rejected_progress(PoseRejectedReport(1, 7.0, False), numbering)
    assert (got.waypoint_index, got.waypoints_total, got.via) == (2, 2, False)
    assert math.isnan(got.distance_to_go_m) and math.isnan(got.speed_mps)
    assert math.isnan(got.heading_error_deg)
    assert (got.pose_fresh, got.link_ok, got.nav_state) == (False, False, "pose_invalid")
