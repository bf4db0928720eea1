"""The simulator's mission protocol (helixd.sim.firmware.mission_server) against ArduPilot's
behaviour."""

from __future__ import annotations

import os
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from hypothesis import given, settings
from hypothesis import strategies as hs
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_DENIED,
    MAV_MISSION_ERROR,
    MAV_MISSION_INVALID_PARAM5_X,
    MAV_MISSION_INVALID_PARAM7,
    MAV_MISSION_INVALID_SEQUENCE,
    MAV_MISSION_NO_SPACE,
    MAV_MISSION_OPERATION_CANCELLED,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_UNSUPPORTED,
    MAV_MISSION_UNSUPPORTED_FRAME,
)
from helixd.sim.faults import make_spec
from helixd.sim.firmware import mission_items as sm
from helixd.sim.firmware.mission_items import Outcome
from helixd.sim.firmware.mission_server import MissionServer
from tests.support.mavmsgs import stamp
from tests.support.simcore import incoming, make_core, of_type, run

GCS = (255, 190)
OTHER = (254, 190)
HOME = (53.52325, -113.52, 668.0)
_mav = mavlink.MAVLink(None)


def count(n: int, mission_type: int = 0) -> Any:
    return _mav.mission_count_encode(1, 1, n, mission_type)


def item(seq: int, lat_deg: float = 53.5, lon_deg: float = -113.5, command: int = 16,
         frame: int = 3, mission_type: int = 0, p1: float = 0.0) -> Any:  # fmt: skip
    return _mav.mission_item_int_encode(
        1, 1, seq, frame, command, 0, 1, p1, 0.0, 0.0, 0.0,
        round(lat_deg * 1e7), round(lon_deg * 1e7), 0.0, mission_type,
    )  # fmt: skip


def sends(out: Outcome, kind: str) -> list[Any]:
    return [m for _, m in out.sends if m.get_type() == kind]


def acks(out: Outcome) -> list[int]:
    return [int(m.type) for m in sends(out, "MISSION_ACK")]


def server() -> MissionServer:
    return MissionServer(*HOME, max_mission_items=5, max_fence_items=4, max_rally_items=2)


def upload(
    srv: MissionServer, n: int, now: float = 0.0, mission_type: int = 0, command: int = 16
) -> Outcome:
    out = srv.handle(0, stamp(count(n, mission_type)), now)
    for seq in range(n):
        out = srv.handle(0, stamp(item(seq, 53.5 + seq * 1e-4, mission_type=mission_type,
                                       command=command)), now)  # fmt: skip
    return out


def test_upload_is_requested_with_mission_request_and_acked() -> None:
    srv = server()
    out = srv.handle(0, stamp(count(3)), 0.0)
    reqs = sends(out, "MISSION_REQUEST")
    assert [int(r.seq) for r in reqs] == [0]
    assert (int(reqs[0].target_system), int(reqs[0].target_component)) == GCS
    for seq in range(3):
        out = srv.handle(0, stamp(item(seq, 53.5 + seq * 1e-4)), 0.1)
        if seq < 2:
            assert [int(r.seq) for r in sends(out, "MISSION_REQUEST")] == [seq + 1]
    assert acks(out) == [MAV_MISSION_ACCEPTED]
    assert [t.text for t in out.texts] == ["Flight plan received"]
    stored = srv.stored()
    assert len(stored) == 3 and stored[2].x == round((53.5 + 2e-4) * 1e7)


def test_row_zero_reads_back_as_arduplots_own_home() -> None:
    srv = server()
    upload(srv, 2)
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 0, 0)), 1.0)
    (got,) = sends(out, "MISSION_ITEM_INT")
    assert (int(got.x), int(got.y)) == (round(HOME[0] * 1e7), round(HOME[1] * 1e7))
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 1, 0)), 1.0)
    (got,) = sends(out, "MISSION_ITEM_INT")
    assert int(got.x) == round((53.5 + 1e-4) * 1e7)
    out = srv.handle(0, stamp(_mav.mission_request_list_encode(1, 1, 0)), 1.0)
    assert [int(m.count) for m in sends(out, "MISSION_COUNT")] == [2]


