"""Forwarding between the simulator's links, as ArduPilot's MAVLink_routing.cpp does."""

from __future__ import annotations

import os
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.sim.inbound import Router

AP_SYSID = 1


def frm(sysid: int, compid: int, build: Any) -> Any:
    mav = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    return mav.decode(bytearray(build(mav).pack(mav)))


def heartbeat(sysid: int, compid: int = 190) -> Any:
    return frm(sysid, compid, lambda m: m.heartbeat_encode(6, 8, 0, 0, 4))


def test_heartbeat_goes_to_every_other_active_link() -> None:
    r = Router()
    assert r.forward_links(0, heartbeat(247, 191), AP_SYSID) == []  # nobody else yet
    assert r.forward_links(1, heartbeat(247, 190), AP_SYSID) == [0]  # GCS on helixd's id
    assert r.forward_links(0, heartbeat(247, 191), AP_SYSID) == [1]


def test_heartbeat_not_sent_back_where_that_sender_lives() -> None:
    r = Router()
    r.forward_links(0, heartbeat(247, 191), AP_SYSID)
    r.forward_links(1, heartbeat(247, 191), AP_SYSID)  # same sysid AND compid on link 1
    # (247, 191) is known on both links: ArduPilot forwards its heartbeat nowhere
    assert r.forward_links(1, heartbeat(247, 191), AP_SYSID) == []


def test_targeted_and_broadcast_messages() -> None:
    r = Router()
    r.forward_links(0, heartbeat(247, 191), AP_SYSID)
    r.forward_links(1, heartbeat(255, 190), AP_SYSID)
    for_us = frm(
        255, 190, lambda m: m.command_long_encode(AP_SYSID, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    )
    assert r.forward_links(1, for_us, AP_SYSID) == []
    to_helixd = frm(
        255, 190, lambda m: m.command_long_encode(247, 191, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    )
    assert r.forward_links(1, to_helixd, AP_SYSID) == [0]
    broadcast = frm(255, 190, lambda m: m.system_time_encode(0, 0))  # no target field
    assert r.forward_links(1, broadcast, AP_SYSID) == [0]
    radio = frm(255, 190, lambda m: m.radio_status_encode(1, 2, 3, 4, 5, 6, 7))
    assert r.forward_links(1, radio, AP_SYSID) == []


def test_our_own_messages_coming_back_are_ignored() -> None:
    r = Router()
    r.forward_links(1, heartbeat(255), AP_SYSID)
    loop = frm(AP_SYSID, 1, lambda m: m.heartbeat_encode(10, 3, 0, 0, 4))
    assert r.forward_links(0, loop, AP_SYSID) == []
    assert all(s != AP_SYSID for s, _, _ in r.routes)
