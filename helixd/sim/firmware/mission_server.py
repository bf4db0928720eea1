"""ArduPilot's mission on the vehicle: the MAVLink mission messages routed, and AP_Mission's
current command (pure: messages in, messages out).

Written from ArduPilot's ``GCS_Common.cpp`` (``GCS_MAVLINK::handle_common_mission_message``:
which message goes to which protocol) and ``AP_Mission``. :class:`MissionServer` routes each
mission message by ``mission_type`` to the item protocol of that type
(:mod:`helixd.sim.firmware.mission_items`: uploads, downloads, what is stored), answers an
unknown type with MAV_MISSION_UNSUPPORTED, and keeps AP_Mission's current command, its jump
counters and its state, which AUTO runs (:mod:`helixd.sim.firmware.mode_auto`).

Behaviours (each cites its ArduPilot function):

* The current item (``AP_Mission::set_current_cmd`` with the mission not running — Rover
  runs it only in AUTO, :mod:`helixd.sim.firmware.mode_auto`): an index past the end, or a
  mission of home alone, fails; index 0 means 1 and restarts the jump counters; the current
  *nav* index becomes the first NAV command (``is_nav_cmd``: id ≤ MAV_CMD_NAV_LAST,
  NAV_SET_YAW_SPEED, NAV_SCRIPT_TIME, NAV_ATTITUDE_TIME) at or after it, following DO_JUMP /
  DO_JUMP_TAG (``get_next_cmd`` with its jump counters, "Mission: N Jump i/n" texts and the
  64-jump limit); no NAV command there fails and leaves no current command (seq 0). The mission
  stays stopped. At boot and after a clear there is no current command
  (``get_current_nav_index`` reads 0); an upload leaves it as it was.
* MISSION_SET_CURRENT (``GCS_MAVLINK::handle_mission_set_current``): ``set_current_cmd(seq)``;
  on success MISSION_CURRENT with the *requested* seq goes back to the sender's link only
  (``send_mission_current(mission, packet.seq)``, some GCSs take it as the ack); on failure
  nothing.
* MAV_CMD_DO_SET_MISSION_CURRENT (``GCS_MAVLINK::handle_command_do_set_mission_current``,
  :meth:`MissionServer.do_set_mission_current`): seq = param1 as uint32, narrowed to uint16 by
  ``is_valid_index``; seq ≥ count → DENIED (a NaN/negative param1, undefined in C++, is DENIED
  here); param2 == 1 ``reset()``s the mission first (current command and jump counters) and
  ``resume()``s it after; ``set_current_cmd`` failing → FAILED; ACCEPTED → MISSION_CURRENT
  (``send_message(MSG_CURRENT_WAYPOINT)``: the nav index) after the ACK, on the commanding
  link only (``GCS_MAVLINK::send_message`` is per channel despite the source's "all
  listeners" comment). A resumed mission is RUNNING: further set-current calls take
  ``advance_current_nav_cmd``'s search (same NAV item found; the DO/NAV ``start_command``
  callbacks it runs, even outside AUTO, are not modelled).
* MISSION_CURRENT (``GCS_MAVLINK::send_mission_current``, streamed in EXTENDED_STATUS as
  MSG_CURRENT_WAYPOINT): seq = ``get_current_nav_index()``, total excludes home, mission_state
  from ``GCS_MAVLINK::mission_state`` (NO_MISSION unless ``present()`` — more than home —,
  stopped NOT_STARTED, running ACTIVE, complete COMPLETE), mission_mode 1 only in a mode that
  ``current_mode_requires_mission`` (Rover: AUTO).
* A disarm outside AUTO resets the mission (``AP_Arming_Rover::disarm`` → ``AP_Mission::reset``):
  no current command, so MISSION_CURRENT reads seq 0 until the current item is set again.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from typing import Any, cast

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_JUMP,
    MAV_CMD_DO_JUMP_TAG,
    MAV_CMD_JUMP_TAG,
    MAV_CMD_NAV_ATTITUDE_TIME,
    MAV_CMD_NAV_LAST,
    MAV_CMD_NAV_SCRIPT_TIME,
    MAV_CMD_NAV_SET_YAW_SPEED,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_TYPE_RALLY,
    MAV_MISSION_UNSUPPORTED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_SEVERITY_INFO,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_COMPLETE,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_NOT_STARTED,
    UINT16_MAX,
)
from helixd.sim.firmware.messages import Message
from helixd.sim.firmware.mission_items import (
    FENCE_RULES,
    MISSION_RULES,
    RALLY_RULES,
    ItemProtocol,
    Outcome,
    StoredItem,
    item_from_float,
    item_from_int,
    mission_ack,
)
from helixd.sim.firmware.rover_firmware import SimStatusText

__all__ = ["MissionServer"]


# AP_Mission
CMD_INDEX_NONE = UINT16_MAX  # AP_MISSION_CMD_INDEX_NONE
NAV_EXCEPTIONS = frozenset(
    {MAV_CMD_NAV_SET_YAW_SPEED, MAV_CMD_NAV_SCRIPT_TIME, MAV_CMD_NAV_ATTITUDE_TIME}
)
MAX_JUMP_COMMANDS = 100  # AP_MISSION_MAX_NUM_DO_JUMP_COMMANDS (HAL_MEM_CLASS_500 and SITL)
JUMP_TIMES_MAX = 32767  # AP_MISSION_JUMP_TIMES_MAX: what an untracked jump has "run"
JUMP_REPEAT_FOREVER = -1  # AP_MISSION_JUMP_REPEAT_FOREVER
GET_NEXT_CMD_MAX_JUMPS = 64  # get_next_cmd's max_loops
ADVANCE_MAX_LOOPS = 255  # advance_current_nav_cmd's max_loops
FLT_EPSILON = 1.1920929e-07  # is_equal(float, float)
MISSION_STOPPED, MISSION_RUNNING, MISSION_COMPLETE = 0, 1, 2  # AP_Mission::mission_state
# AP_Mission::Mission_Command::type(): the names "Mission: N <type>" says (the few modelled)
COMMAND_TYPES = {16: "WP", 17: "LoitUnlim", 19: "LoitTime", 20: "RTL", 93: "Delay"}
MISSION_STATES = {  # GCS_MAVLINK::mission_state
    MISSION_STOPPED: MISSION_STATE_NOT_STARTED,
    MISSION_RUNNING: MISSION_STATE_ACTIVE,
    MISSION_COMPLETE: MISSION_STATE_COMPLETE,
}

_mav = mavlink.MAVLink(None)


def is_nav_cmd(command: int) -> bool:
    """AP_Mission::is_nav_cmd."""
    return command <= MAV_CMD_NAV_LAST or command in NAV_EXCEPTIONS


def seq_from_param(param1: float) -> int | None:
    """handle_command_do_set_mission_current: ``(uint32_t)packet.param1``, then the uint16 of
    ``is_valid_index`` / ``set_current_cmd``. None where C++ is undefined (NaN, negative,
    beyond uint32): the simulator refuses those rather than guess."""
    if not math.isfinite(param1) or param1 < 0.0 or param1 >= 2.0**32:
        return None
    return int(param1) & UINT16_MAX


class MissionServer:
    """GCS_MAVLINK::handle_common_mission_message: the three protocols and AP_Mission's
    current command (nav index, DO_JUMP counters, mission state)."""

    MESSAGES = frozenset(
        {
            "MISSION_COUNT",
            "MISSION_ITEM",
            "MISSION_ITEM_INT",
            "MISSION_REQUEST",
            "MISSION_REQUEST_INT",
            "MISSION_REQUEST_LIST",
            "MISSION_CLEAR_ALL",
            "MISSION_SET_CURRENT",
            "MISSION_ACK",
        }
    )

    def __init__(
        self,
        home_lat_deg: float,
        home_lon_deg: float,
        home_alt_m: float,
        max_mission_items: int = 700,
        max_fence_items: int = 84,
        max_rally_items: int = 10,
        requires_mission: Callable[[], bool] = lambda: False,
    ) -> None:
        """``requires_mission``: AP_Vehicle::current_mode_requires_mission (Rover: in AUTO)."""
        home = StoredItem(
            MAV_CMD_NAV_WAYPOINT,
            MAV_FRAME_GLOBAL,
            x=round(home_lat_deg * 1e7),
            y=round(home_lon_deg * 1e7),
            z=home_alt_m,
        )
        self.protocols = {
            MAV_MISSION_TYPE_MISSION: ItemProtocol(
                MAV_MISSION_TYPE_MISSION, MISSION_RULES, max_mission_items, home
            ),
            MAV_MISSION_TYPE_FENCE: ItemProtocol(
                MAV_MISSION_TYPE_FENCE, FENCE_RULES, max_fence_items
            ),
            MAV_MISSION_TYPE_RALLY: ItemProtocol(
                MAV_MISSION_TYPE_RALLY, RALLY_RULES, max_rally_items
            ),
        }
        self.requires_mission = requires_mission
        # AP_Mission: _nav_cmd.index / _do_cmd.index (CMD_INDEX_NONE: none), _flags.state,
        # _jump_tracking (jump index → times run, at most MAX_JUMP_COMMANDS entries)
        self.nav_index = CMD_INDEX_NONE
        self.do_index = CMD_INDEX_NONE
        self.state = MISSION_STOPPED
        self.jumps_run: dict[int, int] = {}

    @property
    def current_seq(self) -> int:
        """AP_Mission::get_current_nav_index: 0 while there is no current command."""
        return 0 if self.nav_index == CMD_INDEX_NONE else self.nav_index

    @property
    def _mission(self) -> ItemProtocol:
        return self.protocols[MAV_MISSION_TYPE_MISSION]

    def stored(self, mission_type: int = MAV_MISSION_TYPE_MISSION) -> tuple[StoredItem, ...]:
        return tuple(self.protocols[mission_type].items)

    def mission_state(self) -> int:
        """GCS_MAVLINK::mission_state: NO_MISSION unless AP_Mission::present() (> home)."""
        if len(self._mission.items) <= 1:
            return MISSION_STATE_NO_MISSION
        return MISSION_STATES[self.state]

    def mission_current_fields(self, seq: int | None = None) -> tuple[int, int, int, int]:
        """(seq, total, mission_state, mission_mode) as GCS_MAVLINK::send_mission_current
        fills them; ``seq`` defaults to the current nav index (MSG_CURRENT_WAYPOINT)."""
        total = max(0, len(self._mission.items) - 1)  # home excluded
        return (
            self.current_seq if seq is None else seq,
            total,
            self.mission_state(),
            1 if self.requires_mission() else 0,
        )

    def mission_current(self, seq: int | None = None) -> Message:
        return cast(Message, _mav.mission_current_encode(*self.mission_current_fields(seq)))

    # -- AP_Mission's current command ------------------------------------------------------

    def _command_at(self, index: int) -> StoredItem:
        """read_cmd_from_storage: row 0 is home (a NAV_WAYPOINT)."""
        prot = self._mission
        if index == 0 and prot.home is not None:
            return prot.home
        return prot.items[index]

    def _jump_tag_index(self, tag: int) -> int:
        """get_index_of_jump_tag: the first JUMP_TAG with this tag, 0 if none."""
        for i in range(1, len(self._mission.items)):
            cmd = self._command_at(i)
            if cmd.command == MAV_CMD_JUMP_TAG and int(cmd.param1) == tag:
                return i
        return 0

    def _jump_times_run(self, index: int) -> int:
        """get_jump_times_run (allocates a tracking entry on first use)."""
        if index in self.jumps_run:
            return self.jumps_run[index]
        if len(self.jumps_run) >= MAX_JUMP_COMMANDS:
            return JUMP_TIMES_MAX
        self.jumps_run[index] = 0
        return 0

    def _next_cmd(self, start: int, out: Outcome) -> tuple[int, StoredItem] | None:
        """get_next_cmd(start, cmd, increment_jump_num_times_if_found=true): the first
        non-jump command at or after ``start``, following jumps and counting them."""
        total = len(self._mission.items)
        index = start
        jumps_left = GET_NEXT_CMD_MAX_JUMPS
        while index < total:
            cmd = self._command_at(index)
            if cmd.command not in (MAV_CMD_DO_JUMP, MAV_CMD_DO_JUMP_TAG):
                return index, cmd
            target = int(cmd.param1)
            if cmd.command == MAV_CMD_DO_JUMP_TAG:
                target = self._jump_tag_index(target)
            if jumps_left == 0:
                return None
            jumps_left -= 1
            if target >= total or target == 0:
                return None
            times = int(cmd.param2)
            run = self._jump_times_run(index)
            if times == JUMP_REPEAT_FOREVER or run < times:
                if index in self.jumps_run:  # increment_jump_times_run
                    self.jumps_run[index] += 1
                    of = "unlimited" if times == JUMP_REPEAT_FOREVER else str(times)
                    out.say(
                        SimStatusText(
                            MAV_SEVERITY_INFO, f"Mission: {index} Jump {self.jumps_run[index]}/{of}"
                        )
                    )
                index = target
            else:
                if index in self.jumps_run:  # a finished loop starts over (MIS_OPTIONS 0)
                    self.jumps_run[index] = 0
                index += 1
        return None

    def set_current_cmd(self, index: int, out: Outcome) -> bool:
        """AP_Mission::set_current_cmd."""
        total = len(self._mission.items)
        if index >= total or total == 1:
            return False
        self.do_index = CMD_INDEX_NONE
        if index == 0 or self.state == MISSION_COMPLETE:
            self.jumps_run.clear()  # init_jump_tracking
            index = max(index, 1)
        if self.state == MISSION_RUNNING:  # in AUTO: the command starts at once
            started = self._advance_current_nav_cmd(index, out)
            if started:
                self._say_started(out)
            return started
        while True:
            found = self._next_cmd(index, out)
            if found is None:
                self.nav_index = CMD_INDEX_NONE
                return False
            at, cmd = found
            if is_nav_cmd(cmd.command):
                self.nav_index = at
                break
            if self.do_index == CMD_INDEX_NONE:
                self.do_index = at
            index = at + 1
        self.state = MISSION_STOPPED
        return True

    def _advance_current_nav_cmd(self, index: int, out: Outcome) -> bool:
        """AP_Mission::advance_current_nav_cmd from ``index`` (the mission running); every
        start_command is taken to succeed. Running out of commands completes the mission."""
        for _ in range(ADVANCE_MAX_LOOPS):
            found = self._next_cmd(index, out)
            if found is None:
                break
            at, cmd = found
            if is_nav_cmd(cmd.command):
                self.nav_index = at
                return True
            if self.do_index == CMD_INDEX_NONE:
                self.do_index = at
            index = at + 1
        self.state = MISSION_COMPLETE  # set_current_cmd: "on failure set mission complete"
        return False

    def _reset(self) -> None:
        """AP_Mission::reset."""
        self.nav_index = CMD_INDEX_NONE
        self.do_index = CMD_INDEX_NONE
        self.jumps_run.clear()

    def _resume(self, out: Outcome) -> None:
        """AP_Mission::resume, for a mission set_current_cmd has just stopped at a NAV item
        (``start()`` and the repeat-distance rewind are not reachable from here)."""
        self.state = MISSION_RUNNING
        index = self.do_index if self.do_index != CMD_INDEX_NONE else self.nav_index
        self.set_current_cmd(index, out)

    def do_set_mission_current(
        self, link: int, param1: float, param2: float
    ) -> tuple[int, Outcome]:
        """GCS_MAVLINK::handle_command_do_set_mission_current: (MAV_RESULT, what follows the
        COMMAND_ACK: jump texts, and MISSION_CURRENT to ``link`` when ACCEPTED)."""
        out = Outcome()
        seq = seq_from_param(param1)
        if seq is None or seq >= len(self._mission.items):  # is_valid_index
            return MAV_RESULT_DENIED, out
        reset_and_restart = abs(param2 - 1.0) < FLT_EPSILON
        if reset_and_restart:
            self._reset()
        if not self.set_current_cmd(seq, out):
            return MAV_RESULT_FAILED, out
        if reset_and_restart:
            self._resume(out)
        out.send((link, self.mission_current()))  # send_message(MSG_CURRENT_WAYPOINT)
        return MAV_RESULT_ACCEPTED, out

    # -- messages --------------------------------------------------------------------------

    def handle(self, link: int, msg: Any, now_s: float) -> Outcome:
        out = Outcome()
        kind = msg.get_type()
        if kind not in self.MESSAGES or kind == "MISSION_ACK":
            return out  # MISSION_ACK from a GCS: nothing to do
        who = (int(msg.get_srcSystem()), int(msg.get_srcComponent()))
        if kind == "MISSION_SET_CURRENT":
            seq = int(msg.seq)
            if self.set_current_cmd(seq, out):
                out.send((link, self.mission_current(seq)))  # the requested seq, echoed
            return out
        mission_type = int(getattr(msg, "mission_type", 0))
        prot = self.protocols.get(mission_type)
        if prot is None:
            out.send((link, mission_ack(who, MAV_MISSION_UNSUPPORTED, mission_type)))
            return out
        if kind == "MISSION_COUNT":
            prot.handle_count(out, link, who, msg, now_s)
        elif kind == "MISSION_ITEM_INT":
            prot.handle_item(out, link, who, item_from_int(msg), int(msg.seq), now_s)
        elif kind == "MISSION_ITEM":
            prot.handle_item(out, link, who, item_from_float(msg), int(msg.seq), now_s)
        elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            as_int = kind == "MISSION_REQUEST_INT"
            prot.handle_request(out, link, who, msg, as_int, self.nav_index)
        elif kind == "MISSION_REQUEST_LIST":
            prot.handle_request_list(out, link, who, msg)
        elif kind == "MISSION_CLEAR_ALL":
            cleared = prot.upload is None
            prot.handle_clear_all(out, link, who)
            if mission_type == MAV_MISSION_TYPE_MISSION and cleared:
                # AP_Mission::clear (ArduPilot refuses it while armed with the mission
                # running in AUTO: not modelled)
                self._reset()
                self.state = MISSION_STOPPED
        return out

    # -- AP_Mission running in AUTO (ModeAuto drives it: helixd.sim.firmware.mode_auto) ------

    def nav_item(self) -> tuple[int, StoredItem] | None:
        """The current nav command (index, item) while the mission runs; None otherwise."""
        if self.state != MISSION_RUNNING or self.nav_index == CMD_INDEX_NONE:
            return None
        if self.nav_index >= len(self._mission.items):
            return None
        return self.nav_index, self._command_at(self.nav_index)

    def start_or_resume(self, out: Outcome) -> None:
        """AP_Mission::start_or_resume with MIS_RESTART 0 (resume): a completed mission, or
        one with no current command (or one the mission no longer has), starts from its first
        command (jump counters cleared); otherwise the current nav command starts again. Each
        nav command started says "Mission: N WP" (AP_Mission::start_command)."""
        if self.state == MISSION_RUNNING:
            return
        # a current command the stored mission no longer has (a shorter one uploaded since):
        # AP_Mission::resume finds read_cmd_from_storage failing and starts again
        gone = self.nav_index != CMD_INDEX_NONE and self.nav_index >= len(self._mission.items)
        restart = self.state == MISSION_COMPLETE or self.nav_index == CMD_INDEX_NONE or gone
        self.state = MISSION_RUNNING
        if restart:
            self.jumps_run.clear()
            self.do_index = CMD_INDEX_NONE
            if not self._advance_current_nav_cmd(1, out):
                return
        self._say_started(out)

    def stop(self) -> None:
        """AP_Mission::stop (ModeAuto::_exit: leaving AUTO stops a running mission)."""
        if self.state == MISSION_RUNNING:
            self.state = MISSION_STOPPED

    def nav_done(self, out: Outcome) -> bool:
        """The current nav command verified: on to the next one (True), or the mission is
        complete (False; the caller says "Mission Complete", ModeAuto::exit_mission)."""
        if self.state != MISSION_RUNNING or self.nav_index == CMD_INDEX_NONE:
            return False
        self.do_index = CMD_INDEX_NONE
        if not self._advance_current_nav_cmd(self.nav_index + 1, out):
            return False
        self._say_started(out)
        return True

    def _say_started(self, out: Outcome) -> None:
        if self.state == MISSION_RUNNING and self.nav_index != CMD_INDEX_NONE:
            cmd = self._command_at(self.nav_index)
            name = COMMAND_TYPES.get(cmd.command, f"Cmd{cmd.command}")
            out.say(SimStatusText(MAV_SEVERITY_INFO, f"Mission: {self.nav_index} {name}"))

    def reset_on_disarm(self) -> None:
        """``AP_Arming_Rover::disarm`` outside AUTO: ``mission.reset()`` — no current command
        (MISSION_CURRENT seq 0), jump counters cleared; the state is left as it was."""
        self._reset()

    def reboot(self) -> None:
        """A reboot loses uploads in progress and the current command (AP_Mission's
        constructor: no nav command, stopped); stored items persist."""
        for prot in self.protocols.values():
            prot.upload = None
        self._reset()
        self.state = MISSION_STOPPED

    def update(self, now_s: float) -> Outcome:
        out = Outcome()
        for prot in self.protocols.values():
            prot.update(out, now_s)
        return out
