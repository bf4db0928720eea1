"""The setup phases' pure parts: the plan placed from the rover (and the autopilot's home);
preflight's GPS verdict on a vehicle state fed as the link's reader feeds it."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import pytest

from helixd.base.frames import NedPose
from helixd.base.plan import MissionFrameKind
from helixd.config.root import HelixdConfig
from helixd.link.services.command_client import CommandRejected
from helixd.link.vehicle import Change, HomePosition
from helixd.mission.expand import DEFAULT_OPTIONS
from helixd.mission.model import Mission
from helixd.runtime.arming import explain_arm_refusal
from helixd.runtime.placing import mission_frame, resolve_flight
from helixd.runtime.setup import PreflightFailed, gps_verdict
from tests.support.feed import Feed, still_pending
from tests.support.mavmsgs import AP, decoded
from tests.support.peer import linked

CFG = HelixdConfig()
RETURNS = Mission.model_validate(
    {
        "name": "out and home",
        "mode": "roll",
        "frame": "local_ned",
        "waypoints": [{"north": 5, "east": 0}, {"command": "NAV_RETURN_TO_LAUNCH"}],
    }
)
HERE = NedPose(1.0, 2.0, 0.0)


def test_a_return_home_without_the_autopilots_home_is_refused() -> None:
    with pytest.raises(PreflightFailed, match="NAV_RETURN_TO_LAUNCH"):
        resolve_flight(RETURNS, CFG, None, HERE, None, DEFAULT_OPTIONS)


def test_a_return_home_ends_at_the_autopilots_home() -> None:
    home = HomePosition(53.5, -113.5, -3.0, 4.0)
    plan, where = resolve_flight(RETURNS, CFG, None, HERE, home, DEFAULT_OPTIONS)
    assert where.home_xy_m == (4.0, -3.0)  # x east, y north
    assert where.start_xy_m == (2.0, 1.0)
    last = plan.waypoints[-1]
    assert (last.x_m, last.y_m) == (4.0, -3.0)


def test_a_start_mission_is_framed_at_the_rover() -> None:
    start = Mission.model_validate(
        {"name": "s", "mode": "roll", "frame": "start", "waypoints": [{"x": 1, "y": 0}]}
    )
    assert start.frame is MissionFrameKind.START
    frame = mission_frame(start, HERE)
    assert frame.to_ned(0.0, 0.0)[:2] == pytest.approx((1.0, 2.0))
    assert mission_frame(RETURNS, HERE).to_ned(0.0, 0.0)[:2] == pytest.approx((0.0, 0.0))


# -- preflight's GPS verdict: the first good GPS_RAW_INT may follow the first fresh pose --------


def gps_raw(time_usec: int, fix_type: int, satellites: int) -> Any:
    return decoded(
        AP.gps_raw_int_encode(time_usec, fix_type, 0, 0, 0, 100, 100, 0, 0, satellites), AP
    )


def test_preflight_waits_for_the_first_good_gps_report_within_the_stale_limit() -> None:
    """The simulator and ArduPilot send GPS_RAW_INT at 5 Hz and the pose at 40 Hz: the GPS
    still says "no fix" when the pose is first fresh. The verdict is taken when a good
    report arrives, not at once."""

    async def main() -> None:
        feed = Feed()
        feed.rx(gps_raw(0, 1, 0))  # before the fix: ArduPilot's report with no fix
        verdict = asyncio.ensure_future(gps_verdict(feed.state, feed.telemetry, CFG.safety))
        assert await still_pending(verdict)
        feed.rx(gps_raw(5_000_000, 3, 12))
        assert await asyncio.wait_for(verdict, 1.0) is None

    asyncio.run(main())


def test_preflight_refuses_a_gps_without_a_fix_after_the_stale_limit() -> None:
    safety = CFG.safety.model_copy(update={"gps_stale_s": 0.1})

    async def main() -> None:
        feed = Feed()
        feed.rx(gps_raw(0, 1, 0))

        async def reports() -> None:  # the stream goes on, still without a fix
            while True:
                await asyncio.sleep(0.02)
                feed.rx(gps_raw(0, 1, 0))

        sender = asyncio.ensure_future(reports())
        t0 = time.monotonic()
        fault = await asyncio.wait_for(gps_verdict(feed.state, feed.telemetry, safety), 2.0)
        waited_s = time.monotonic() - t0
        sender.cancel()
        assert fault is not None and "fix_type 1" in fault.detail
        assert 0.09 <= waited_s < 1.0  # waited for the grace, not the whole connect timeout

    asyncio.run(main())


def test_a_gps_that_never_reported_is_refused_by_name() -> None:
    safety = CFG.safety.model_copy(update={"gps_stale_s": 0.05})

    async def main() -> None:
        feed = Feed()
        fault = await gps_verdict(feed.state, feed.telemetry, safety)
        assert fault is not None and fault.detail == "no GPS_RAW_INT received"

    asyncio.run(main())


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
