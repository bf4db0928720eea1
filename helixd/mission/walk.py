"""AP_Mission's walk through a mission's items, as ArduPilot Rover runs it: which navigation
item becomes current after which, the do/condition items started with it, the jumps taken and
the counters AP_Mission holds. Pure: no I/O, no clocks; :mod:`helixd.mission.expand` builds the
flight on it.

A port of ``libraries/AP_Mission/AP_Mission.cpp``, so the order is ArduPilot's, not
a reading of the list:

* ``get_next_cmd``: DO_JUMP (and DO_JUMP_TAG, through the first JUMP_TAG with its tag) is
  followed while it has been taken fewer times than its repeat count (−1: forever); a jump
  counts only when the *navigation* command is advanced, and a finished jump's counter is reset
  so an outer loop runs the inner one again; at most 64 jumps per search; a jump to item 0 or
  past the end ends the mission.
* ``advance_current_nav_cmd``: after a navigation command completes, the items after it are
  scanned; the first do/condition item met is started, navigation items Rover does not start
  (NAV_TAKEOFF, NAV_LAND, altitude-only items) are passed over, and the next navigation item
  it starts becomes current (at most 255 items scanned). Nothing left: the mission is complete
  — and the do item met on the way was still started.
* ``advance_current_do_cmd`` / ``get_next_do_cmd``: the remaining do/condition items run one
  after another from the first, following jumps without counting them, up to the next
  navigation item of *any* kind; a condition (CONDITION_DELAY, CONDITION_DISTANCE) holds the
  items after it. When the navigation command completes, whatever is left is dropped.

The walk's order does not depend on the items' places: the queries here (where a walk is at
a step, the counters when an item is current, where a restart starts) walk the items alone.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

from helixd.mav.constants import MAV_CMD_DO_JUMP, MAV_CMD_DO_JUMP_TAG, MAV_CMD_JUMP_TAG
from helixd.mission.commands import JUMP_FOREVER, Role, stored_whole
from helixd.mission.model import WaypointSpec

XY = tuple[float, float]

MAX_JUMPS_PER_SEARCH = 64  # AP_Mission::get_next_cmd
MAX_SCAN = 255  # AP_Mission::advance_current_nav_cmd
MAX_CHAIN = 1_000  # do items started with one step


class WalkStart(Protocol):
    """Where a walk starts (:class:`helixd.mission.expand.ExpandOptions` is one)."""

    @property
    def first_item(self) -> int: ...  # the mission item the walk starts at (1: the first)

    @property
    def jumps_taken(self) -> tuple[tuple[int, int], ...]: ...  # (DO_JUMP item, times taken)


@dataclass(frozen=True)
class Cmd:
    index: int  # 1-based mission item number
    wp: WaypointSpec
    xy: XY | None  # its place in the mission frame (None: none, or "where the rover is")
    latlon: tuple[float, float] | None  # a global mission's lat/lon, for commands sent

    @property
    def role(self) -> Role:
        return self.wp.spec.role

    @property
    def nav(self) -> bool:
        return self.wp.spec.nav

    @property
    def name(self) -> str:
        return self.wp.name

    def p(self, i: int) -> float:
        return self.wp.param(i)


class Walker:
    """AP_Mission's command walk over items 1..N (index 0 is home and never walked)."""

    def __init__(self, cmds: Sequence[Cmd]) -> None:
        self.cmds = cmds
        self.total = len(cmds) + 1
        self.runs: dict[int, int] = {}
        # the jump counters when the last advance_nav met its first do item (before the jumps
        # between that item and the navigation item were counted)
        self.runs_at_first_do: dict[int, int] = {}
        self.forever_taken: dict[int, int] = {}  # forever jumps: index → times taken
        self.bad_jumps: set[tuple[int, int]] = set()  # (jump item, target)

    def cmd(self, index: int) -> Cmd:
        return self.cmds[index - 1]

    def tag_index(self, tag: int) -> int:
        """AP_Mission::get_index_of_jump_tag: the first JUMP_TAG with this tag, else 0."""
        for c in self.cmds:
            if c.wp.command == MAV_CMD_JUMP_TAG and stored_whole(c.p(0)) == tag:
                return c.index
        return 0

    def next_cmd(self, start: int, increment: bool) -> Cmd | None:
        """AP_Mission::get_next_cmd."""
        index = start
        jump_index: int | None = None
        loops = MAX_JUMPS_PER_SEARCH
        while index < self.total:
            c = self.cmd(index)
            command = c.wp.command
            if command not in (MAV_CMD_DO_JUMP, MAV_CMD_DO_JUMP_TAG):
                return c
            target = stored_whole(c.p(0))
            if command == MAV_CMD_DO_JUMP_TAG:
                target = self.tag_index(target)
            times = stored_whole(c.p(1))
            if loops == 0:
                return None
            loops -= 1
            if target >= self.total or target == 0:
                self.bad_jumps.add((c.index, target))
                return None
            if not increment and jump_index == index:
                return None
            if jump_index is None:
                jump_index = index
            if times == JUMP_FOREVER or self.runs.get(index, 0) < times:
                if increment:
                    self.runs[index] = self.runs.get(index, 0) + 1
                    if times == JUMP_FOREVER:
                        self.forever_taken[index] = self.forever_taken.get(index, 0) + 1
                index = target
            else:
                if increment:
                    self.runs[index] = 0  # MIS_OPTIONS DONT_ZERO_COUNTER is off by default
                index += 1
        return None

    def advance_nav(
        self, after: int | None, starts: Callable[[Cmd], bool]
    ) -> tuple[Cmd | None, Cmd | None, list[Cmd]]:
        """AP_Mission::advance_current_nav_cmd: (the navigation item started, the first do
        item started on the way, the navigation items passed over)."""
        index = 1 if after is None else after + 1
        first_do: Cmd | None = None
        passed: list[Cmd] = []
        for _ in range(MAX_SCAN):
            c = self.next_cmd(index, increment=True)
            if c is None:
                return None, first_do, passed
            if c.nav:
                if starts(c):
                    return c, first_do, passed
                passed.append(c)
            elif first_do is None:
                first_do = c
                self.runs_at_first_do = dict(self.runs)
            index = c.index + 1
        return None, first_do, passed

    def do_chain(self, first: Cmd) -> tuple[list[Cmd], bool]:
        """AP_Mission::advance_current_do_cmd, repeated: the do items after ``first`` up to the
        next navigation item; True when they loop without end (a jump over do items only)."""
        chain = [first]
        seen = {first.index}
        current = first
        while True:
            if current.index + 1 >= self.total:
                return chain, False
            c = self.next_cmd(current.index + 1, increment=False)
            if c is None or c.nav:
                return chain, False
            if c.index in seen or len(chain) >= MAX_CHAIN:
                return chain, True
            seen.add(c.index)
            chain.append(c)
            current = c


