"""One soak day (tools/soak.py): ``helixd serve`` on the simulated clock beside the built-in
simulator, a QGroundControl-like crew pressing the day's buttons, the day's faults injected,
and the rules checked on every snapshot the simulator publishes (its truth, not helixd's log).

:class:`Rules` is the referee. Per snapshot (each autopilot loop, 50 Hz): the scroll outputs
at trim within :data:`STOP_LIMIT_S` of the crew's stop word (Pause, HOLD, MANUAL, disarm, the
start switch low, the radio's mode switch) and of helixd saying the mission completed, and
held there until the crew's next go word; within a fault's limit (:data:`FAULT_LIMIT_S`) of a
fault injected while driving; never driven while disarmed; never outside the fence; the
autopilot's current item moving only along the mission (next item, a DO_JUMP's target, or
where the crew set it). Per fault injected while driving: the fall-back reported once, named
as the fault (:data:`FAULT_CAUSES`). Per day: no traceback or error-level exception line, the
service's exit 0 on SIGTERM, asyncio tasks and file descriptors flat, every run directory
with a summary ``replay`` reads.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import io
import json
import math
import os
import signal
import sys
import time
import traceback
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium
from helixd.cli.runs import load_summary, print_replay
from helixd.config.safety import StallConfig
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_FRAME_GLOBAL,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
)
from helixd.recorder.rundir import RunRecorder, default_opener
from helixd.sim.firmware.modes import MODE_NUMBERS
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import deep_merge
from tests.support.gcs import HELIXD, QGC_SYSID, SIM, do_item, fence_circle, latlon, waypoint
from tests.support.harness import NEUTRAL_TOLERANCE_US, NEUTRAL_US, guard_installed
from tests.support.kill9 import KILLED_CODE
from tests.support.loop_gcs import upload_fence, upload_items
from tests.support.loop_mav import LoopMav
from tests.support.serve import HIGH_US, LOW_US, SWITCH_CH
from tests.support.simulated import Steer, simulated_serve
from tests.support.soak_plan import (
    DAY_FAULTS,
    FENCE_RADIUS_M,
    GO_WORDS,
    STOP_WORDS,
    DayPlan,
    Item,
    Step,
)
from tests.support.soak_resume import KillsTold, ResumeRule, navs_from

STOP_LIMIT_S = 0.5  # the crew's stop word (and helixd's "completed") → scrolls at trim
# a disarm shows to helixd only in the autopilot's 1 Hz HEARTBEAT, and ArduPilot passes the
# RC-passthrough scroll channels through while disarmed: helixd's overrides must go within one
# period and the fall-back's 0.5 s
DISARMED_LIMIT_S = 1.5
# A mode the crew picks (HOLD, MANUAL, the radio's mode switch) shows to helixd within
# 0.2 s while the autopilot is in AUTO (MISSION_CURRENT's mission_mode, 5 Hz), otherwise only
# in its 1 Hz HEARTBEAT (README, "Safety": a person's mode change is a pilot takeover, its
# fall-back within 0.5 s of detection): one period and the fall-back's tick
MODE_WORDS = {"pause": "HOLD", "manual": "MANUAL", "radio_mode": ""}  # word: the mode it sets
HEARTBEAT_LIMIT_S = 1.2
# a fault injected while driving → scrolls at trim: the time helixd's watchdog needs to see it
# (helixd.config.safety.SafetyConfig's defaults) and the fall-back's 0.5 s
FAULT_LIMIT_S: dict[str, float] = {
    "link_drop": 1.0, "stale_pose": 1.5, "ekf_unhealthy": 1.5, "reboot": 1.5, "gps_loss": 6.0,
    "gps_silent": 3.0, "battery_low": 1.5, "fence_breach": 1.5, "rc_loss": 2.0, "stall": 12.0,
    "nan_position": 1.0, "nan_yaw": 1.0, "absurd_position": 1.0, "time_backwards": 1.0,
    "kill": 0.8,
}  # fmt: skip
# kill: helixd-guard (guard_installed(1.0)) puts the scroll outputs at trim HXG_TIMEOUT 0.5 s
# after helixd's last word to it, which helixd sends every serve.tick_s (0.1 s), read by
# the guard's loop and shown at the autopilot's next output (0.02 s): 0.62 s at most (0.56 s
# measured, tests/integration/test_serve_kill.py), and a margin
# a fault shorter than this may be over before helixd's watchdog sees it (safety.stall's 4 s)
# helixd's stall watch is armed while it commands more than safety.stall's 0.2 m/s: a stall
# of a rover slower than that (creeping the last centimetres onto a waypoint, seed 100: 0.09 m
# from it for the stall's 5.8 s, then on to the next) is not one helixd can see
STALL_ARMED_MPS = StallConfig().commanded_speed_min_mps
SEEN_AFTER_S = {"stall": 4.5}
# the cause helixd must name for each fault (summary.json's fault, the fallback event's cause)
FAULT_CAUSES: dict[str, frozenset[str]] = {
    "link_drop": frozenset({"link_lost"}),
    "stale_pose": frozenset({"pose_stale"}),
    "ekf_unhealthy": frozenset({"ekf_unhealthy", "autopilot_ekf"}),
    "reboot": frozenset({"link_lost", "disarmed"}),
    "gps_loss": frozenset({"gps_lost", "ekf_unhealthy", "autopilot_ekf"}),
    "gps_silent": frozenset({"gps_lost"}),
    "battery_low": frozenset({"autopilot_battery"}),
    "fence_breach": frozenset({"autopilot_fence", "geofence"}),
    "rc_loss": frozenset({"rc_lost", "autopilot_radio"}),
    "stall": frozenset({"stall"}),
    "nan_position": frozenset({"pose_invalid"}),
    "nan_yaw": frozenset({"pose_invalid"}),
    "absurd_position": frozenset({"pose_invalid"}),
    "time_backwards": frozenset({"pose_invalid"}),
}
# the crew's words that hand a mission's flight over to one to the autopilot's place: the
# mission's flight is interrupted there (a continue goes on from it)
HANDOVER_WORDS = frozenset({"goto", "rtl", "smart_rtl"})
# ArduPilot's battery and fence failsafes switched on (HOLD), as a field's parameters would
AUTOPILOT_PARAMS = {"BATT_FS_LOW_ACT": 2.0, "FENCE_ENABLE": 1.0, "FENCE_ACTION": 2.0}
# the fault's fall-back logged within this of it at the latest: a cut link (or a rebooting
# autopilot) is named after safety.heartbeat_timeout_s (2 s) of silence
NAMED_WITHIN_S = 2.5
# modes ArduPilot drives in when armed (arming in them starts the mission or the place)
DRIVING_MODES = frozenset({"AUTO", "GUIDED", "RTL", "SMART_RTL"})
# ArduPilot's battery and fence failsafes act once (until a reboot): a second one is no news
LATCHING = frozenset({"battery_low", "fence_breach"})
# faults helixd cannot see, by design (README, "Safety"): a receiver that just stops sending
# while helixd overrides every channel it reads
UNSEEN = frozenset({("rc_loss", "no_pulses")})
FENCE_MARGIN_M = 3.0  # beyond the fence by less than a stop from full speed is not "outside"
CREW_TIMEOUT_S = 3.0  # a press the autopilot or helixd does not answer in this is refused
# the service's defaults where the serve tests speed them up (a field day polls as the field does)
SERVE_CONFIG: dict[str, Any] = {
    "link": {"own_id_watch_s": 0.5},
    "serve": {"mission_poll_s": 10.0, "tick_s": 0.1, "state_rate_hz": 1.0},
}
NO_SWITCH: dict[str, Any] = {"startup": {"start_switch_channel": None}}
EVENING_S = 600.0  # simulated seconds a day may run past its length (boot, the evening) at most
TASKS_SLACK = 3  # asyncio tasks a quiet service may have more at the end than at the start
FDS_SLACK = 3
# resident memory (MB) the process may grow by over the day's second half (the first warms
# caches up: imports, the first flight's recorder and plots) beyond what the harness keeps of
# the console's lines meanwhile (console_mb)
RSS_SLACK_MB = 25.0
# the simulator's event history: an entry (~340 B) for every scroll output change, 50 Hz a
# channel while driving, up to its 200 000-entry default (~70 MB) a long day fills, which the
# soak never reads (the rules read the snapshots): a day keeps only its latest entries, so
# the memory rule measures helixd, not the rig's record of the day (seed 101)
SIM_HISTORY_ENTRIES = 1_000
# the full card: flight.csv's writes raise ENOSPC while it is full; a card full for this long
# while a flight records is cut (a row goes out every control tick) and must be told
CARD_FILE = "flight.csv"
CARD_SEEN_AFTER_S = 2.0
CARD_TOLD_WITHIN_S = 2.0  # after the card is free again: the record_cut line is there


class Card:
    """The recorder's card (the day's ``full_card`` fault): while ``full``, every write of
    flight.csv raises ``OSError(ENOSPC)``, as a card with no space left does."""

    def __init__(self) -> None:
        self.full = False

    def opener(self, path: Path, mode: str) -> IO[str]:
        fh = default_opener(path, mode)
        if path.name != CARD_FILE:
            return fh
        real_write = fh.write

        def write(text: str) -> int:
            if self.full:
                raise OSError(errno.ENOSPC, "No space left on device", str(path))
            return real_write(text)

        fh.write = write  # type: ignore[method-assign]
        return fh


@contextlib.contextmanager
def card_in_recorder(card: Card) -> Iterator[None]:
    """Every run directory created meanwhile writes through ``card``."""
    real = RunRecorder.__dict__["create"]
    bound = RunRecorder.create

    def create(*args: Any, **kwargs: Any) -> RunRecorder:
        return bound(*args, **{**kwargs, "opener": card.opener})

    RunRecorder.create = create  # type: ignore[method-assign]
    try:
        yield
    finally:
        RunRecorder.create = real  # type: ignore[method-assign]


def logged_value(line: str, key: str) -> str:
    """The value of ``key=`` in a logfmt console line ('' if absent; quotes taken off)."""
    _, sep, rest = line.partition(f" {key}=")
    if not sep:
        return ""
    if rest.startswith('"'):
        return rest[1:].split('"', 1)[0]
    return rest.split(" ", 1)[0]


@dataclass
class Violation:
    rule: str
    at_s: float
    detail: str


@dataclass
class DayResult:
    seed: int
    simulated_s: float
    wall_s: float
    cpu_s: float  # this process's CPU time for the day (the wall's depends on the machine's load)
    violation: Violation | None
    actions: dict[str, int] = field(default_factory=dict)
    faults: dict[str, int] = field(default_factory=dict)
    events: list[str] = field(default_factory=list)  # the last steps and log lines
    done: list[Step] = field(default_factory=list)  # the steps performed, in order
    rss_mb: tuple[float, float] = (0.0, 0.0)  # resident memory at midday and at the end


class Broken(Exception):
    """A rule broke: the day stops here."""

    def __init__(self, violation: Violation) -> None:
        super().__init__(f"{violation.rule} at {violation.at_s:.2f} s: {violation.detail}")
        self.violation = violation


def nav_successors(items: tuple[Item, ...]) -> dict[int, set[int]]:
    """For each navigation item, the navigation items the autopilot may go to next: the one
    after it, or, past a DO_JUMP, its target (taken) and the one after the jump (done)."""

    def next_navs(start: int, seen: frozenset[int] = frozenset()) -> set[int]:
        out: set[int] = set()
        for j in range(start, len(items)):
            it = items[j]
            if it.is_nav:
                out.add(j)
                return out
            if it.command == mavlink.MAV_CMD_DO_JUMP and j not in seen:
                target = int(it.params[0])
                out |= next_navs(target, seen | {j})
        return out

    return {i: next_navs(i + 1) for i, it in enumerate(items) if it.is_nav}


class Rules:
    """The referee: fed every snapshot and every log line, raises :class:`Broken`."""

    def __init__(self, st: Steer) -> None:
        self.st = st
        self.stop_at: float | None = None  # the crew's latest word is stop, since
        self.stop_limit_s = STOP_LIMIT_S
        self.fault_at: float | None = None
        self.fault_limit_s = 0.0
        self.disarmed_at: float | None = None
        self.completed_at: float | None = None
        self.items: tuple[Item, ...] = ()
        self.successors: dict[int, set[int]] = {}
        self.flown_successors: dict[int, set[int]] = {}  # the flight's plan, uploaded over
        self.free_until = 0.0  # item changes are the crew's (or a reboot's) until then
        self.last_seq = 0
        # the items helixd set as the autopilot's current (mission_current_set), latest last,
        # and whether the crew's set current moved that display while helixd drives in MANUAL
        self.shown: tuple[int, ...] = ()
        self.crew_moved_shown = False
        self.mode_switch = ""  # the mode of the radio's mode switch position ('' unknown)
        self.lines_seen = 0
        self.log_times: list[float] = []  # simulated time each console line was first seen
        self.broken: Violation | None = None
        self.pending: list[tuple[str, float, float]] = []  # faults to be named: kind, at, by
        self.latched: set[str] = set()  # the autopilot's failsafes already taken
        self.fault_times: list[float] = []  # when each fault was injected
        self.go_times: list[float] = []  # when the crew said go
        self.t0 = 0.0  # the day's time 0 (the plan's steps count from it)
        self.serve_state = ""  # the service's latest serve_state
        self.flight_request = ""  # what started the latest flight (serve_flight_start)
        self.flight_at = 0.0  # when it started
        self.uploaded_at = 0.0  # the crew's latest upload (a flight before it: another plan)
        self.run_dir = ""  # the run directory of the latest flight (helixd_start)
        self.cuts: Counter[str] = Counter()  # record_cut warnings per run directory
        # full cards to be told: (run directory, console line at the fault, check after)
        self.cards: list[tuple[str, int, float]] = []
        self.kills = KillsTold()  # each kill told by the next start when it cut a flight
        self.resume = ResumeRule()  # a continue goes on from the interrupted item

    def fail(self, rule: str, detail: str) -> None:
        if self.broken is None:
            self.broken = Violation(rule, now_s() - self.t0, detail)

    # -- the crew's words --------------------------------------------------------------------
    def word(self, name: str, mode: str, arg: object = None, armed: bool = True) -> None:
        t = now_s()
        if name == "disarm" and not armed:
            return  # a disarmed rover disarmed: nothing anyone can see
        if name == "radio_mode":
            # ArduPilot acts on the mode switch moved, not on its position
            # (RC_Channel::read_mode_switch → debounce_completed: a position equal to
            # switch_state.current_position changes nothing): the switch put where it stands
            # is no word (seed 102: HOLD, later GCS modes, HOLD again, the mode left as it was)
            was, self.mode_switch = self.mode_switch, str(arg)
            if was == arg:
                return
        if name in MODE_WORDS and mode == (arg or MODE_WORDS[name]):
            return  # the mode it already is: nothing the autopilot or helixd can see
        if name == "arm" and mode in DRIVING_MODES:
            name = "continue"  # ArduPilot armed in AUTO (GUIDED, RTL) drives: a go word
        if name in STOP_WORDS or name in HANDOVER_WORDS:
            self.resume.interrupted(
                self.mission_flying(), self.last_seq, navs_from(self.items, self.last_seq), t
            )
        self.resume.word(name, t)
        if name in STOP_WORDS:
            limit = DISARMED_LIMIT_S if name == "disarm" else STOP_LIMIT_S
            if name in MODE_WORDS and mode != "AUTO":
                limit = HEARTBEAT_LIMIT_S
            if self.stop_at is None or t + limit < self.stop_at + self.stop_limit_s:
                self.stop_at, self.stop_limit_s = t, limit
        elif name in GO_WORDS:
            self.stop_at = self.fault_at = self.completed_at = None
            self.go_times.append(t)
        if name == "set_current" and self.serve_state == "flying":
            self.crew_moved_shown = True
        if name in GO_WORDS or name in STOP_WORDS or name in ("set_current", "upload", "reupload"):
            # the crew's (re)start or continue may go on from an earlier item (the
            # interrupted leg's) or a later one, and a flight helixd drives in MANUAL shows
            # the item it stopped at when it is stopped: the items are the crew's for a moment
            self.free_until = t + 3.0

    def fault(self, kind: str, driving: bool, args: dict[str, object]) -> None:
        t = now_s()
        self.free_until = max(self.free_until, t + 3.0)  # a reboot resets the mission
        if kind == "reboot":
            self.latched.clear()
        if kind in LATCHING:
            if kind in self.latched:
                return  # ArduPilot's failsafe fires once: already taken since the boot
            self.latched.add(kind)
        self.fault_times.append(t)
        if not driving or (kind, args.get("kind")) in UNSEEN:
            # a fault helixd cannot see interrupts nothing: the flight goes on, its item with
            # it (seed 4001: a receiver's silence, waypoint 1 reached 12 s later, then AUTO)
            return
        duration = args.get("duration_s")
        unseen = isinstance(duration, float) and duration < SEEN_AFTER_S.get(
            kind, FAULT_LIMIT_S[kind]
        )  # over before helixd's watchdog may see it (a 2.5 s stall: 4 s to notice)
        if not unseen:
            self.resume.interrupted(
                self.mission_flying(), self.last_seq, navs_from(self.items, self.last_seq), t
            )
        if kind == "kill":  # told by the next start (KillsTold), not by a fall-back
            self.fault_at = t if self.fault_at is None else self.fault_at
            self.fault_limit_s = FAULT_LIMIT_S[kind] if self.fault_at == t else self.fault_limit_s
            return
        if unseen:
            return
        if self.fault_at is None:
            self.fault_at, self.fault_limit_s = t, FAULT_LIMIT_S[kind]
        self.pending.append((kind, t, t + max(FAULT_LIMIT_S[kind], NAMED_WITHIN_S) + 2.0))

    def kill(self, driving: bool) -> None:
        """helixd killed: the scrolls at trim by the guard, the cut flight told by the next
        start; a flight under way is interrupted (whatever it drove)."""
        cut = bool(self.run_dir) and not (Path(self.run_dir) / "summary.json").exists()
        self.kills.kill(now_s(), len(self.st.console.lines), cut)
        if not driving:
            self.resume.interrupted(
                self.mission_flying(), self.last_seq, navs_from(self.items, self.last_seq), now_s()
            )
        self.fault("kill", driving, {})

    def mission_flying(self) -> bool:
        """A flight of the mission under way: not one to the autopilot's place (its
        interruption leaves the mission's interrupted item as it was), nor one of a plan
        uploaded over since (a continue flies the new one whole; soak seed 24)."""
        flying = self.serve_state == "flying" and self.flight_request != "goto"
        return flying and self.flight_at > self.uploaded_at

    def full_card(self, duration_s: float) -> None:
        """The card full for ``duration_s``: a flight recording meanwhile must say so, once."""
        if self.serve_state == "flying" and duration_s >= CARD_SEEN_AFTER_S:
            by = now_s() + duration_s + CARD_TOLD_WITHIN_S
            self.cards.append((self.run_dir, len(self.st.console.lines), by))

    def mission(self, items: tuple[Item, ...]) -> None:
        self.uploaded_at = now_s()
        self.items = items
        # a flight under way flies the plan it started with until it ends (seed 282: its
        # DO_JUMP from item 9 back to 2 after the crew uploaded another plan)
        self.flown_successors = self.successors if self.serve_state == "flying" else {}
        self.successors = nav_successors(items)
        self.shown = ()
        self.free_until = now_s() + 3.0

    # -- every snapshot ----------------------------------------------------------------------
    def snapshot(self, s: SimSnapshot) -> None:
        t = now_s()
        self._lines(t)
        driven = driving(s)
        if not s.armed:
            self.disarmed_at = self.disarmed_at if self.disarmed_at is not None else t
        else:
            self.disarmed_at = None
        if driven:
            self._driven(t, s)
        dist = math.hypot(s.north_m, s.east_m)
        if dist > FENCE_RADIUS_M + FENCE_MARGIN_M:
            self.fail("outside_fence", f"{dist:.1f} m from home; {s.describe()}")
        self._items(t, s)
        broken = self.resume.driven(t, s.mission_current_seq, driven, self.successors)
        if broken is not None:
            self.fail("resume_item", f"{broken}; {s.describe()}")

    def _driven(self, t: float, s: SimSnapshot) -> None:
        if self.disarmed_at is not None and t - self.disarmed_at > DISARMED_LIMIT_S:
            self.fail("driven_disarmed", s.describe())
        if self.stop_at is not None and t - self.stop_at > self.stop_limit_s:
            self.fail("driven_after_stop", f"stop {t - self.stop_at:.2f} s ago; {s.describe()}")
        if self.fault_at is not None and t - self.fault_at > self.fault_limit_s:
            self.fail("driven_after_fault", f"fault {t - self.fault_at:.2f} s ago; {s.describe()}")
        if self.completed_at is not None and t - self.completed_at > STOP_LIMIT_S:
            self.fail("driven_after_completed", s.describe())

    def _items(self, t: float, s: SimSnapshot) -> None:
        seq = s.mission_current_seq
        if seq == self.last_seq:
            return
        before, self.last_seq = self.last_seq, seq
        # 0: the autopilot's mission at rest (helixd flying it in MANUAL shows the item it
        # stopped at when it pauses); 1: a start from the beginning
        if t < self.free_until or seq <= 1 or before == 0 or not self.successors:
            return
        allowed = self.successors.get(before, set()) | self.flown_successors.get(before, set())
        if seq not in allowed and not self._shown_again(s.mode, seq):
            self.fail("item_order", f"current item {before} -> {seq}, expected one of {allowed}")

    def _shown_again(self, mode: str, seq: int) -> bool:
        """Whether ``seq`` is helixd's own display coming back after the crew's set current.
        A flight helixd drives in MANUAL (the start switch, its own id) shows the item it flies
        as the autopilot's current (serve/flights.py ``_set_current_item``) and follows its own
        walk: set current is a command of AUTO (README, "Set current waypoint"; ArduPilot's
        mission is not running in MANUAL, ``AP_Mission::set_current_cmd`` only moves its
        current command). The crew's set current then moves the display alone, and helixd's
        next step shows its own item again: that move follows the item helixd showed last
        (seed 102: items 4, 7 set by the crew, then helixd's 3 after its 1)."""
        if not self.crew_moved_shown or mode != "MANUAL":
            return False
        back = any(seq == h or seq in self.successors.get(h, set()) for h in self.shown[-2:])
        if back:
            self.crew_moved_shown = False
        return back

    def _lines(self, t: float) -> None:
        lines = self.st.console.lines
        while self.lines_seen < len(lines):
            text = lines[self.lines_seen]
            self.lines_seen += 1
            self.log_times.append(t)
            if "Traceback" in text or "event=exception" in text:
                self.fail("traceback", text[:300])
            if "event=serve_state state=completed" in text:
                self.completed_at = t
            if "event=sim_statustext " in text and 'text="Mission Complete"' in text:
                self.resume.autopilot_done()
            if "event=serve_state " in text:
                self.serve_state = logged_value(text, "state")
                self.crew_moved_shown = False
            elif "event=serve_flight_start " in text:
                self.flight_request, self.flight_at = logged_value(text, "request"), t
                self.flown_successors = {}  # a new flight flies the plan there is now
            elif "event=mission_current_set " in text:
                self.shown = (*self.shown[-1:], int(logged_value(text, "seq")))
            elif "event=helixd_start " in text:
                self.run_dir = logged_value(text, "run_dir")
            elif "event=record_cut " in text:
                run = str(Path(logged_value(text, "path")).parent)
                self.cuts[run] += 1
                if self.cuts[run] > 1:
                    self.fail("card_full_once", f"a second record_cut in {run}: {text[:200]}")
        for run, mark, by in list(self.cards):
            if t > by:
                self.cards.remove((run, mark, by))
                self._card_told(run, mark)
        for kind, at, by in list(self.pending):
            if t > by:
                self.pending.remove((kind, at, by))
                self._named(kind, at, by)
        broken = self.kills.due(t, self.st.console.lines)
        if broken is not None:
            self.fail("fault_named", broken)

    def _card_told(self, run: str, mark: int) -> None:
        later = self.st.console.lines[mark:]
        if any("event=serve_state " in ln for ln in later):
            return  # the flight stopped or ended meanwhile: it may have written nothing since
        if self.cuts[run] != 1:
            self.fail("card_full_reported", f"a full card in {run} told {self.cuts[run]} times")

    def _named(self, kind: str, at: float, by: float) -> None:
        # a go word ends the window: a new flight may meet the same fault and be told again
        window_end = min([by, *(g for g in self.go_times if g > at)])
        causes = [
            line.split("cause=")[1].split()[0]
            for line, seen in zip(self.st.console.lines, self.log_times, strict=False)
            if at <= seen <= window_end and "event=fallback" in line and "cause=" in line
        ]
        if self.stop_at is not None and self.stop_at < by:
            return  # the crew stopped it meanwhile: whose stop was reported is open
        if window_end < by and not causes:
            return  # the crew said go before it was told: the new flight's checks decide
        if any(at < other <= by for other in self.fault_times):
            return  # another fault came meanwhile: which one was named first is open
        if len(causes) != 1 or causes[0] not in FAULT_CAUSES[kind]:
            self.fail("fault_named", f"{kind} at {at - self.t0:.2f} s reported as {causes}")


def driving(s: SimSnapshot) -> bool:
    """A scroll output away from trim (0: no pulses, as while booting, drives nothing)."""
    return any(p != 0 and abs(p - NEUTRAL_US) > NEUTRAL_TOLERANCE_US for p in s.scroll_pwm_us)


def items_msgs(items: tuple[Item, ...]) -> list[Any]:
    out = []
    for seq, it in enumerate(items):
        if it.is_nav:
            out.append(waypoint(seq, it.north_m, it.east_m))
        else:
            out.append(do_item(seq, it.command, *it.params))
    return out


def fence_msgs() -> list[Any]:
    return [fence_circle(0, 0.0, 0.0, FENCE_RADIUS_M, inclusion=True)]


def num(step: Step, key: str) -> float:
    return float(str(step.arg(key)))


class Crew:
    """The day's hands: performs each step through the ground station or the simulator."""

    def __init__(
        self, st: Steer, gcs: LoopMav, rules: Rules, plan: DayPlan, card: Card | None = None
    ) -> None:
        self.st, self.gcs, self.rules, self.plan = st, gcs, rules, plan
        self.card = Card() if card is None else card
        self.rss_mb = (0.0, 0.0)  # resident memory at midday and at the end
        self.lines_at_midday = 0  # the console's lines then
        self.actions: dict[str, int] = {}
        self.faults: dict[str, int] = {}
        self.done: list[Step] = []
        self.t0 = now_s()
        self.simulated_s = 0.0
        self.before = (0, 0)  # asyncio tasks, descriptors once the service is up
        self.next_step = 0  # the plan's next step (the day goes on after a restart)
        self.restarted_at = 0  # the console's line count at the last restart

    async def mode(self, name: str) -> None:
        flag = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        await self.gcs.command(
            MAV_CMD_DO_SET_MODE, flag, MODE_NUMBERS[name], timeout_s=CREW_TIMEOUT_S
        )

    async def ap(self, cmd: int, *params: float) -> None:
        await self.gcs.command(cmd, *params, timeout_s=CREW_TIMEOUT_S)

    async def helixd(self, cmd: int, *params: float) -> None:
        self.gcs.heartbeat()
        await self.gcs.command(cmd, *params, target=HELIXD, timeout_s=CREW_TIMEOUT_S)

    async def goto(self, step: Step) -> None:
        lat, lon = latlon(float(str(step.arg("north_m"))), float(str(step.arg("east_m"))))
        self.gcs.drain()
        self.gcs.mav.command_int_send(
            1, 1, MAV_FRAME_GLOBAL, MAV_CMD_DO_REPOSITION, 0, 0,
            -1.0, float(MAV_DO_REPOSITION_FLAGS_CHANGE_MODE), 0.0, math.nan,
            round(lat * 1e7), round(lon * 1e7), SIM.origin_alt_m,
        )  # fmt: skip
        await self.gcs.recv(
            "COMMAND_ACK", CREW_TIMEOUT_S, lambda m: int(m.command) == MAV_CMD_DO_REPOSITION
        )

    async def upload(self, step: Step) -> None:
        items = self.plan.missions[int(str(step.arg("items")))]
        self.rules.mission(items)
        await upload_items(self.gcs, items_msgs(items), CREW_TIMEOUT_S * 3)
        if step.name == "upload":
            await upload_fence(self.gcs, fence_msgs(), CREW_TIMEOUT_S * 3)

    async def start(self) -> None:
        """QGroundControl's Start Mission on a disarmed rover: GUIDED, arm, MISSION_START."""
        await self.mode("GUIDED")
        await self.ap(MAV_CMD_COMPONENT_ARM_DISARM, 1)
        await self.ap(MAV_CMD_MISSION_START, 0, 0)

    def table(self) -> dict[str, Callable[[Step], Any]]:
        return {
            "upload": self.upload, "reupload": self.upload,
            "start": lambda _: self.start(),
            "start_helixd": lambda _: self.helixd(MAV_CMD_MISSION_START, 0, 0),
            "pause": lambda _: self.mode("HOLD"),
            "pause_helixd": lambda _: self.helixd(MAV_CMD_DO_PAUSE_CONTINUE, 0),
            "continue": lambda _: self.mode("AUTO"),
            "continue_helixd": lambda _: self.helixd(MAV_CMD_DO_PAUSE_CONTINUE, 1),
            "set_current": lambda s: self.ap(MAV_CMD_DO_SET_MISSION_CURRENT, num(s, "seq")),
            "goto": self.goto,
            "rtl": lambda _: self.mode("RTL"),
            "smart_rtl": lambda _: self.mode("SMART_RTL"),
            "manual": lambda _: self.mode("MANUAL"),
            "disarm": lambda _: self.ap(MAV_CMD_COMPONENT_ARM_DISARM, 0),
            "arm": lambda _: self.ap(MAV_CMD_COMPONENT_ARM_DISARM, 1),
            "speed_helixd": lambda s: self.helixd(
                MAV_CMD_DO_CHANGE_SPEED, 1, num(s, "speed_mps"), -1
            ),
            "switch_high": lambda _: self.switch(HIGH_US),
            "switch_low": lambda _: self.switch(LOW_US),
            "radio_mode": lambda s: self.radio_mode(str(s.arg("mode"))),
            "restart": lambda _: self.nothing(),
        }  # fmt: skip

    def day_fault(self, step: Step) -> None:
        """One of the day's own faults (not the simulator's): ``full_card`` (``kill``:
        :func:`crew_day` kills the service after the referee took note)."""
        if step.name == "kill":
            self.rules.kill(driving(self.st.snapshot()))
            return
        assert step.name == "full_card", step.name
        duration_s = num(step, "duration_s")
        self.rules.full_card(duration_s)
        self.card.full = True

        def free() -> None:
            self.card.full = False

        asyncio.get_running_loop().call_later(duration_s, free)

    async def nothing(self) -> None:
        """The step is the day's (``restart``: crew_day stops the service)."""

    async def switch(self, pwm_us: int) -> None:
        self.st.set_rc(SWITCH_CH, pwm_us)

    async def radio_mode(self, mode: str) -> None:
        self.st.inject("pilot_takeover", mode=mode)

    async def perform(self, step: Step) -> None:
        self.done.append(step)
        self.simulated_s = now_s() - self.t0
        if step.kind == "fault":
            self.faults[step.name] = self.faults.get(step.name, 0) + 1
            if step.name in DAY_FAULTS:
                self.day_fault(step)
                return
            snap = self.st.snapshot()
            driving_now = driving(snap)
            if step.name == "stall" and snap.speed_mps < STALL_ARMED_MPS:
                driving_now = False  # creeping onto a waypoint: helixd's watch is not armed
            self.rules.fault(step.name, driving_now, dict(step.args))
            self.st.inject(step.name, **dict(step.args))
            return
        self.actions[step.name] = self.actions.get(step.name, 0) + 1
        snap = self.st.snapshot()
        # the pilot's transmitter (its mode switch, the start switch) through a dead receiver
        # switches nothing
        if step.name not in ("radio_mode", "switch_low", "switch_high") or snap.receiver_ok:
            self.rules.word(step.name, snap.mode, step.arg("mode"), snap.armed)
        elif step.name == "radio_mode":  # moved all the same: read when the receiver is back
            self.rules.mode_switch = str(step.arg("mode"))
        # refused or unanswered (a link down, a rebooting autopilot): the crew goes on
        with contextlib.suppress(AssertionError):
            await self.table()[step.name](step)


def resources() -> tuple[int, int]:
    """(asyncio tasks, open file descriptors) of this process."""
    return len(asyncio.all_tasks()), len(os.listdir("/proc/self/fd"))


def console_mb(lines: list[str]) -> float:
    """What the harness keeps of these console lines (the line, its list slot, the
    referee's time for it): the process grows by this beside helixd."""
    return sum(sys.getsizeof(line) + 8 + 32 for line in lines) / 1e6


def rss_mb() -> float:
    """This process's resident memory (MB)."""
    with open("/proc/self/statm", encoding="ascii") as fh:
        pages = int(fh.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


async def settle(st: Steer, rules: Rules, until_s: float) -> None:
    """Simulated time passes to ``until_s``, the referee's verdict checked on the way."""
    while (left := until_s - now_s()) > 0:
        await asyncio.sleep(min(left, 5.0))
        if rules.broken is not None:
            raise Broken(rules.broken)


async def crew_day(st: Steer, plan: DayPlan, crews: list[Crew], card: Card) -> None:
    """One start of the service: the first sets the day up, a later one (after the crew's
    ``restart``) takes the day on from the next step; the day's last ends it."""
    if not crews:
        crew = Crew(st, st.ground_station(1, QGC_SYSID), Rules(st), plan, card)
        crews.append(crew)
        st.server.snapshot_listeners.append(crew.rules.snapshot)
        st.set_rc(SWITCH_CH, LOW_US)
        await st.line("no mission on the autopilot", 60.0)
        await st.until(lambda s: not s.booting, 60.0)
        crew.t0 = crew.rules.t0 = now_s()
        await settle(st, crew.rules, crew.t0 + 1.0)
        crew.before = resources()
    else:
        crew = crews[0]
        crew.st, crew.rules.st = st, st
        crew.gcs = st.ground_station(1, QGC_SYSID)
        # the service up again (or not, with the link cut: the crew goes on all the same)
        with contextlib.suppress(AssertionError):
            await st.line("event=serve_state state=", 60.0, after=crew.restarted_at)
    rules, t0 = crew.rules, crew.t0
    for step in plan.steps[crew.next_step :]:
        await settle(st, rules, t0 + step.at_s)
        if not crew.rss_mb[0] and step.at_s >= plan.length_s / 2.0:
            crew.rss_mb = (rss_mb(), 0.0)  # midday: the caches are warm
            crew.lines_at_midday = len(st.console.lines)
        crew.next_step += 1
        await crew.perform(step)
        if step.name in ("restart", "kill"):
            crew.restarted_at = st.mark()
            if step.name == "kill":  # kill -9; systemd starts it again after RestartSec
                st.kill()
            else:
                st.signal(signal.SIGTERM)  # systemd's restart: stop, then start again
            return
    await settle(st, rules, t0 + plan.length_s)
    # the crew's evening: the switch low, disarmed (a paused flight ends, its files close)
    for name in ("switch_low", "disarm"):
        await crew.perform(Step(-1, now_s() - t0, "crew", name))
    await settle(st, rules, now_s() + 30.0)  # faults over, the service quiet again
    after, before = resources(), crew.before
    crew.rss_mb = (crew.rss_mb[0] or rss_mb(), rss_mb())
    harness_mb = console_mb(st.console.lines[crew.lines_at_midday :])
    if crew.rss_mb[1] > crew.rss_mb[0] + harness_mb + RSS_SLACK_MB:
        rules.fail(
            "memory_flat",
            f"resident memory {crew.rss_mb} MB at midday and at the end, "
            f"{harness_mb:.1f} MB of it the harness's console",
        )
        raise Broken(rules.broken)  # type: ignore[arg-type]
    states = [ln for ln in st.console.lines if "event=serve_state" in ln]
    quiet = not states or not any(f"state={s} " in states[-1] for s in ("flying", "paused"))
    if quiet and (after[0] > before[0] + TASKS_SLACK or after[1] > before[1] + FDS_SLACK):
        rules.fail("resources_flat", f"tasks, fds {before} at the start, {after} at the end")
        raise Broken(rules.broken)  # type: ignore[arg-type]
    st.signal(signal.SIGTERM)


def check_runs(run_root: Path) -> Violation | None:
    """Every run directory has a summary and ``helixd replay`` prints it."""
    if not run_root.is_dir():
        return None
    for run in sorted(p for p in run_root.iterdir() if p.is_dir()):
        summary, problem = load_summary(run)
        if summary is None:
            return Violation("run_dir_readable", 0.0, f"{run.name}: {problem}")
        try:
            print_replay(run, tty=False, out=io.StringIO())
        except Exception as exc:  # any failure of replay is the finding
            return Violation("run_dir_readable", 0.0, f"{run.name}: replay: {exc!r}")
    return None


def ring_ne(box: tuple[float, float, float, float]) -> tuple[tuple[float, float], ...]:
    n0, n1, e0, e1 = box
    return ((n0, e0), (n0, e1), (n1, e1), (n1, e0))


def pond(plan: DayPlan, workdir: Path) -> Path:
    """The day's media map for helixd (GeoJSON, local_ned: positions [east, north])."""
    assert plan.water_ne is not None
    ring = [[e, n] for n, e in ring_ne(plan.water_ne)]
    data = {
        "type": "FeatureCollection", "frame": "local_ned", "default_medium": "hard",
        "features": [{"type": "Feature", "properties": {"medium": "water"},
                      "geometry": {"type": "Polygon", "coordinates": [[*ring, ring[0]]]}}],
    }  # fmt: skip
    path = workdir / "pond.geojson"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def run_day(plan: DayPlan, workdir: Path) -> DayResult:
    """The day of ``plan`` in ``workdir`` (its config, runs/ and serve.log)."""
    workdir.mkdir(parents=True, exist_ok=True)
    config = deep_merge(SERVE_CONFIG, {} if plan.switch else NO_SWITCH)
    world: dict[str, Any] = {}
    if plan.water_ne is not None:
        config = deep_merge(config, {"media": {"media_map": str(pond(plan, workdir))}})
        world["media"] = MediaMap(
            MediaFrame.LOCAL_NED, (MediaArea(Medium.WATER, ring_ne(plan.water_ne)),), Medium.HARD
        )
    crews: list[Crew] = []
    card = Card()

    async def day(st: Steer) -> None:
        await crew_day(st, plan, crews, card)

    wall, cpu = time.perf_counter(), time.process_time()
    violation: Violation | None = None
    served = None
    try:
        with card_in_recorder(card):
            served = simulated_serve(
                workdir,
                [day] * (1 + sum(1 for s in plan.steps if s.name in ("restart", "kill"))),
                config,
                seed=plan.seed,
                limit_s=plan.length_s + EVENING_S,
                params=AUTOPILOT_PARAMS,
                history_max_entries=SIM_HISTORY_ENTRIES,
                **guard_installed(1.0),  # helixd-guard on the autopilot, as in the field
                **world,
            )
    except Broken as exc:
        violation = exc.violation
    except (AssertionError, TimeoutError) as exc:
        violation = Violation("harness", 0.0, f"{type(exc).__name__}: {str(exc)[:500]}")
    except Exception as exc:  # raised in the service or the simulator: the day's finding
        where = "".join(traceback.format_exception(exc)[-3:])
        violation = Violation("exception", 0.0, f"{type(exc).__name__}: {exc}\n{where}"[:1500])
    if violation is None and served is not None:
        if any(code not in (0, KILLED_CODE) for code in served.codes):
            violation = Violation("exit_code", 0.0, f"serve ended {served.codes} on SIGTERM")
        elif "Traceback" in served.log:
            violation = Violation("traceback", 0.0, "a traceback in the service's log")
        else:
            violation = check_runs(workdir / "runs")
    crew = crews[0] if crews else None
    log = (
        (workdir / "serve.log").read_text(encoding="utf-8")
        if (workdir / "serve.log").exists()
        else ""
    )
    events = [s.describe() for s in (crew.done[-8:] if crew else [])] + log.splitlines()[-25:]
    return DayResult(
        seed=plan.seed,
        simulated_s=plan.length_s if violation is None or crew is None else crew.simulated_s,
        wall_s=time.perf_counter() - wall,
        cpu_s=time.process_time() - cpu,
        violation=violation,
        actions=crew.actions if crew else {},
        faults=crew.faults if crew else {},
        events=events,
        done=crew.done if crew else [],
        rss_mb=crew.rss_mb if crew else (0.0, 0.0),
    )
