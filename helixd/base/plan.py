"""Plain plan and mode types: what the control core flies, free of the mission file format.

:mod:`helixd.mission` loads and validates mission files (pydantic, YAML) and resolves them into
a :class:`Plan`; the navigator only ever sees this module's types.

A mission with commands (ArduPilot's mission: navigation items and the do/condition items
between them) also resolves into a :class:`Program`: the navigation steps in the order
ArduPilot Rover flies them (jumps expanded, :mod:`helixd.mission.expand`), each with the plan
waypoints it flies to, the time it waits, and the :class:`MissionAction` s started with it. The
navigator flies the plan's waypoints; :mod:`helixd.control.sequencer` steps through the
program beside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum


class MotionMode(StrEnum):
    ROLL = "roll"  # hard ground: v_y = 0, drive along +x
    SCROLL = "scroll"  # water, mud, snow: v_x = 0, drive along +y
    OMNI = "omni"  # viscous media: ω_z = 0, heading held


class MissionFrameKind(StrEnum):
    START = "start"
    LOCAL_NED = "local_ned"
    GLOBAL = "global"


@dataclass(frozen=True, slots=True)
class PlanWaypoint:
    """One target in the mission frame (x/y metres, yaw CCW from +x)."""

    x_m: float
    y_m: float
    tolerance_m: float
    final_yaw_rad: float | None = None
    via: bool = False  # inserted by the planner on the way to the next waypoint
    # stopped at precisely (a hold, a delay or a return follows), like the final waypoint
    stop: bool = False
    # the motion mode of the leg to this waypoint (None: the plan's mode); where the next
    # leg's mode differs the waypoint is a stop and the rover turns in place there
    mode: MotionMode | None = None
    # a stop inserted where the mode changes (helixd.planning.media_modes): not one of the
    # mission's waypoints, so not counted where the mission's are (a resume's index)
    media_stop: bool = False
    # where the media map says the leg's mode cannot move (a ROLL leg pinned across water):
    # spans (near, far) of the distance still to go to this waypoint (m); the ground check
    # never answers "firm again" there (helixd.control.ground_check)
    unfit_to_go_m: tuple[tuple[float, float], ...] = ()
    # what the ground of the leg to this waypoint delivers (roll, scroll, yaw fractions), as
    # the rover learnt it (helixd.prepare.ground_learning); None: the declared ground
    ground: tuple[float, float, float] | None = None


class ActionKind(StrEnum):
    """What the flight does with one do/condition item of the mission."""

    SEND = "send"  # a command the autopilot runs (COMMAND_LONG), acknowledgement checked
    SPEED = "speed"  # cruise speed from here on (m/s, already bounded by the config)
    REVERSE = "reverse"  # drive backwards (value 1) or forwards (value 0) from here on
    WAIT_TIME = "wait_time"  # CONDITION_DELAY: the items after it wait ``value`` seconds
    WAIT_DISTANCE = "wait_distance"  # CONDITION_DISTANCE: … until within ``value`` m of the target
    NOTE = "note"  # nothing is done (an item ArduPilot Rover skips or ignores): logged


@dataclass(frozen=True, slots=True)
class MissionAction:
    """One do/condition item, at its place in the mission."""

    item: int  # mission item number (sequence number as the ground station shows it)
    command: int  # MAV_CMD
    kind: ActionKind
    value: float = 0.0  # speed (m/s), reverse (0/1), wait (s) or distance (m)
    params: tuple[float, float, float, float, float, float, float] = (0.0,) * 7  # COMMAND_LONG
    text: str = ""  # what it does, for the operator


@dataclass(frozen=True, slots=True)
class NavStep:
    """One navigation item as flown: where it goes, how long it waits, what starts with it."""

    item: int
    command: int
    first_waypoint: int | None  # plan waypoints first..last flown in this step; None: in place
    last_waypoint: int | None
    hold_s: float  # waited after arriving (in place: the whole step)
    actions: tuple[MissionAction, ...]  # the do/condition items started when this step starts
    speed_mps: float  # cruise expected on this step's legs (the estimate; set by its actions)
    text: str
    forever: bool = False  # NAV_LOITER_UNLIM: the step never ends by itself
    skipped: tuple[str, ...] = ()  # navigation items passed over on the way to this one


@dataclass(frozen=True, slots=True)
class Program:
    """The mission's navigation steps in flight order (jumps expanded) and how it ends."""

    steps: tuple[NavStep, ...]
    final_actions: tuple[MissionAction, ...] = ()  # started when the last step completes
    ending: str = ""  # why the mission ends where it does, when not simply at its last item
    never_ends: bool = False  # a jump repeated forever or a loiter without end
    notes: tuple[str, ...] = field(default=())
    # where the walk assumed the rover starts (None: not known, the estimate starts at wp 0)
    start_xy_m: tuple[float, float] | None = None
    # the mission's items as the ground station numbers them (home 0 not counted; 0: unknown)
    items_total: int = 0
    # a patrol: the DO_JUMP item repeated forever (0: none); its laps are unrolled beyond the
    # time limit and ``lap_starts`` holds the step index where lap 2, 3, … starts
    patrol_item: int = 0
    lap_starts: tuple[int, ...] = ()

    def laps(self) -> tuple[str, ...]:
        """Per step, ``"lap k of n"`` when its item is flown n > 1 times (a DO_JUMP repeats
        it), else ``""``."""
        times: dict[int, int] = {}
        for s in self.steps:
            times[s.item] = times.get(s.item, 0) + 1
        seen: dict[int, int] = {}
        out: list[str] = []
        for s in self.steps:
            seen[s.item] = seen.get(s.item, 0) + 1
            n = times[s.item]
            if n <= 1:
                out.append("")
            elif self.patrol_item:  # a patrol's laps have no count: it is flown until stopped
                out.append(f"lap {seen[s.item]}")
            else:
                out.append(f"lap {seen[s.item]} of {n}")
        return tuple(out)

    def first_lap(self) -> tuple[int, int] | None:
        """A patrol's first lap as step indices [start, end) (None: not a patrol)."""
        if not self.patrol_item or not self.lap_starts:
            return None
        end = self.lap_starts[0]
        item = self.steps[end].item
        start = next(i for i, s in enumerate(self.steps) if s.item == item)
        return start, end