def test_mission_request_float_answers_mission_item_in_degrees() -> None:
    srv = server()
    upload(srv, 2)
    out = srv.handle(0, stamp(_mav.mission_request_encode(1, 1, 1, 0)), 1.0)
    (got,) = sends(out, "MISSION_ITEM")
    assert abs(float(got.x) - (53.5 + 1e-4)) < 1e-6


def test_second_uploader_denied_same_uploader_restarts() -> None:
    srv = server()
    srv.handle(0, stamp(count(3)), 0.0)
    out = srv.handle(1, stamp(count(2), OTHER), 0.1)
    assert acks(out) == [MAV_MISSION_DENIED]
    out = srv.handle(0, stamp(item(0), OTHER), 0.1)
    assert acks(out) == [MAV_MISSION_DENIED]
    out = srv.handle(0, stamp(count(1)), 0.2)  # the uploader restarts with another count
    assert [int(r.seq) for r in sends(out, "MISSION_REQUEST")] == [0]
    out = srv.handle(0, stamp(item(0)), 0.3)
    assert acks(out) == [MAV_MISSION_ACCEPTED]
    assert len(srv.stored()) == 1


def test_download_denied_during_upload_and_clear_is_error() -> None:
    srv = server()
    srv.handle(0, stamp(count(3)), 0.0)
    out = srv.handle(1, stamp(_mav.mission_request_list_encode(1, 1, 0), OTHER), 0.1)
    assert acks(out) == [MAV_MISSION_DENIED]
    out = srv.handle(1, stamp(_mav.mission_request_int_encode(1, 1, 0, 0), OTHER), 0.1)
    assert acks(out) == [MAV_MISSION_DENIED]
    out = srv.handle(1, stamp(_mav.mission_clear_all_encode(1, 1, 0), OTHER), 0.1)
    assert acks(out) == [MAV_MISSION_ERROR]


def test_no_space() -> None:
    srv = server()
    out = srv.handle(0, stamp(count(6)), 0.0)
    assert acks(out) == [MAV_MISSION_NO_SPACE]
    assert [t.text for t in out.texts] == ["Only 5 items are supported"]
    out = srv.handle(0, stamp(count(5, MAV_MISSION_TYPE_FENCE)), 0.0)
    assert acks(out) == [MAV_MISSION_NO_SPACE]


def test_wrong_sequence_is_complained_about_and_upload_goes_on() -> None:
    srv = server()
    srv.handle(0, stamp(count(2)), 0.0)
    out = srv.handle(0, stamp(item(1)), 0.1)
    assert acks(out) == [MAV_MISSION_INVALID_SEQUENCE]
    out = srv.handle(0, stamp(item(0)), 0.2)
    assert [int(r.seq) for r in sends(out, "MISSION_REQUEST")] == [1]


def test_unsupported_command_and_bad_latitude_end_the_upload() -> None:
    srv = server()
    srv.handle(0, stamp(count(2)), 0.0)
    # DO_SET_MODE: not a command AP_Mission stores (NAV_TAKEOFF is: Rover skips it in flight)
    out = srv.handle(0, stamp(item(0, command=176)), 0.1)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED]
    assert srv.update(5.0).sends == []  # no upload left to re-request
    srv.handle(0, stamp(count(1)), 6.0)
    out = srv.handle(0, stamp(item(0, lat_deg=91.0)), 6.1)
    assert acks(out) == [MAV_MISSION_INVALID_PARAM5_X]
    srv.handle(0, stamp(count(1)), 7.0)
    out = srv.handle(0, stamp(item(0, frame=1)), 7.1)  # MAV_FRAME_LOCAL_NED
    assert acks(out) == [MAV_MISSION_UNSUPPORTED_FRAME]


