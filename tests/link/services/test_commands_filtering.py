"""Only the target system is listened to; what it says lands in VehicleState."""

from __future__ import annotations

import asyncio
import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.services.command_client import CommandTimeout
from helixd.mav.constants import EKF_ATTITUDE, EKF_CONST_POS_MODE, EKF_VELOCITY_HORIZ
from tests.support.peer import Reply, linked, until

SET_MODE = mavlink.MAV_CMD_DO_SET_MODE


async def test_other_systems_are_counted_and_dropped() -> None:
    async with linked() as (ap, peer):
        await ap.request_streams()
        await until(lambda: ap.state.pose is not None, 3.0, "a pose")
        for _ in range(3):  # another vehicle on the same network, armed, in HOLD
            peer.send_as(42, 1, lambda c: c.heartbeat_encode(10, 3, 129, 4, 4))
            peer.send_as(42, 1, lambda c: c.local_position_ned_encode(1, 999.0, 999.0, 0, 0, 0, 0))
            peer.send_as(42, 1, lambda c: c.statustext_encode(2, b"not for us"))
        await until(lambda: ap.state.foreign_sysid_counts.get(42, 0) >= 9, 3.0, "9 from sys 42")
        st = ap.state
        assert st.mode == "MANUAL" and not st.armed
        assert st.pose is not None and st.pose.ned.north_m < 100.0
        assert all(t.text != "not for us" for t in st.statustexts)


async def test_an_ack_from_another_system_does_not_answer_our_command() -> None:
    async with linked(command_timeout_s=0.2, command_retries=1) as (ap, peer):
        peer.set_reply(SET_MODE, Reply(result=None))
        for _ in range(4):
            peer.send_as(42, 1, lambda c: c.command_ack_encode(SET_MODE, 0, 0, 0, 255, 191))
        with pytest.raises(CommandTimeout):
            await ap.action.command_long(SET_MODE, (1, 4))


async def test_other_components_of_the_autopilot_do_not_set_the_mode() -> None:
    async with linked() as (ap, peer):
        # a gimbal (component 154) of system 1 with its own heartbeat
        for _ in range(3):
            peer.send_as(1, 154, lambda c: c.heartbeat_encode(26, 0, 129, 4, 4))
        peer.statustext("PreArm: gimbal not ready")
        await until(
            lambda: any("gimbal" in t.text for t in ap.state.statustexts),
            2.0,
            "the statustext (any component may speak)",
        )
        assert ap.state.mode == "MANUAL" and not ap.state.armed


async def test_state_from_the_autopilot() -> None:
    async with linked() as (ap, peer):
        await ap.request_streams()
        await until(
            lambda: (
                ap.state.pose is not None
                and ap.state.ekf is not None
                and bool(ap.state.rc_inputs_us)
                and bool(ap.state.servo_outputs_us)
            ),
            3.0,
            "pose, EKF, RC and servo state",
        )
        st = ap.state
        assert st.pose is not None
        assert math.isclose(st.pose.vn_mps, 0.1, rel_tol=1e-5)
        assert st.ekf is not None and st.ekf.healthy
        assert len(st.rc_inputs_us) == 18 and st.rc_inputs_us[0] == 1500
        assert st.rc_rssi is None  # 255 = unknown
        assert len(st.servo_outputs_us) == 16
        assert st.battery_voltage_v == pytest.approx(12.6)
        peer.ekf_flags = EKF_ATTITUDE | EKF_VELOCITY_HORIZ | EKF_CONST_POS_MODE  # no aiding
        await until(
            lambda: ap.state.ekf is not None and not ap.state.ekf.healthy, 3.0, "EKF unhealthy"
        )
        assert ap.state.ekf is not None
        assert "constant-position" in ap.state.ekf.describe()
        poses = ap.telemetry.pose()
        first = await asyncio.wait_for(anext(poses), 2.0)  # a new pose, streamed
        second = await asyncio.wait_for(anext(poses), 2.0)
        assert second.rx_monotonic_s > first.rx_monotonic_s  # none is yielded twice
        await poses.aclose()
