"""An observer link (every command but `run`): it speaks as link.observer_system and never
sends what ArduPilot counts as contact with its GCS (HEARTBEAT, RC override, MANUAL_CONTROL)."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.connection import Autopilot
from helixd.link.wire.codec import NeverSent
from helixd.mav.constants import MAV_CMD_REQUEST_MESSAGE
from tests.support.peer import AutopilotPeer, UdpWire, link_config, safety_config

OBSERVER = 248


async def test_an_observer_on_udpout_announces_itself_without_a_heartbeat() -> None:
    peer = AutopilotPeer(lambda port: UdpWire(port, target=None))  # answers the last sender
    peer.start()
    cfg = link_config(url=f"udpout:127.0.0.1:{peer.port}")
    ap = await Autopilot.connect(cfg, safety_config(), observer=True)
    try:
        await ap.wait_heartbeat(3.0)  # arrives only because the observer announced itself
        granted = await ap.request_streams()
        assert granted["LOCAL_POSITION_NED"] == 40.0
        assert ap.cfg.source_system == OBSERVER != cfg.source_system
        with pytest.raises(NeverSent):
            ap.start_heartbeat()
        with pytest.raises(NeverSent):
            ap.action.send_rc_override([0] * 18)
        with pytest.raises(NeverSent):
            ap.send_message(mavlink.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0))
        with pytest.raises(NeverSent):
            ap.send_message(mavlink.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3))
    finally:
        await ap.close()
        peer.stop()
    assert peer.records.gcs_heartbeats == []  # no HEARTBEAT of any type, from any id
    assert peer.records.overrides == []
    requests = peer.records.commands_of(MAV_CMD_REQUEST_MESSAGE)
    assert requests and requests[0].params[0] == mavlink.MAVLINK_MSG_ID_HEARTBEAT
    assert {c.sysid for c in peer.records.commands} == {OBSERVER}


def test_the_observer_id_is_neither_the_gcs_nor_the_autopilot() -> None:
    with pytest.raises(ValueError, match=r"observer_system = 247 is also link\.source_system"):
        link_config(observer_system=247)
    with pytest.raises(ValueError, match="autopilot's system id"):
        link_config(observer_system=1)