def test_rerequest_after_one_second_and_cancel_after_eight() -> None:
    srv = server()
    srv.handle(0, stamp(count(2)), 0.0)
    assert srv.update(0.9).sends == []
    out = srv.update(1.05)
    assert [int(r.seq) for r in sends(out, "MISSION_REQUEST")] == [0]
    srv.handle(0, stamp(item(0)), 2.0)
    assert sends(srv.update(2.9), "MISSION_REQUEST") == []
    assert [int(r.seq) for r in sends(srv.update(3.1), "MISSION_REQUEST")] == [1]
    out = srv.update(10.05)
    assert acks(out) == [MAV_MISSION_OPERATION_CANCELLED]
    assert [t.text for t in out.texts] == ["Mission upload timeout"]
    out = srv.handle(0, stamp(_mav.mission_request_list_encode(1, 1, 0)), 10.1)
    assert sends(out, "MISSION_COUNT")  # no longer receiving


def test_fence_and_rally_need_mavlink2_mission_does_not() -> None:
    srv = server()
    out = srv.handle(0, stamp(count(1, MAV_MISSION_TYPE_FENCE), v1=True), 0.0)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED]
    assert [t.text for t in out.texts] == ["Need mavlink2 for item transfer"]
    out = srv.handle(0, stamp(_mav.mission_request_list_encode(1, 1, 2), v1=True), 0.0)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED]
    out = srv.handle(0, stamp(count(1), v1=True), 0.0)
    assert sends(out, "MISSION_REQUEST")


def test_fence_upload_stored_on_completion_and_bad_seq_invalid() -> None:
    srv = server()
    out = upload(srv, 3, mission_type=MAV_MISSION_TYPE_FENCE, command=5001)
    assert acks(out) == [MAV_MISSION_ACCEPTED]
    assert [i.command for i in srv.stored(MAV_MISSION_TYPE_FENCE)] == [5001] * 3
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 3, 1)), 1.0)
    assert acks(out) == [MAV_MISSION_ERROR]  # seq == count: ArduPilot checks seq > count
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 4, 1)), 1.0)
    assert acks(out) == [MAV_MISSION_INVALID_SEQUENCE]
    srv.handle(0, stamp(count(1, MAV_MISSION_TYPE_FENCE)), 2.0)
    out = srv.handle(0, stamp(item(0, command=16, mission_type=1)), 2.1)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED]
    assert len(srv.stored(MAV_MISSION_TYPE_FENCE)) == 3  # failed upload kept the old fence


def test_request_past_the_end_educates_with_count() -> None:
    srv = server()
    upload(srv, 2)
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 7, 0)), 1.0)
    assert [int(m.count) for m in sends(out, "MISSION_COUNT")] == [2]
    assert acks(out) == [MAV_MISSION_ERROR]


def test_clear_all_and_unknown_type() -> None:
    srv = server()
    upload(srv, 3)
    out = srv.handle(0, stamp(_mav.mission_clear_all_encode(1, 1, 0)), 1.0)
    assert acks(out) == [MAV_MISSION_ACCEPTED]
    assert srv.stored() == ()
    out = srv.handle(0, stamp(_mav.mission_request_list_encode(1, 1, 7)), 1.0)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED]


def test_set_current_answers_the_sender_with_the_requested_seq() -> None:
    # GCS_MAVLINK::handle_mission_set_current: send_mission_current(mission, packet.seq) on
    # the receiving channel; an index ArduPilot refuses gets nothing
    srv = server()
    upload(srv, 3)
    out = srv.handle(1, stamp(_mav.mission_set_current_encode(1, 1, 2)), 1.0)
    (cur,) = sends(out, "MISSION_CURRENT")
    assert [link for link, _ in out.sends] == [1]
    assert (int(cur.seq), int(cur.total)) == (2, 2)
    assert srv.current_seq == 2
    assert srv.handle(0, stamp(_mav.mission_set_current_encode(1, 1, 9)), 1.0).sends == []
    assert srv.current_seq == 2
    # seq 0 restarts at 1, but the reply echoes the 0 that was asked for
    out = srv.handle(0, stamp(_mav.mission_set_current_encode(1, 1, 0)), 1.0)
    assert [int(m.seq) for m in sends(out, "MISSION_CURRENT")] == [0]
    assert srv.current_seq == 1


def test_stray_item_without_upload_gets_no_answer() -> None:
    srv = server()
    assert srv.handle(0, stamp(item(0)), 0.0).sends == []


