"""Arming: a PreArm refusal explained in the crew's terms (what the throttle channel must read),
any other refusal passed on as it came; no start switch, no wait."""

from __future__ import annotations

import asyncio
from typing import cast

import pytest

from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandRejected
from helixd.link.vehicle import Change
from helixd.report.notify import ServiceNotifier
from helixd.runtime.arming import explain_arm_refusal, start_gate
from helixd.runtime.signals import StopRequest
from tests.support.peer import linked


def test_a_refusal_not_about_the_throttle_is_passed_on_as_it_came() -> None:
    refused = CommandRejected("COMPONENT_ARM_DISARM", 4, "PreArm: GPS 1: Bad fix")
    unused = cast(Autopilot, None)  # nothing to read: the autopilot is never asked
    assert asyncio.run(explain_arm_refusal(unused, refused)) is refused


def test_no_start_switch_no_wait() -> None:
    cfg = HelixdConfig()
    assert cfg.startup.start_switch_channel is None
    unused = cast(Autopilot, None)  # returns before it reads the link
    asyncio.run(start_gate(unused, cfg, StopRequest(), ServiceNotifier()))


async def test_a_throttle_not_neutral_refusal_says_what_the_channel_must_read() -> None:
    """The crew's arm after `autopilot check`: RC5 (RCMAP_THROTTLE) rests high. The refusal
    says what RC5 must read and what it reads, and points nowhere near startup.force_arm."""
    async with linked(command_timeout_s=0.2, command_retries=1) as (ap, peer):
        peer.prearm_text = "Arm: Throttle (RC5) is not neutral"
        peer.rc_in[4] = 1900
        peer.params.update({"RC5_TRIM": 1500.0, "RC5_DZ": 30.0})
        assert await ap.telemetry.wait_for(
            lambda st: st.rc_inputs_us[4:5] == (1900,), Change.RC, 5.0
        )
        with pytest.raises(CommandRejected) as raised:
            await ap.action.arm(force=False)
        assert "force" not in str(raised.value)
        explained = str(await explain_arm_refusal(ap, raised.value))
    assert (
        "RC5 (RCMAP_THROTTLE) must read its trim RC5_TRIM = 1500 µs ± RC5_DZ = 30 µs "
        "(1470–1530 µs) to arm; it reads 1900 µs — put the stick or switch on RC5"
    ) in explained
    assert "'Arm: Throttle (RC5) is not neutral'" in explained
    assert "force" not in explained
