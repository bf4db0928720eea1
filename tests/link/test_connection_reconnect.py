"""The link comes back by itself: peer restart (UDP), reboot, TCP drop, serial device gone."""

from __future__ import annotations

import time
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.connection import Autopilot
from tests.support.peer import (
    AutopilotPeer,
    TcpServerWire,
    link_config,
    linked,
    pty_peer,
    safety_config,
    tcp_peer,
    until,
)

SET_INTERVAL = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
LPN = mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED


def rerequested(peer: AutopilotPeer, after_t: float) -> bool:
    return any(int(c.params[0]) == LPN for c in peer.records.commands_of(SET_INTERVAL, after_t))


async def lost_then_back(ap: Autopilot, peer: AutopilotPeer, restart: bool) -> None:
    """Common tail: link marked lost, peer back, link regained, streams asked again."""
    await until(lambda: ap.state.link_lost, 3.0, "link marked lost")
    assert ap.state.link_lost_count == 1
    t_back = time.monotonic()
    if restart:
        peer.start()
    await until(lambda: not ap.state.link_lost, 5.0, "link regained")
    assert ap.state.link_lost_count == 1
    await until(lambda: rerequested(peer, t_back), 5.0, "streams re-requested")
    pose = await ap.telemetry.next_pose(after_rx_s=time.monotonic(), timeout_s=3.0)
    assert pose is not None


async def test_udp_peer_stops_and_restarts_on_the_same_port() -> None:
    async with linked() as (ap, peer):
        await ap.request_streams()
        port = peer.port
        peer.stop()
        await lost_then_back(ap, peer, restart=True)
        assert peer.port == port


async def test_autopilot_reboot_is_detected_from_time_boot_ms() -> None:
    async with linked() as (ap, peer):
        await ap.request_streams()
        await until(lambda: (ap.state.last_time_boot_ms or 0) > 1500, 5.0, "1.5 s of uptime")
        t_reboot = time.monotonic()
        peer.reboot()  # no heartbeat gap at all: only time_boot_ms tells
        await until(lambda: ap.state.reboot_count == 1, 3.0, "reboot detected")
        assert ap.state.link_lost_count == 1 and not ap.state.link_lost
        await until(lambda: rerequested(peer, t_reboot), 3.0, "streams re-requested")
        await until(
            lambda: ap.granted_rates_hz.get("LOCAL_POSITION_NED") == 40.0,
            3.0,
            "pose rate granted again",
        )


async def test_tcp_connection_dropped_by_the_autopilot_is_reopened() -> None:
    peer = tcp_peer()
    peer.start()
    cfg = link_config(url=f"tcp:127.0.0.1:{peer.port}", reconnect_interval_s=0.2)
    ap = await Autopilot.connect(cfg, safety_config())
    try:
        await ap.wait_heartbeat(5.0)
        await ap.request_streams()

        def drop(wire: object) -> None:
            assert isinstance(wire, TcpServerWire)
            wire.drop_client()

        peer.call_soon(drop)
        await lost_then_back(ap, peer, restart=False)
        assert ap.link_stats.reopen_count >= 1
        # the cause the watchdogs name at once (a pulled cable), kept for the record
        assert ap.state.link_lost_cause == "closed by the other end"
    finally:
        await ap.close()
        peer.stop()


async def test_serial_device_that_vanishes_and_returns(tmp_path: Path) -> None:
    device = tmp_path / "ttyAutopilot"
    peer = pty_peer(device)
    peer.start()
    ap = await Autopilot.connect(link_config(url=f"{device}:921600"), safety_config())
    try:
        await ap.wait_heartbeat(5.0)
        await ap.request_streams()
        peer.stop()  # USB unplugged: the tty closes and its /dev name disappears
        await until(lambda: ap.state.link_lost, 3.0, "link marked lost")
        await until(
            lambda: ap.link_stats.reopen_count == 0 and not device.exists(),
            1.0,
            "device gone, no reopen possible",
        )
        await lost_then_back(ap, peer, restart=True)
        assert ap.link_stats.reopen_count == 1
    finally:
        await ap.close()
        peer.stop()