def test_core_routes_mission_messages_and_re_requests_on_tick() -> None:
    core = make_core()
    run(core, 0.2)
    core.handle(1, incoming(count(2)))
    out = core.drain_outbox()
    assert [int(m.seq) for m in of_type(out, "MISSION_REQUEST", link=1)] == [0]
    assert of_type(out, "MISSION_REQUEST", link=0) == []
    out = run(core, 1.3)
    assert [int(m.seq) for m in of_type(out, "MISSION_REQUEST", link=1)] == [0]
    core.handle(1, incoming(item(0)))
    core.handle(1, incoming(item(1)))
    out = core.drain_outbox()
    assert [int(m.type) for m in of_type(out, "MISSION_ACK", link=1)] == [0]
    assert any(m.get_type() == "STATUSTEXT" for _, m in out)
    assert len(core.mission.stored()) == 2


def test_result_numbers_are_mavlinks() -> None:
    enum = mavlink.enums["MAV_MISSION_RESULT"]
    for name in (
        "ACCEPTED", "ERROR", "UNSUPPORTED_FRAME", "UNSUPPORTED", "NO_SPACE",
        "INVALID_PARAM5_X", "INVALID_PARAM6_Y", "INVALID_PARAM7", "INVALID_SEQUENCE",
        "DENIED", "OPERATION_CANCELLED",
    ):  # fmt: skip
        assert enum[getattr(sm, f"MAV_MISSION_{name}")].name == f"MAV_MISSION_{name}"


def test_fence_item_rules_and_readback() -> None:
    srv = server()
    srv.handle(0, stamp(count(1, 1)), 0.0)
    out = srv.handle(0, stamp(item(0, command=5001, frame=2, mission_type=1)), 0.1)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED_FRAME]  # frame checked before command
    srv.handle(0, stamp(count(1, 1)), 0.2)
    vertex = _mav.mission_item_int_encode(
        1, 1, 0, 6, 5001, 0, 1, 4.0, 7.0, 8.0, 9.0, 535_000_000, -1_135_000_000, 12.0, 1
    )
    out = srv.handle(0, stamp(vertex), 0.3)
    assert acks(out) == [MAV_MISSION_ACCEPTED]
    assert out.texts == []  # no text on a fence upload
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 0, 1)), 0.4)
    (got,) = sends(out, "MISSION_ITEM_INT")
    # get_item_as_mission_item: frame 0, param1 (vertex count), x/y; the rest zero
    assert (int(got.frame), float(got.param1), float(got.param2), float(got.z)) == (0, 4, 0, 0)
    assert (int(got.x), int(got.autocontinue), int(got.mission_type)) == (535_000_000, 0, 1)


def test_rally_rules_readback_and_texts() -> None:
    srv = server()
    srv.handle(0, stamp(count(1, 2)), 0.0)
    out = srv.handle(0, stamp(item(0, command=5100, frame=0, mission_type=2)), 0.1)
    assert acks(out) == [MAV_MISSION_UNSUPPORTED_FRAME]  # only relative-altitude frames
    srv.handle(0, stamp(count(1, 2)), 0.2)
    high = _mav.mission_item_int_encode(1, 1, 0, 3, 5100, 0, 1, 0, 0, 0, 0, 1, 2, 40000.0, 2)
    assert acks(srv.handle(0, stamp(high), 0.3)) == [MAV_MISSION_INVALID_PARAM7]
    srv.handle(0, stamp(count(1, 2)), 0.4)
    ok = _mav.mission_item_int_encode(1, 1, 0, 6, 5100, 0, 1, 0, 0, 0, 0, 1, 2, 12.7, 2)
    out = srv.handle(0, stamp(ok), 0.5)
    assert acks(out) == [MAV_MISSION_ACCEPTED]
    assert [t.text for t in out.texts] == ["Rally points received"]
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 0, 2)), 0.6)
    (got,) = sends(out, "MISSION_ITEM_INT")
    assert (int(got.frame), float(got.z)) == (3, 12.0)  # int16 altitude
    srv.handle(0, stamp(count(2, 2)), 1.0)
    out = srv.update(9.5)
    assert [t.text for t in out.texts] == ["Rally upload timeout"]
    assert len(srv.stored(2)) == 1  # rally keeps what was written before the timeout


