"""The simulator's current mission item against ArduPilot: MAV_CMD_DO_SET_MISSION_CURRENT
(GCS_MAVLINK::handle_command_do_set_mission_current), AP_Mission::set_current_cmd with the
mission stopped (Rover outside AUTO), and MISSION_CURRENT (GCS_MAVLINK::send_mission_current,
mission_state())."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from hypothesis import given, settings
from hypothesis import strategies as hs
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_JUMP,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_WAYPOINT,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_NOT_STARTED,
)
from helixd.sim import stream_rates as st
from helixd.sim.firmware.mission_items import Outcome
from helixd.sim.firmware.mission_server import MissionServer
from tests.support.mavmsgs import stamp
from tests.support.simcore import incoming, make_core, of_type, run

GCS = (255, 190)
HOME = (53.52325, -113.52, 668.0)
WP, SERVO, SPEED = MAV_CMD_NAV_WAYPOINT, MAV_CMD_DO_SET_SERVO, MAV_CMD_DO_CHANGE_SPEED
NAV_COMMANDS = (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_RETURN_TO_LAUNCH)
DO_COMMANDS = (MAV_CMD_DO_SET_SERVO, MAV_CMD_DO_CHANGE_SPEED)
_mav = mavlink.MAVLink(None)


def item_msg(seq: int, command: int, p1: float = 0.0, p2: float = 0.0) -> Any:
    return _mav.mission_item_int_encode(
        1, 1, seq, 3, command, 0, 1, p1, p2, 0.0, 0.0, 535_000_000 + seq, -1_135_000_000, 0.0, 0
    )


def upload(srv: MissionServer, items: Sequence[tuple[int, float, float] | int]) -> None:
    """Row 0 (home) and then ``items``: a command id or (command, param1, param2)."""
    rows = [(WP, 0.0, 0.0)] + [(i, 0.0, 0.0) if isinstance(i, int) else i for i in items]
    srv.handle(0, stamp(_mav.mission_count_encode(1, 1, len(rows), 0)), 0.0)
    for seq, (command, p1, p2) in enumerate(rows):
        out = srv.handle(0, stamp(item_msg(seq, command, p1, p2)), 0.0)
    assert [int(m.type) for _, m in out.sends if m.get_type() == "MISSION_ACK"] == [0]
    assert len(srv.stored()) == len(rows)


def server(
    items: Sequence[tuple[int, float, float] | int] = (), max_items: int = 40
) -> MissionServer:
    srv = MissionServer(*HOME, max_mission_items=max_items)
    if items:
        upload(srv, items)
    return srv


def currents(out: Outcome) -> list[tuple[int | None, tuple[int, int, int, int]]]:
    return [
        (link, (int(m.seq), int(m.total), int(m.mission_state), int(m.mission_mode)))
        for link, m in out.sends
        if m.get_type() == "MISSION_CURRENT"
    ]


def texts(out: Outcome) -> list[str]:
    return [t.text for t in out.texts]


def test_a_nav_item_becomes_current_and_is_volunteered_to_the_commanding_link() -> None:
    srv = server([WP, WP, WP])
    result, out = srv.do_set_mission_current(1, 2.0, 0.0)
    assert result == MAV_RESULT_ACCEPTED
    # seq, total (home excluded), NOT_STARTED (stopped, not in AUTO), mission_mode 0
    assert currents(out) == [(1, (2, 3, MISSION_STATE_NOT_STARTED, 0))]
    assert srv.current_seq == 2


def test_a_do_item_moves_the_current_item_to_the_next_nav_item() -> None:
    srv = server([WP, SERVO, SPEED, WP, WP])
    result, out = srv.do_set_mission_current(0, 2.0, 0.0)
    assert result == MAV_RESULT_ACCEPTED
    assert currents(out) == [(0, (4, 5, MISSION_STATE_NOT_STARTED, 0))]
    assert srv.current_seq == 4


def test_seq_zero_means_the_first_item() -> None:
    srv = server([SERVO, WP, WP])
    result, out = srv.do_set_mission_current(0, 0.0, 0.0)
    assert result == MAV_RESULT_ACCEPTED
    assert currents(out)[0][1][0] == 2  # index 1 is a DO item: the first NAV item is 2


def test_an_index_past_the_end_is_denied_and_nothing_changes() -> None:
    srv = server([WP, WP])
    assert srv.do_set_mission_current(0, 2.0, 0.0)[0] == MAV_RESULT_ACCEPTED
    for bad in (3.0, 700.0, -1.0, math.nan, math.inf):
        result, out = srv.do_set_mission_current(0, bad, 0.0)
        assert result == MAV_RESULT_DENIED, bad
        assert out.steps == []
    assert srv.current_seq == 2
    # param1 is narrowed to uint16 (is_valid_index): 65537 is index 1
    assert srv.do_set_mission_current(0, 65537.0, 0.0)[0] == MAV_RESULT_ACCEPTED
    assert srv.current_seq == 1


def test_no_nav_item_at_or_after_seq_fails_and_leaves_no_current_item() -> None:
    srv = server([WP, SERVO, SPEED])
    assert srv.do_set_mission_current(0, 1.0, 0.0)[0] == MAV_RESULT_ACCEPTED
    result, out = srv.do_set_mission_current(0, 2.0, 0.0)
    assert result == MAV_RESULT_FAILED
    assert currents(out) == []
    assert srv.current_seq == 0  # _nav_cmd.index = NONE → get_current_nav_index() 0


def test_without_a_mission_home_alone_fails_and_nothing_at_all_is_denied() -> None:
    srv = server()
    assert srv.do_set_mission_current(0, 0.0, 0.0)[0] == MAV_RESULT_FAILED  # home only
    assert srv.mission_current_fields() == (0, 0, MISSION_STATE_NO_MISSION, 0)
    srv = server([WP])
    srv.handle(0, stamp(_mav.mission_clear_all_encode(1, 1, 0)), 0.0)
    assert srv.stored() == ()
    assert srv.do_set_mission_current(0, 0.0, 0.0)[0] == MAV_RESULT_DENIED  # 0 items


def test_a_do_jump_is_followed_and_counted() -> None:
    # 1: DO_JUMP to 3, twice; 2: WP; 3: WP
    srv = server([(MAV_CMD_DO_JUMP, 3.0, 2.0), WP, WP])
    seen = []
    for _ in range(3):
        result, out = srv.do_set_mission_current(0, 1.0, 0.0)
        assert result == MAV_RESULT_ACCEPTED
        seen.append((srv.current_seq, texts(out)))
    assert seen == [
        (3, ["Mission: 1 Jump 1/2"]),
        (3, ["Mission: 1 Jump 2/2"]),
        (2, []),  # the jump has run its times: its counter restarts and 2 is next
    ]


def test_reset_and_restart_resumes_the_mission() -> None:
    srv = server([WP, SERVO, WP])
    result, out = srv.do_set_mission_current(0, 2.0, 1.0)
    assert result == MAV_RESULT_ACCEPTED
    assert currents(out) == [(0, (3, 3, MISSION_STATE_ACTIVE, 0))]
    # running now: a further set goes through advance_current_nav_cmd, same NAV item found
    result, out = srv.do_set_mission_current(0, 1.0, 0.0)
    assert currents(out) == [(0, (1, 3, MISSION_STATE_ACTIVE, 0))]
    srv.reboot()
    assert srv.mission_current_fields() == (0, 3, MISSION_STATE_NOT_STARTED, 0)


def test_mission_item_current_compares_the_command_id_with_the_nav_index() -> None:
    # MissionItemProtocol_Waypoints::get_item: cmd.id == get_current_nav_cmd().index
    srv = server([WP] * 17)
    assert srv.do_set_mission_current(0, 2.0, 0.0)[0] == MAV_RESULT_ACCEPTED

    def current_flags() -> list[int]:
        flags = []
        for seq in range(18):
            out = srv.handle(0, stamp(_mav.mission_request_int_encode(1, 1, seq, 0)), 0.0)
            (reply,) = [m for _, m in out.sends if m.get_type() == "MISSION_ITEM_INT"]
            flags.append(int(reply.current))
        return flags

    assert current_flags() == [0] * 18
    assert srv.do_set_mission_current(0, float(WP), 0.0)[0] == MAV_RESULT_ACCEPTED
    assert current_flags() == [1] * 18  # every NAV_WAYPOINT (id 16), home included


@settings(max_examples=150, deadline=None)
@given(
    commands=hs.lists(hs.sampled_from(NAV_COMMANDS + DO_COMMANDS), min_size=1, max_size=12),
    seq=hs.integers(0, 14),
)
def test_set_current_lands_on_the_first_nav_item_at_or_after_seq(
    commands: list[int], seq: int
) -> None:
    srv = server(commands)
    before = srv.current_seq
    result, out = srv.do_set_mission_current(0, float(seq), 0.0)
    rows = [WP, *commands]
    if seq >= len(rows):
        assert result == MAV_RESULT_DENIED and srv.current_seq == before
        return
    nav = [i for i in range(max(seq, 1), len(rows)) if rows[i] in NAV_COMMANDS]
    if not nav:
        assert result == MAV_RESULT_FAILED and srv.current_seq == 0
        return
    assert result == MAV_RESULT_ACCEPTED
    assert currents(out) == [(0, (nav[0], len(commands), MISSION_STATE_NOT_STARTED, 0))]


def command_msg(kind: str, seq: float, reset: float = 0.0) -> Any:
    cmd = MAV_CMD_DO_SET_MISSION_CURRENT
    if kind == "long":
        return mavlink.MAVLink_command_long_message(1, 1, cmd, 0, seq, reset, 0, 0, 0, 0, 0)
    return mavlink.MAVLink_command_int_message(1, 1, 0, cmd, 0, 0, seq, reset, 0, 0, 0, 0, 0.0)


def core_with_mission(rows: int) -> Any:
    core = make_core()
    run(core, 1.5)  # booted
    core.handle(0, incoming(_mav.mission_count_encode(1, 1, rows, 0)))
    for seq in range(rows):
        core.handle(0, incoming(item_msg(seq, WP)))
    acks = of_type(core.drain_outbox(), "MISSION_ACK", link=0)
    assert [int(a.type) for a in acks] == [0]
    return core


def test_core_answers_command_long_and_int_with_ack_then_mission_current_on_that_link() -> None:
    core = core_with_mission(4)
    for kind, seq in (("long", 2.0), ("int", 3.0)):
        core.handle(1, incoming(command_msg(kind, seq)))
        out = core.drain_outbox()  # no tick: nothing streamed in between
        kinds = [(link, m.get_type()) for link, m in out]
        assert kinds[:2] == [(1, "COMMAND_ACK"), (1, "MISSION_CURRENT")], kind
        assert int(out[0][1].result) == MAV_RESULT_ACCEPTED
        assert int(out[1][1].seq) == int(seq)
        assert of_type(out, "MISSION_CURRENT", link=0) == []  # the other link: not volunteered
    core.handle(1, incoming(command_msg("long", 9.0)))
    out = core.drain_outbox()
    assert [int(m.result) for m in of_type(out, "COMMAND_ACK")] == [MAV_RESULT_DENIED]
    assert of_type(out, "MISSION_CURRENT") == []
    assert core.mission.current_seq == 3


def test_mission_current_is_streamed_on_every_link_in_extended_status() -> None:
    assert st.MSG_MISSION_CURRENT in st.STREAMS[2]  # STREAM_EXTENDED_STATUS_msgs
    core = core_with_mission(3)
    core.handle(0, incoming(command_msg("long", 2.0)))
    core.drain_outbox()
    out = run(core, 2.5)
    for link in (0, 1):
        streamed = of_type(out, "MISSION_CURRENT", link=link)
        assert len(streamed) >= 2, link
        fields = {
            (int(m.seq), int(m.total), int(m.mission_state), int(m.mission_mode)) for m in streamed
        }
        assert fields == {(2, 2, MISSION_STATE_NOT_STARTED, 0)}


def test_a_disarm_resets_the_mission_so_the_current_item_reads_0() -> None:
    """AP_Arming_Rover::disarm outside AUTO calls mission.reset(): MISSION_CURRENT seq 0."""
    core = core_with_mission(3)
    core.handle(0, incoming(command_msg("long", 2.0)))
    core.drain_outbox()
    core.ap.armed = True
    run(core, 0.1)
    assert core.mission.current_seq == 2  # armed: nothing reset
    core.ap.arm_disarm(0.0, 0.0, core.now_s, core.ekf_status())
    assert core.mission.current_seq == 0  # at the disarm itself, not at the next tick
    core.handle(0, incoming(command_msg("long", 2.0)))  # set again after the disarm
    run(core, 0.1)
    assert core.mission.current_seq == 2  # and it stays
    assert core.mission.current_seq == 2
