"""udpout: we speak first (the autopilot side learns our address from what we send)."""

from __future__ import annotations

from helixd.link.connection import Autopilot
from tests.support.peer import HELIXD_SYSID, AutopilotPeer, UdpWire, link_config, safety_config


async def test_udpout_link_announces_itself_and_gets_answers() -> None:
    peer = AutopilotPeer(lambda port: UdpWire(port, target=None))  # answers the last sender
    peer.start()
    ap = await Autopilot.connect(link_config(url=f"udpout:127.0.0.1:{peer.port}"), safety_config())
    try:
        await ap.wait_heartbeat(3.0)  # only arrives because wait_heartbeat announced us
        assert [h for h in peer.records.gcs_heartbeats if h[1] == HELIXD_SYSID]
        granted = await ap.request_streams()
        assert granted["LOCAL_POSITION_NED"] == 40.0
    finally:
        await ap.close()
        peer.stop()
