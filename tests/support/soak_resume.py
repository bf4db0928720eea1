"""The soak's referee for interruptions (tests.support.soak_day.Rules holds these): a kill
of the service told by the service started again, and a resumed flight going on from the
item it was interrupted at.

**Kill told** (``fault_named`` for the day's ``kill``): a kill that cut a flight's run
(its run directory without a summary at the kill) is told by the next start of the service,
once: its ``serve_flight_cut`` line (the STATUSTEXT goes with it), before
:data:`KILL_TOLD_WITHIN_S`. A kill of an idle service is told nothing.

**Resumed from the interrupted item** (``resume_item``): when a flight is interrupted — a
kill, the service's restart (SIGTERM), a fault while driving, the crew's stop word — the
autopilot's current item (the simulator's truth: the autopilot's own item in AUTO, the one
helixd set as current while it drives in MANUAL) is where a continue must go on. The next
continue (the autopilot's AUTO, DO_PAUSE_CONTINUE 1 or MISSION_START 0 to helixd, the start
switch) must, when it drives, drive with that item current, unless the crew set current,
uploaded a mission or started from the beginning (QGroundControl's Start Mission) in
between; a disarm lets the autopilot restart its mission (AP_Arming_Rover::disarm resets it
outside AUTO), and so does AUTO entered again after its mission completed, so after either
only helixd's own continue is judged.
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.support.kill9 import RESTART_S
from tests.support.soak_plan import Item

# the restarted service tells the cut flight as it starts: RestartSec, then its start-up
KILL_TOLD_WITHIN_S = RESTART_S + 10.0
CONTINUE_WORDS = frozenset({"continue", "continue_helixd", "start_helixd", "switch_high"})
HELIXD_CONTINUES = frozenset({"continue_helixd", "start_helixd", "switch_high"})
RESET_WORDS = frozenset({"set_current", "upload", "reupload", "start"})
# a continue that has not driven in this long was refused or is not a continue: not judged
DRIVES_WITHIN_S = 15.0
# an interrupted flight stops within its stop's limit (at most the disarm's 1.5 s): a
# waypoint reached meanwhile (the rover's last centimetres before the HOLD is seen, seed 312)
# moves the item it is interrupted at, as helixd's display shows
SETTLES_WITHIN_S = 1.5


def navs_from(items: tuple[Item, ...], seq: int) -> frozenset[int]:
    """The navigation items a walk starting at item ``seq`` flies first: ``seq`` itself when it
    is one, else the first after the do items there (a DO_JUMP's target too). The autopilot's
    current item may be a do item (seed 10's hour: DO_CHANGE_SPEED item 4; helixd's continue
    runs it again and shows item 5 as it drives there)."""
    out: set[int] = set()
    for j in range(max(seq, 0), len(items)):
        it = items[j]
        if it.is_nav:
            out.add(j)
            break
        if it.command == mavlink.MAV_CMD_DO_JUMP:
            out.add(int(it.params[0]))
    return frozenset(out)


@dataclass
class Kill:
    at_s: float
    mark: int  # the console's lines at the kill
    told: bool  # a flight's run was cut: its restart must tell it


class KillsTold:
    """Each kill: told once by the next start when it cut a flight, never otherwise."""

    def __init__(self) -> None:
        self.kills: list[Kill] = []

    def kill(self, at_s: float, mark: int, run_cut: bool) -> None:
        self.kills.append(Kill(at_s, mark, run_cut))

    def due(self, now_s: float, lines: list[str]) -> str | None:
        """The first kill judged now that broke the rule (its detail), else None."""
        for i, k in enumerate(list(self.kills)):
            later = self.kills[i + 1] if i + 1 < len(self.kills) else None
            if now_s <= k.at_s + KILL_TOLD_WITHIN_S and later is None:
                continue
            self.kills.remove(k)
            end = later.mark if later is not None else len(lines)
            told = sum("event=serve_flight_cut " in ln for ln in lines[k.mark : end])
            if told != (1 if k.told else 0):
                cut = "cut a flight" if k.told else "cut no flight"
                return f"kill at {k.at_s:.2f} s ({cut}) told {told} times"
            return None
        return None


class ResumeRule:
    """The item a continue must drive with (module docstring)."""

    def __init__(self) -> None:
        self.item: int | None = None  # the interrupted item a continue goes on from
        self.by_autopilot = True  # an AUTO continue still finds it (no disarm since)
        self.autopilot_complete = False  # its mission completed: AUTO starts it again
        self.judge: tuple[int, float, str] | None = None  # item, since, the continue's word
        # the items a continue of the autopilot's AUTO flies without driving: the interrupted
        # one, and those it moves on to from there before it drives (already within their
        # radius: seed 104, AUTO again 0.5 m from item 1 showed item 3 as it drove)
        self.passed: set[int] = set()
        self.leads_to: frozenset[int] = frozenset()  # navs an interrupted do item leads to
        self.settles_until = 0.0  # the interrupted flight may still move its item until then
        # the item it moved from then: reached at the very stop or not (an AUTO flight's
        # autopilot counts its own WP_RADIUS, helixd its own: seed 4002, 1.9 m from item 4 at
        # the crew's disarm, the autopilot on 5, helixd's continue from 4), either is its item
        self.settled_from: int | None = None

    def interrupted(
        self, flying: bool, seq: int, leads_to: frozenset[int] = frozenset(), t: float = 0.0
    ) -> None:
        """A flight interrupted (kill, restart, fault while driving, a stop word) with item
        ``seq`` current (``leads_to``: :func:`navs_from` it)."""
        self.judge = None
        if flying and seq >= 1:
            self.item, self.by_autopilot = seq, not self.autopilot_complete
            self.leads_to, self.settles_until = leads_to, t + SETTLES_WITHIN_S
            self.settled_from = None

    def word(self, name: str, t: float) -> None:
        if name in RESET_WORDS:
            self.item, self.judge = None, None
        elif name == "disarm":
            self.by_autopilot = False
        elif name in CONTINUE_WORDS and self.item is not None and self._finds(name):
            self.judge, self.passed = (self.item, t, name), {self.item, *self.leads_to}
            if self.settled_from is not None:
                self.passed.add(self.settled_from)
        if name in CONTINUE_WORDS or name in RESET_WORDS:
            self.autopilot_complete = False  # started again (or a new mission)

    def autopilot_done(self) -> None:
        """The autopilot's mission completed (its "Mission Complete", reached within its own
        WP_RADIUS while helixd still drove to its arrival): AUTO again starts it from the
        first item (``start_or_resume``), so an AUTO continue is not judged (seed 15)."""
        self.by_autopilot, self.autopilot_complete = False, True

    def _finds(self, name: str) -> bool:
        """Whether the continue ``name`` must find the interrupted item: helixd's own always
        (its state file), the autopilot's AUTO unless it was disarmed since."""
        return name in HELIXD_CONTINUES or self.by_autopilot

    def driven(
        self, t: float, seq: int, driving: bool, successors: dict[int, set[int]]
    ) -> str | None:
        """Each snapshot: the continue's first driven one breaks the rule on another item
        (``successors``: the mission's, :func:`tests.support.soak_day.nav_successors`)."""
        if self.judge is None:
            moved = self.item is not None and seq >= 1 and seq != self.item
            if moved and t <= self.settles_until:
                if self.settled_from is None:
                    self.settled_from = self.item
                self.item, self.leads_to = seq, frozenset()
            return None
        item, since, name = self.judge
        if t - since > DRIVES_WITHIN_S:
            self.judge = None  # refused, or it did not drive: nothing flown to judge
            return None
        if not driving:
            moved_on = any(seq in successors.get(p, set()) for p in self.passed)
            if name not in HELIXD_CONTINUES and moved_on:
                self.passed.add(seq)  # the autopilot moved on from a reached item
            return None
        self.judge, self.item = None, None
        if seq not in self.passed:
            return f"{name} at {since:.2f} s drove with item {seq} current, interrupted at {item}"
        return None


__all__ = ["CONTINUE_WORDS", "KILL_TOLD_WITHIN_S", "Kill", "KillsTold", "ResumeRule", "navs_from"]