@dataclass(frozen=True, slots=True)
class Plan:
    name: str
    mode: MotionMode
    frame: MissionFrameKind
    waypoints: tuple[PlanWaypoint, ...]
    speed_mps: float
    # Start of the first leg (mission frame, m). None: the rover's pose at the first step, as
    # for a fresh mission. A resumed mission sets the waypoint before its first one, so line
    # guidance re-enters the interrupted leg instead of cutting across to the waypoint.
    leg_start_xy_m: tuple[float, float] | None = None
    program: Program | None = None  # None: a plain list of waypoints, nothing between them
    # per motion mode, the ground (roll, scroll, yaw fractions) the slip estimate starts from
    # there, as the rover learnt it where it first flies in that mode
    # (helixd.prepare.ground_learning); a mode not listed: the declared ground
    slip_priors: tuple[tuple[MotionMode, tuple[float, float, float]], ...] = ()

    def mode_at(self, index: int) -> MotionMode:
        """The motion mode of the leg to plan waypoint ``index`` (clamped to the plan)."""
        if not self.waypoints:
            return self.mode
        own = self.waypoints[min(max(index, 0), len(self.waypoints) - 1)].mode
        return self.mode if own is None else own

    @property
    def single_mode(self) -> bool:
        """True when every leg is flown in the plan's one mode."""
        return all(w.mode is None or w.mode is self.mode for w in self.waypoints)

    @property
    def peak_speed_mps(self) -> float:
        """The highest cruise speed the program may set (the plan's speed without one)."""
        if self.program is None:
            return self.speed_mps
        speeds = [self.speed_mps, *(s.speed_mps for s in self.program.steps)]
        actions = [a for s in self.program.steps for a in s.actions]
        actions += self.program.final_actions
        speeds += [a.value for a in actions if a.kind is ActionKind.SPEED]
        return max(speeds)

    def assumed_start_xy_m(self) -> tuple[float, float]:
        """Where an estimate without the rover's pose starts: the start the program was
        resolved from, else waypoint 0 (a start-frame mission: the origin)."""
        if self.frame is MissionFrameKind.START:
            return (0.0, 0.0)
        if self.program is not None and self.program.start_xy_m is not None:
            return self.program.start_xy_m
        first = self.waypoints[0]
        return (first.x_m, first.y_m)

    def path_length_m(self, start_xy_m: tuple[float, float] = (0.0, 0.0)) -> float:
        """Length of the polyline start → wp1 → … → wpN (m)."""
        total = 0.0
        px, py = start_xy_m
        for wp in self.waypoints:
            total += math.hypot(wp.x_m - px, wp.y_m - py)
            px, py = wp.x_m, wp.y_m
        return total

    def numbers(self) -> tuple[int, ...]:
        """Per waypoint, see :func:`operator_numbers`."""
        return operator_numbers([w.via for w in self.waypoints])

    def leg_speeds_mps(self) -> list[float]:
        """The cruise speed expected on the leg to each waypoint (the program's, or the plan's)."""
        speeds = [self.speed_mps] * len(self.waypoints)
        if self.program is not None:
            for step in self.program.steps:
                if step.first_waypoint is not None and step.last_waypoint is not None:
                    for i in range(step.first_waypoint, step.last_waypoint + 1):
                        speeds[i] = step.speed_mps
        return speeds

    def waits_s(self) -> float:
        """Time the program waits in holds and delays (s; 0 without a program)."""
        if self.program is None:
            return 0.0
        return sum(s.hold_s for s in self.program.steps)

    @property
    def operator_count(self) -> int:
        """The operator's waypoints (via points not counted)."""
        return sum(not w.via for w in self.waypoints)


def operator_numbers(vias: Sequence[bool], first: int = 1) -> tuple[int, ...]:
    """The operator's numbering, 1-based as a ground station shows mission items: each
    waypoint's own number; a via point (inserted by the planner) gets the number of the
    waypoint its leg leads to. ``first``: the number of the first operator waypoint here
    (a resumed run starts further on)."""
    out: list[int] = []
    k = first
    for via in vias:
        out.append(k)
        if not via:
            k += 1
    return tuple(out)


