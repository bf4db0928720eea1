"""COMMAND_LONG ack matching and parameters against a peer that answers late, twice, never."""

from __future__ import annotations

import asyncio
import math
import time
from typing import Any

import pytest
import structlog
import structlog.testing
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.link.services.command_client import CommandClient, CommandRejected, CommandTimeout
from helixd.link.vehicle import VehicleState
from tests.support.peer import DENIED, FAILED, Reply, linked, until

SET_MODE = mavlink.MAV_CMD_DO_SET_MODE
ARM = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
HOLD = (1, 4)


async def test_late_answer_is_taken_and_its_twin_does_not_satisfy_the_next_command() -> None:
    async with linked(command_timeout_s=0.25, command_retries=2) as (ap, peer):
        # every try answered 0.35 s late: the first try's ack arrives after the re-send
        peer.set_reply(SET_MODE, Reply(delay_s=0.35))
        t0 = time.monotonic()
        assert await ap.action.command_long(SET_MODE, HOLD) == mavlink.MAV_RESULT_ACCEPTED
        tries = peer.records.commands_of(SET_MODE, t0)
        assert [c.confirmation for c in tries] == [0, 1]  # re-sent once, confirmation counted
        # the re-send's own (late) ack is still on its way; the next command gets no answer
        peer.set_reply(SET_MODE, Reply(result=None))
        with pytest.raises(CommandTimeout) as info:
            await ap.action.command_long(SET_MODE, HOLD)
        assert "MAV_CMD_DO_SET_MODE" in str(info.value)
        assert ap.ack_stats.duplicates >= 1


async def test_duplicated_ack_does_not_satisfy_the_next_command() -> None:
    async with linked(command_settle_s=0.05) as (ap, peer):
        peer.set_reply(SET_MODE, Reply(copies=2))  # two identical acks back to back
        assert await ap.action.command_long(SET_MODE, HOLD) == mavlink.MAV_RESULT_ACCEPTED
        peer.set_reply(SET_MODE, Reply(result=DENIED))
        with pytest.raises(CommandRejected) as info:
            await ap.action.command_long(SET_MODE, HOLD)  # must see DENIED, not the stale ACCEPTED
        assert info.value.result_name == "DENIED"
        await until(
            lambda: ap.ack_stats.unexpected + ap.ack_stats.duplicates >= 1,
            2.0,
            "the duplicate ack to be discarded",
        )


async def test_never_answered_gives_bounded_retries_then_timeout_naming_the_command() -> None:
    async with linked(command_timeout_s=0.2, command_retries=2) as (ap, peer):
        peer.set_reply(SET_MODE, Reply(result=None))
        t0 = time.monotonic()
        with pytest.raises(CommandTimeout) as info:
            await ap.action.command_long(SET_MODE, HOLD)
        elapsed = time.monotonic() - t0
        assert info.value.command_name == "MAV_CMD_DO_SET_MODE"
        assert info.value.tries == 3
        assert 0.55 <= elapsed < 2.0
        assert len(peer.records.commands_of(SET_MODE, t0)) == 3
        # the link is still usable for the same command afterwards
        peer.set_reply(SET_MODE, None)
        await ap.action.set_mode("HOLD")
        await until(lambda: ap.state.mode == "HOLD", 2.0, "HOLD in the heartbeat")


@pytest.mark.parametrize(("result", "name"), [(DENIED, "DENIED"), (FAILED, "FAILED")])
async def test_refusals_carry_the_result_name(result: int, name: str) -> None:
    async with linked() as (ap, peer):
        peer.set_reply(SET_MODE, Reply(result=result))
        with pytest.raises(CommandRejected) as info:
            await ap.action.set_mode("GUIDED")
        assert info.value.result_name == name
        assert name in str(info.value)


async def test_unknown_command_is_unsupported() -> None:
    async with linked() as (ap, _peer):
        with pytest.raises(CommandRejected) as info:
            await ap.action.command_long(31337, ())
        assert info.value.result_name == "UNSUPPORTED"
        assert "31337" in info.value.command_name


async def test_arm_refusal_carries_the_prearm_statustext_and_force_arms() -> None:
    async with linked() as (ap, peer):
        peer.prearm_text = "PreArm: Hardware safety switch"
        with pytest.raises(CommandRejected) as info:
            await ap.action.arm(force=False)
        assert info.value.result_name == "FAILED"
        assert info.value.statustext == "PreArm: Hardware safety switch"
        assert "PreArm: Hardware safety switch" in str(info.value)
        with structlog.testing.capture_logs() as logs:
            await ap.action.arm(force=True)
        normal, forced = peer.records.commands_of(ARM)[-2:]
        assert normal.params[:2] == (1.0, 0.0)  # force only after a normal arm is refused
        assert forced.params[:2] == (1.0, 21196.0)
        warned = [e for e in logs if e["event"] == "arm_forced"]
        assert warned and warned[0]["log_level"] == "warning"
        assert warned[0]["overrides"] == "PreArm: Hardware safety switch"
        await until(lambda: ap.state.armed, 2.0, "armed in the heartbeat")
        await ap.action.disarm()
        await until(lambda: not ap.state.armed, 2.0, "disarmed in the heartbeat")