def rover_starts(c: Cmd) -> bool:
    """Rover's ModeAuto::start_command returns true (the navigation item becomes current)."""
    return c.role not in (Role.NAV_SKIPPED, Role.UNKNOWN)


def jumps_when_current(
    entries: Sequence[WaypointSpec], options: WalkStart, step: int, item: int
) -> tuple[tuple[int, int], ...]:
    """The jump counters AP_Mission holds when item ``item`` is its current navigation item,
    for the first time at or after step ``step`` (1-based) of the walk ``options`` starts
    (its ``first_item`` and ``jumps_taken``): where the autopilot's AUTO went on to while
    helixd flew that step. Empty when the walk does not reach ``item`` within
    ``MAX_SCAN`` steps after ``step``. The walk's order does not depend on the places."""
    for n, nav_index, walker in _walk(entries, options):
        if n > step + MAX_SCAN:
            break
        if n >= step and nav_index == item:
            return _counters(walker)
    return ()


def walk_at_step(
    entries: Sequence[WaypointSpec], options: WalkStart, step: int
) -> tuple[int, tuple[tuple[int, int], ...]] | None:
    """Step ``step`` (1-based) of the walk ``options`` starts (its ``first_item`` and
    ``jumps_taken``): its navigation item and the jump counters AP_Mission holds while that
    item is current. A *set current waypoint* (``set_current_cmd``) and a resume keep those
    counters, so a walk started at another item from there starts with them. None when the
    walk ends before that step."""
    if step < 1:
        return None
    for n, nav_index, walker in _walk(entries, options):
        if n == step:
            return nav_index, _counters(walker)
    return None


def _walk(entries: Sequence[WaypointSpec], options: WalkStart) -> Iterator[tuple[int, int, Walker]]:
    """The walk ``options`` starts (its ``first_item`` and ``jumps_taken``), step by step:
    (step, 1-based; its navigation item; the walker, its jump counters as they are then)."""
    cmds = [Cmd(i + 1, wp, None, None) for i, wp in enumerate(entries)]
    walker = Walker(cmds)
    walker.runs = dict(options.jumps_taken)
    first = min(max(options.first_item, 1), len(cmds))
    nav, _, _ = walker.advance_nav(None if first <= 1 else first - 1, rover_starts)
    n = 1
    while nav is not None:
        yield n, nav.index, walker
        nav, _, _ = walker.advance_nav(nav.index, rover_starts)
        n += 1


def _counters(walker: Walker) -> tuple[tuple[int, int], ...]:
    """The jump counters AP_Mission holds (the DO_JUMPs taken at least once)."""
    return tuple(sorted((i, r) for i, r in walker.runs.items() if r > 0))


def restart_at_step(
    entries: Sequence[WaypointSpec], options: WalkStart, step: int
) -> tuple[int, tuple[tuple[int, int], ...]] | None:
    """Where a walk starting again at step ``step`` (1-based) of the walk ``options`` starts
    (its ``first_item`` and ``jumps_taken``), so that it flies that step again as it was
    flown, do items included: the first do item started with that step (AP_Mission's
    ``set_current_cmd`` on a do item starts it and the navigation item after it) or, without
    one, its navigation item; and the jump counters held there (the jumps taken between
    that do item and the navigation item are not counted yet: the new walk takes them again).
    None when the walk ends before that step."""
    if step < 1:
        return None
    cmds = [Cmd(i + 1, wp, None, None) for i, wp in enumerate(entries)]
    walker = Walker(cmds)
    walker.runs = dict(options.jumps_taken)
    first = min(max(options.first_item, 1), len(cmds))
    after: int | None = None if first <= 1 else first - 1
    n = 1
    while True:
        walker.runs_at_first_do = {}
        nav, first_do, _ = walker.advance_nav(after, rover_starts)
        if nav is None:
            return None
        if n == step:
            runs = walker.runs if first_do is None else walker.runs_at_first_do
            item = nav.index if first_do is None else first_do.index
            return item, tuple(sorted((i, r) for i, r in runs.items() if r > 0))
        after = nav.index
        n += 1


__all__ = [
    "MAX_SCAN",
    "XY",
    "Cmd",
    "WalkStart",
    "Walker",
    "jumps_when_current",
    "restart_at_step",
    "rover_starts",
    "walk_at_step",
]