@dataclass(frozen=True, slots=True)
class Numbering:
    """How the operator numbers a run's waypoints: 1-based over the whole mission (a resumed
    run continues the count), via points not counted (see :func:`operator_numbers`); a mission
    with commands by its mission items, with laps (see :func:`program_numbering`)."""

    numbers: tuple[int, ...]  # per plan index
    vias: tuple[bool, ...]  # per plan index
    total: int  # the operator's waypoints (a mission with commands: its items) in the mission
    # per plan index, a mission with commands: "lap 2 of 3" where a DO_JUMP repeats the item
    laps: tuple[str, ...] = ()
    items: bool = False  # numbers are mission items (a mission with commands), not waypoints

    @staticmethod
    def of(vias: Sequence[bool], first: int = 1, total: int | None = None) -> Numbering:
        """``first``: the number of this run's first operator waypoint; ``total`` (default:
        the last one's number) of the whole mission."""
        own = sum(not v for v in vias)
        numbers = operator_numbers(vias, first)
        last = max(numbers, default=0)  # a total is never below a number shown ("8/7")
        return Numbering(
            numbers, tuple(vias), max(first - 1 + own if total is None else total, last)
        )

    @property
    def operator_count(self) -> int:
        """The operator's waypoints in this run."""
        return sum(not v for v in self.vias)

    def number(self, index: int) -> int:
        """The number of plan index ``index`` (a via point: of the waypoint it leads to)."""
        return self.numbers[min(max(index, 0), len(self.numbers) - 1)] if self.numbers else 0

    def via(self, index: int) -> bool:
        return bool(self.vias) and self.vias[min(max(index, 0), len(self.vias) - 1)]

    def lap(self, index: int) -> str:
        """``"lap 2 of 3"`` while flying an item a DO_JUMP repeats, else ``""``."""
        return self.laps[min(max(index, 0), len(self.laps) - 1)] if self.laps else ""

    def label(self, index: int) -> str:
        """``"3/5"``, ``"via → 3/5"`` for a via point on the leg to waypoint 3, ``"3/5 (lap 2
        of 3)"`` for item 3 of a mission with commands on the second of its three laps."""
        return waypoint_label(self.number(index), self.via(index), self.total, self.lap(index))


def program_numbering(plan: Plan) -> Numbering | None:
    """The numbering of a mission with commands (None without): each plan waypoint gets the
    mission item (sequence number as the ground station shows it, home 0, the first item 1)
    of the navigation step that flies it, and its lap where a DO_JUMP repeats that item; the
    total is the mission's item count, so no number shown is ever above it. A plan waypoint
    no step flies (none should) gets the item of the next one that is flown."""
    program = plan.program
    if program is None:
        return None
    count = len(plan.waypoints)
    items: list[int | None] = [None] * count
    laps = [""] * count
    for step, lap in zip(program.steps, program.laps(), strict=True):
        first, last = step.first_waypoint, step.last_waypoint
        if first is None or last is None:
            continue
        for i in range(max(first, 0), min(last, count - 1) + 1):
            items[i] = step.item
            laps[i] = lap
    numbers = [0] * count
    following = max((s.item for s in program.steps), default=1)
    for i in range(count - 1, -1, -1):
        got = items[i]
        if got is None:
            numbers[i] = following
            laps[i] = laps[i + 1] if i + 1 < count else ""
        else:
            numbers[i] = following = got
    total = max([program.items_total, *numbers, 1])
    return Numbering(
        tuple(numbers), tuple(w.via for w in plan.waypoints), total, tuple(laps), items=True
    )


def mission_item_of(plan: Plan, numbering: Numbering, index: int) -> int:
    """The mission item (its sequence number, as the ground station shows it) being flown
    while plan waypoint ``index`` is the target: the navigation step that flies it, else (a
    plain list of waypoints) the operator's number of the waypoint."""
    if plan.program is not None:
        for step in plan.program.steps:
            first, last = step.first_waypoint, step.last_waypoint
            if first is not None and last is not None and first <= index <= last:
                return step.item
    return numbering.number(index)


def waypoint_label(number: int, via: bool, total: int | None = None, lap: str = "") -> str:
    """``"3"`` (or ``"3/5"`` with ``total``) for the operator's waypoint 3; ``"via → 3"`` (or
    ``"via → 3/5"``) for a via point on the leg to it; ``lap`` (``"lap 2 of 3"``) is added
    in brackets: ``"3/5 (lap 2 of 3)"``."""
    text = str(number) if total is None else f"{number}/{total}"
    if lap:
        text += f" ({lap})"
    return f"via → {text}" if via else text


__all__ = [
    "ActionKind",
    "MissionAction",
    "MissionFrameKind",
    "MotionMode",
    "NavStep",
    "Numbering",
    "Plan",
    "PlanWaypoint",
    "Program",
    "mission_item_of",
    "operator_numbers",
    "program_numbering",
    "waypoint_label",
]