def test_mission_int_frames_read_back_without_int() -> None:
    srv = server()
    srv.handle(0, stamp(count(2)), 0.0)
    srv.handle(0, stamp(item(0)), 0.1)
    srv.handle(0, stamp(item(1, frame=6)), 0.2)
    out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, 1, 0)), 0.3)
    (got,) = sends(out, "MISSION_ITEM_INT")
    assert (int(got.frame), int(got.autocontinue)) == (3, 1)


def test_order_of_text_and_ack_as_arduplot() -> None:
    srv = server()
    srv.handle(0, stamp(count(1)), 0.0)
    out = srv.handle(0, stamp(item(0)), 0.1)
    # transfer_is_complete: complete() says "Flight plan received", then the ACK
    assert [type(s).__name__ for s in out.steps] == ["SimStatusText", "tuple"]
    out = srv.handle(0, stamp(count(99)), 0.2)
    # handle_mission_count: NO_SPACE ack first, then the text
    assert [type(s).__name__ for s in out.steps] == ["tuple", "SimStatusText"]


def test_reboot_loses_the_upload_keeps_the_mission() -> None:
    core = make_core()
    run(core, 0.2)
    core.handle(0, incoming(count(1)))
    core.handle(0, incoming(item(0)))
    core.handle(0, incoming(count(3)))
    core.handle(0, incoming(item(0)))
    core.drain_outbox()
    assert core.mission.protocols[0].receiving
    core.inject(make_spec("reboot", {}))
    assert not core.mission.protocols[0].receiving
    assert len(core.mission.stored()) == 1


_u8 = hs.integers(0, 255)
_u16 = hs.integers(0, 65535)
_i32 = hs.integers(-(2**31), 2**31 - 1)
_f = hs.floats(width=32)
_type = hs.sampled_from([0, 1, 2, 3, 255])


def _item_head(commands: list[int]) -> tuple[Any, ...]:
    """target system, component, seq, frame, one of ``commands``, current, autocontinue."""
    return (_u8, _u8, hs.integers(0, 12), _u8, hs.sampled_from(commands), _u8, _u8)


_messages = hs.one_of(
    hs.builds(_mav.mission_count_encode, _u8, _u8, hs.integers(0, 12), _type),
    hs.builds(
        _mav.mission_item_int_encode,
        *_item_head([16, 22, 177, 5001, 5003, 5100, 65535]),
        *[_f] * 4,
        _i32,
        _i32,
        _f,
        _type,
    ),
    hs.builds(_mav.mission_item_encode, *_item_head([16, 177, 5001, 5100]), *[_f] * 7, _type),
    hs.builds(_mav.mission_request_int_encode, _u8, _u8, _u16, _type),
    hs.builds(_mav.mission_request_encode, _u8, _u8, _u16, _type),
    hs.builds(_mav.mission_request_list_encode, _u8, _u8, _type),
    hs.builds(_mav.mission_clear_all_encode, _u8, _u8, _type),
    hs.builds(_mav.mission_set_current_encode, _u8, _u8, _u16),
    hs.builds(_mav.mission_ack_encode, _u8, _u8, _u8, _type),
)


@settings(max_examples=200, deadline=None)
@given(
    steps=hs.lists(
        hs.tuples(_messages, hs.sampled_from([GCS, OTHER]), hs.booleans(), hs.floats(0, 3)),
        max_size=30,
    )
)
def test_fuzz_any_mission_messages(steps: list[tuple[Any, tuple[int, int], bool, float]]) -> None:
    """Whatever arrives: no exception, every reply packs, stored items stay storable."""
    srv = server()
    now = 0.0
    tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    for msg, who, v1, dt in steps:
        now += dt
        for out in (srv.handle(0, stamp(msg, who, v1), now), srv.update(now)):
            for _, reply in out.sends:
                reply.pack(tx)
        for kind, prot in srv.protocols.items():
            assert len(prot.items) <= prot.max_items
            for stored in prot.items[1:] if kind == 0 else prot.items:
                assert prot.rules.validate(stored) == MAV_MISSION_ACCEPTED
