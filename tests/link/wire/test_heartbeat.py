"""Our HEARTBEAT flows only while the daemon's loop feeds it."""

from __future__ import annotations

import contextlib
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.support.peer import HELIXD_SYSID, AutopilotPeer, linked, stays, until


def ours(peer: AutopilotPeer, after_t: float = 0.0) -> list[tuple[float, int, int]]:
    return [
        h for h in list(peer.records.gcs_heartbeats) if h[0] >= after_t and h[1] == HELIXD_SYSID
    ]


async def test_heartbeat_only_while_fed() -> None:
    async with linked(heartbeat_rate_hz=10.0, heartbeat_liveness_s=0.5) as (ap, peer):
        await stays(lambda: ours(peer) == [], 0.3, "no heartbeat before start_heartbeat()")
        ap.start_heartbeat()
        t0 = time.monotonic()
        # the daemon's loop: woken by each pose or every 0.05 s without one, feeding each time
        async with contextlib.aclosing(ap.telemetry.pose_or_tick(0.05)) as ticks:
            async for _ in ticks:
                ap.feed()
                if time.monotonic() - t0 >= 1.0:
                    break
        t_last_feed = time.monotonic()
        beats = ours(peer, t0)
        assert 7 <= len(beats) <= 14  # ~10 Hz
        assert all(b[2] == mavlink.MAV_TYPE_GCS for b in beats)
        # the loop "hangs": heartbeats stop after the liveness window (+ one period)
        silent_from = t_last_feed + 0.5 + 0.1 + 0.15
        await until(lambda: time.monotonic() > silent_from, 2.0, "liveness window to pass")
        await stays(lambda: ours(peer, silent_from) == [], 0.6, "heartbeat silence")
        # the loop recovers
        ap.feed()
        t_resume = time.monotonic()
        await until(lambda: len(ours(peer, t_resume)) >= 2, 2.0, "heartbeats to resume")
        ap.stop_heartbeat()
        t_stop = time.monotonic() + 0.05
        ap.feed()
        await stays(lambda: ours(peer, t_stop) == [], 0.5, "silence after stop_heartbeat()")


async def test_onboard_controller_type_is_selectable() -> None:
    async with linked(heartbeat_rate_hz=10.0, heartbeat_type="onboard_controller") as (ap, peer):
        ap.start_heartbeat()
        await until(lambda: len(ours(peer)) >= 2, 2.0, "heartbeats")
        assert ours(peer)[-1][2] == mavlink.MAV_TYPE_ONBOARD_CONTROLLER
        ap.stop_heartbeat()
