"""Preflight's GPS verdict on a vehicle state fed as the link's reader feeds it."""

from __future__ import annotations

import asyncio
import time
from typing import Any

from helixd.config.root import HelixdConfig
from helixd.runtime.setup import gps_verdict
from tests.support.feed import Feed, still_pending
from tests.support.mavmsgs import AP, decoded

CFG = HelixdConfig()


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