async def test_set_mode_by_name_and_unknown_name() -> None:
    async with linked() as (ap, peer):
        await ap.action.set_mode("hold")
        sent = peer.records.commands_of(SET_MODE)[-1]
        assert sent.params[:2] == (float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), 4.0)
        await until(lambda: ap.state.mode == "HOLD" and ap.state.custom_mode == 4, 2.0, "HOLD")
        with pytest.raises(ValueError, match="SMART_RTL"):
            await ap.action.set_mode("WARP")


async def test_params_get_set_and_missing() -> None:
    async with linked(command_timeout_s=0.15, command_retries=1) as (ap, peer):
        assert await ap.param.get("RC_OVERRIDE_TIME") == 3.0
        assert await ap.param.get("SYSID_MYGCS") is None  # gone in current ArduPilot
        assert await ap.param.set("RC_OVERRIDE_TIME", 2.0) == 2.0
        assert peer.params["RC_OVERRIDE_TIME"] == 2.0
        with pytest.raises(CommandTimeout, match="PARAM_SET NO_SUCH_PARAM"):
            await ap.param.set("NO_SUCH_PARAM", 1.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
async def test_non_finite_param_reads_as_unreadable(bad: float) -> None:
    async with linked(command_timeout_s=0.15, command_retries=1) as (ap, peer):
        peer.params["MAV_GCS_SYSID"] = bad
        started = time.monotonic()
        assert await ap.param.get("MAV_GCS_SYSID") is None
        assert time.monotonic() - started < 0.15  # answered, not timed out
        assert await ap.param.get("RC_OVERRIDE_TIME") == 3.0


async def test_gps_origin_on_request() -> None:
    async with linked() as (ap, peer):
        assert await ap.action.request_gps_origin(2.0) == pytest.approx((45.0, -73.0))
        peer.origin = None  # no EKF origin yet: the autopilot says FAILED
        assert await ap.action.request_gps_origin(2.0) is None


async def test_a_stop_in_the_same_loop_turn_as_the_answer_is_not_swallowed() -> None:
    """The answer and a cancellation of the waiting task in one loop iteration (SITL sends the
    ACK and the HEARTBEAT that makes helixd stop in one TCP segment): the task is cancelled.
    ``asyncio.wait_for(shield(...))`` on Python 3.11 returned the answer instead, and the
    servo sender kept running until the fall-back's 0.5 s deadline."""
    cfg = LinkConfig()
    sent: list[Any] = []
    client = CommandClient(
        lambda: mavlink.MAVLink(None, cfg.source_system, cfg.source_component),
        lambda msg: sent.append(msg) is None,
        cfg,
        VehicleState(),
    )
    task = asyncio.create_task(client.exchange(SET_MODE, HOLD))
    await until(lambda: len(sent) == 1, 1.0, "the command sent")
    ack = mavlink.MAVLink(None, cfg.target_system, cfg.target_component)
    msg = ack.decode(
        bytearray(
            mavlink.MAVLink_command_ack_message(
                SET_MODE, 0, 0, 0, cfg.source_system, cfg.source_component
            ).pack(ack)
        )
    )
    client.on_message(msg, time.monotonic())  # the answer …
    task.cancel()  # … and the stop, before the task runs again
    with pytest.raises(asyncio.CancelledError):
        await task
    assert client.stats.matched == 1


async def test_a_refusals_text_that_trails_the_ack_is_waited_for() -> None:
    """ArduPilot queues the STATUSTEXT explaining a refusal and sends it after the COMMAND_ACK
    ("ServoRelayEvent: Channel 5 is already in use"): refusal_text waits for it a moment."""
    servo = mavlink.MAV_CMD_DO_SET_SERVO
    async with linked() as (ap, peer):
        peer.set_reply(servo, Reply(result=FAILED))
        since = time.monotonic()
        with pytest.raises(CommandRejected) as info:
            await ap.action.command_long(servo, (5, 1500))
        assert info.value.statustext is None  # nothing said yet when the ack came
        peer.statustext("ServoRelayEvent: Channel 5 is already in use", severity=6)
        text = await ap.action.refusal_text(since, "ServoRelayEvent")
        assert text == "ServoRelayEvent: Channel 5 is already in use"
        assert await ap.action.refusal_text(time.monotonic(), "ServoRelayEvent") is None


async def test_force_arm_is_not_used_when_a_normal_arm_passes() -> None:
    async with linked() as (ap, peer):
        with structlog.testing.capture_logs() as logs:
            await ap.action.arm(force=True)
        assert [c.params[:2] for c in peer.records.commands_of(ARM)] == [(1.0, 0.0)]
        assert not [e for e in logs if e["event"] == "arm_forced"]
        await until(lambda: ap.state.armed, 2.0, "armed in the heartbeat")


async def test_no_motor_outputs_refusal_names_the_helix_setup() -> None:
    async with linked() as (ap, peer):
        peer.prearm_text = "PreArm: no motor, sail or scripting outputs defined"
        with pytest.raises(CommandRejected) as info:
            await ap.action.arm()
        assert "SERVOn_FUNCTION = 94 (Script1)" in str(info.value)
        assert "`helixd autopilot check` names it" in str(info.value)
