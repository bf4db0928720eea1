"""The supervisor's snapshot of the vehicle state for the watchdogs (pure)."""

from __future__ import annotations

import asyncio
import math

import pytest

from helixd.base.frames import NedPose
from helixd.config.safety import SafetyConfig
from helixd.link.vehicle import VehicleState
from helixd.safety.supervisor import Motion, Supervisor, fall_back, safety_inputs
from helixd.safety.watchdogs import Fault, FaultCause
from tests.support.mavmsgs import AP, att, decoded, hb, lpn

MOTION = Motion(0.5, 0.1, 0.05, 12.0)


def flying_state() -> VehicleState:
    st = VehicleState()
    st.apply(hb(0, armed=True), 1.0)
    st.apply(decoded(AP.ekf_status_report_encode(0x3F, 0.1, 0.1, 0.1, 0.05, 0.0), AP), 1.0)
    st.apply(att(1000, 0.3), 1.0)
    st.apply(lpn(1000, 3.0, 4.0), 1.0)
    return st


def test_snapshot_carries_state_pose_and_motion() -> None:
    st = flying_state()
    s = safety_inputs(1.1, st, st.pose, NedPose(1.0, 2.0, 0.0), "MANUAL", MOTION)
    assert (s.north_m, s.east_m, s.start_north_m, s.start_east_m) == (3.0, 4.0, 1.0, 2.0)
    assert s.measured_speed_mps == pytest.approx(math.hypot(0.5, -0.2))  # float32 on the wire
    assert (s.commanded_speed_mps, s.commanded_yaw_rate_radps) == (0.5, 0.1)
    assert (s.measured_yaw_rate_radps, s.mission_elapsed_s) == (0.05, 12.0)
    assert s.vehicle_time_s == 1.0 and s.mode == "MANUAL" and s.armed
    assert s.ekf_healthy is True and s.ekf_detail == ""  # the text is built only when unhealthy


def test_unhealthy_ekf_is_described_and_reported() -> None:
    st = flying_state()
    st.apply(decoded(AP.ekf_status_report_encode(0x1 | 0x80, 0.1, 0.1, 0.1, 0.05, 0.0), AP), 1.05)
    s = safety_inputs(1.1, st, st.pose, NedPose(3.0, 4.0, 0.0), "MANUAL", MOTION)
    assert s.ekf_healthy is False and "constant-position" in s.ekf_detail
    fault = Supervisor(SafetyConfig(), NedPose(3.0, 4.0, 0.0), "MANUAL").check(
        1.1, st, st.pose, MOTION
    )
    assert fault is not None and fault.cause is FaultCause.EKF_UNHEALTHY
    assert "constant-position" in fault.detail


def test_no_pose_yet() -> None:
    st = VehicleState()
    s = safety_inputs(5.0, st, None, NedPose(0.0, 0.0, 0.0), "MANUAL", MOTION)
    assert s.north_m is None and s.pose_rx_s is None and s.measured_speed_mps == 0.0
    assert s.vehicle_time_s is None and s.ekf_healthy is None


class FakeSink:
    def __init__(self, calls: list[str]) -> None:
        self.calls = calls

    async def stop(self) -> None:
        self.calls.append("stop")


class FakeAutopilot:
    def __init__(self, calls: list[str]) -> None:
        self.calls = calls

    async def set_mode(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> None:
        self.calls.append(f"mode {name}")

    async def disarm(self, force: bool = False) -> None:
        self.calls.append("disarm")


@pytest.mark.parametrize(
    ("cause", "calls"),
    [
        (FaultCause.PILOT_TAKEOVER, ["stop", "mode HOLD"]),
        (FaultCause.PAUSED, ["stop", "mode HOLD"]),
        # a flight of AUTO released to the pilot (MANUAL): no HOLD taking it from the pilot
        (FaultCause.RELEASED, ["stop"]),
        # the crew set the autopilot's current item: the next flight of AUTO goes there
        (FaultCause.ITEM_SET, ["stop"]),
        # the crew gave the autopilot a new place (Go to location): the next flight drives
        (FaultCause.HANDOVER, ["stop"]),
    ],
)
def test_fall_back_stops_and_asks_hold_except_for_a_release(
    cause: FaultCause, calls: list[str]
) -> None:
    seen: list[str] = []
    report = asyncio.run(
        fall_back(
            Fault(cause, "x"),
            sink=FakeSink(seen),
            autopilot=FakeAutopilot(seen),
            cfg=SafetyConfig(),
            detected_s=0.0,
            pose_text="here",
            disarm=False,
        )
    )
    assert seen == calls
    no_hold = cause in (FaultCause.RELEASED, FaultCause.ITEM_SET, FaultCause.HANDOVER)
    assert (report.hold_requested_after_s is None) is no_hold


class SilentAutopilot(FakeAutopilot):
    """A cut link: every HOLD request goes unanswered."""

    async def set_mode(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> None:
        self.calls.append(f"mode {name}")
        await asyncio.sleep(0)
        raise TimeoutError("no answer")


def test_a_hold_unanswered_is_told_once_with_its_count() -> None:
    seen: list[str] = []
    report = asyncio.run(
        fall_back(
            Fault(FaultCause.LINK_LOST, "closed by the other end"),
            sink=FakeSink(seen),
            autopilot=SilentAutopilot(seen),
            cfg=SafetyConfig(hold_retry_bound_s=0.05),
            detected_s=0.0,
            pose_text="here",
            disarm=False,
        )
    )
    tries = seen.count("mode HOLD")
    assert tries >= 2  # asked again and again until the bound, as before
    assert report.errors == [f"HOLD request: no answer ({tries} tries)"]
    assert not report.hold_acked


def test_supervisor_inputs_name_the_links_cause() -> None:
    st = flying_state()
    st.mark_link_lost("closed by the other end")
    inputs = safety_inputs(1.1, st, st.pose, NedPose(0.0, 0.0, 0.0), "MANUAL", MOTION)
    assert inputs.link_lost_cause == "closed by the other end"
    assert inputs.last_rx_s is not None
