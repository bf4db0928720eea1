"""A mission with commands, as ArduPilot Rover flies it: the navigation steps in flight order
(jumps expanded), the plan waypoints each one drives to, what it waits, and the do/condition
items started with it. Pure: no I/O, no clocks.

The walk is :mod:`helixd.mission.walk`, a port of ``libraries/AP_Mission/AP_Mission.cpp``, so
the order is ArduPilot's, not a reading of the list.

A start at a later item (:attr:`ExpandOptions.first_item` k, ``helixd serve``'s AUTO from the
autopilot's current item) is ArduPilot's ``AP_Mission::set_current_cmd(k)`` followed by
``resume``:

* ``set_current_cmd`` on a running mission calls ``advance_current_nav_cmd(k)``, and on a
  stopped one runs the same search (``get_next_cmd`` from k, counting jumps) that ``resume``
  then restarts: the walk starts at item k, a do item at k is started with the navigation
  item after it, and the do items before k are not run (an earlier DO_CHANGE_SPEED, DO_SET_HOME,
  DO_SET_SERVO has no effect). Items before k stay in the mission: a DO_JUMP after k may
  still jump back to them.
* the jump counters (``_jump_tracking``) are the ones the autopilot holds
  (:attr:`ExpandOptions.jumps_taken`): ``resume`` and ``set_current_cmd`` keep them; only
  ``AP_Mission::reset`` (called by ``start`` and by ``AP_Arming_Rover::disarm`` outside AUTO)
  and ``set_current_cmd`` on item 0 or a completed mission clear them
  (``init_jump_tracking``). After a flight interrupted while armed they are the counters of
  the walk where the autopilot's AUTO had got to
  (:func:`helixd.mission.walk.jumps_when_current`); else zero.
* the speed is the cruise speed: ``ModeAuto::_enter`` calls ``AR_WPNav::init``, which sets the
  speed back to WP_SPEED, so a DO_CHANGE_SPEED flown before AUTO was left counts no more.
* with ``MIS_RESTART`` 1, ``start_or_resume`` calls ``start`` instead: the mission restarts
  from item 1 and the current item reports it, so k is the first item.

A continue of a flight helixd stopped itself (``helixd serve``: the start switch, or
DO_PAUSE_CONTINUE / MISSION_START to helixd; :func:`helixd.prepare.builder.continue_commands`)
flies again the navigation step it stopped at, with what started with it:
:func:`helixd.mission.walk.restart_at_step` starts the walk at that step's first do item (or its
navigation item) with the jump counters held there (a jump between that do item and the
navigation item is not counted yet, so the new walk takes it again), and :func:`carried_at_step`
gives the cruise speed and direction the steps before it had set
(:attr:`ExpandOptions.speed_mps`, :attr:`ExpandOptions.reverse`), set again as its first step
starts — where ArduPilot's own AUTO re-entry would go back to WP_SPEED. A wait interrupted
mid-way (a hold, NAV_LOITER_TIME, NAV_DELAY, CONDITION_DELAY) is waited whole again.

Then ``Rover/mode_auto.cpp`` decides what each navigation item does: NAV_WAYPOINT drives to its
place (lat/lon 0, 0: where the rover is when it starts, ``Location::sanitize``) and holds
``param1`` whole seconds (a hold makes it a stop); NAV_LOITER_TIME drives there, stops and
waits; NAV_LOITER_TURNS drives ``param1`` circles of radius ``param3`` (negative:
counter-clockwise) around its place, entering at the nearest point (flown here as a polygon);
NAV_RETURN_TO_LAUNCH drives to home (moved by DO_SET_HOME); NAV_DELAY stops for ``param1``
seconds; NAV_LOITER_UNLIM waits until the operator continues (``helixd serve``: a
DO_PAUSE_CONTINUE 1 addressed to helixd, and the mission goes on after it; refused by
``helixd run``, which cannot be continued). DO_CHANGE_SPEED sets the cruise speed from its
place on (below 0.05 m/s, e.g. −1: no change; bounded by ``control.min_speed_mps`` ..
``control.max_speed_mps``), DO_SET_REVERSE drives backwards, DO_SET_HOME moves home (and is
sent), the payload commands are sent to the autopilot at their place.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from helixd.base.plan import (
    ActionKind,
    MissionAction,
    MotionMode,
    NavStep,
    PlanWaypoint,
    Program,
)
from helixd.mav.constants import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_JUMP,
    MAV_CMD_DO_JUMP_TAG,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_REVERSE,
)
from helixd.mission.commands import (
    CIRCLE_RADIUS_MIN_M,
    JUMP_FOREVER,
    SKIP_ROLES,
    SPEED_MIN_MPS,
    Role,
    bound_speed,
    command_name,
    speed_floor_mps,
    speed_refused,
    stored_whole,
)
from helixd.mission.model import WaypointSpec
from helixd.mission.walk import XY, Cmd, Walker, rover_starts

MAX_STEPS = 100_000  # navigation steps after expansion (a mission this long is a mistake)
PATROL_STEPS_MAX = 5_000  # a patrol (DO_JUMP forever) is unrolled to at most this many steps
SAME_PLACE_M = 0.01  # a step to where the rover already is drives nowhere
CIRCLE_SEGMENT_M = 2.0  # a circle is flown as a polygon with sides about this long …
CIRCLE_POINTS_MIN = 8  # … with at least this many corners per turn …
CIRCLE_POINTS_MAX = 72  # … and at most this many


@dataclass(frozen=True)
class ExpandOptions:
    """The operator's choices for what is not simply flown."""

    strict: bool = False  # refuse what ArduPilot Rover skips, instead of skipping it
    skip_unsupported: bool = False  # pass over what helixd cannot fly, instead of refusing
    # helixd serve: an operator can continue a NAV_LOITER_UNLIM (DO_PAUSE_CONTINUE 1), so it
    # holds there and the mission goes on after it; `helixd run` cannot, and refuses it
    operator_continue: bool = False
    # the mission item the walk starts at (1: the first); ``helixd serve`` flies the
    # autopilot's AUTO from its current item (MISSION_CURRENT), as ArduPilot runs it from there
    first_item: int = 1
    # the jump counters (DO_JUMP item, times taken) the autopilot holds at that start
    # (AP_Mission's _jump_tracking, kept by resume and set_current_cmd): see
    # :func:`helixd.mission.walk.jumps_when_current`
    jumps_taken: tuple[tuple[int, int], ...] = ()
    # the cruise speed (m/s) and direction the walk starts with (None, False: the configured
    # cruise speed, forwards): a continue carries on what was in effect where the flight was
    # paused (:func:`carried_at_step`); the first step starts by setting them again
    speed_mps: float | None = None
    reverse: bool = False


DEFAULT_OPTIONS = ExpandOptions()


@dataclass(frozen=True)
class Context:
    """What the expansion needs from the rest of the mission (all in the mission frame)."""

    mode: MotionMode
    speed_mps: float  # the cruise speed before any DO_CHANGE_SPEED
    min_speed_mps: float
    max_speed_mps: float
    tolerance_m: float  # the mission's default arrival radius
    start_xy_m: XY | None  # where the rover is when the mission starts (None: not known)
    home_xy_m: XY  # where NAV_RETURN_TO_LAUNCH goes until a DO_SET_HOME moves it
    global_frame: bool  # lat/lon mission: DO_SET_HOME with a place can be sent
    # the point the steps' texts give places from (a lat/lon mission: waypoint 1, the same
    # in `check`, which has no EKF origin, and in flight); the plan itself is not moved
    shown_from_xy_m: XY = (0.0, 0.0)
    # a DO_JUMP repeated forever is planned for at least this long (s): the time limit in
    # force, which ends the patrol
    patrol_s: float = 1800.0


@dataclass
class Expansion:
    waypoints: list[PlanWaypoint]
    program: Program
    problems: list[str] = field(default_factory=list)  # what run (and check) refuse
    notes: list[str] = field(default_factory=list)  # what check lists


def _label(c: Cmd) -> str:
    return f"item {c.index} {c.name}"


def _fmt_xy(xy: XY, shown_from: XY = (0.0, 0.0)) -> str:
    return f"({xy[0] - shown_from[0]:.2f}, {xy[1] - shown_from[1]:.2f})"


def _named(c: Cmd) -> str:
    """A command's non-default named parameters, e.g. "channel 9, pwm_us 1900"."""
    spec = c.wp.spec
    parts: list[str] = []
    defaults = spec.defaults()
    for i, pspec in enumerate(spec.params):
        if pspec is None:
            continue
        v = c.p(i)
        d = defaults[i] if i < len(defaults) else 0.0
        if math.isnan(v) and d is None:
            continue
        if d is not None and v == d:
            continue
        parts.append(f"{pspec.name} {v:g}")
    if not spec.params and c.wp.params is not None:
        parts.append("params " + ", ".join(f"{c.p(i):g}" for i in range(len(c.wp.params))))
    return ", ".join(parts)


def _circle(centre: XY, radius_m: float, turns: float, ccw: bool, entry_from: XY) -> list[XY]:
    """NAV_LOITER_TURNS as a polygon: the point of the circle nearest ``entry_from``, then
    ``turns`` times around (Rover/mode_circle.cpp drives to the nearest edge point first)."""
    cx, cy = centre
    dx, dy = entry_from[0] - cx, entry_from[1] - cy
    theta0 = math.atan2(dy, dx) if math.hypot(dx, dy) > 1e-9 else 0.0
    per_turn = min(
        CIRCLE_POINTS_MAX,
        max(CIRCLE_POINTS_MIN, math.ceil(2 * math.pi * radius_m / CIRCLE_SEGMENT_M)),
    )
    n = max(1, math.ceil(turns * per_turn - 1e-9))
    sweep = (1.0 if ccw else -1.0) * turns * 2 * math.pi
    pts = [(cx + radius_m * math.cos(theta0), cy + radius_m * math.sin(theta0))]
    for k in range(1, n + 1):
        a = theta0 + sweep * k / n
        pts.append((cx + radius_m * math.cos(a), cy + radius_m * math.sin(a)))
    return pts


def loiter_turns(c: WaypointSpec) -> tuple[float, float, bool]:
    """(turns, radius_m, counter-clockwise) as AP_Mission stores NAV_LOITER_TURNS: turns below
    one in 1/256ths, else whole turns up to 255; the radius in whole metres up to 255 m, tens of
    metres above; Rover drives at least 0.1 m (AR_CIRCLE_RADIUS_MIN)."""
    p1, p3 = c.param(0), c.param(2)
    p1 = p1 if math.isfinite(p1) else 0.0
    p3 = p3 if math.isfinite(p3) else 0.0
    turns = math.floor(p1 * 256.0) / 256.0 if 0.0 < p1 < 1.0 else float(int(min(255.0, p1)))
    r = abs(p3)
    radius = float(int(r)) if r <= 255.0 else float(int(min(255.0, r * 0.1)) * 10)
    return max(0.0, turns), max(radius, CIRCLE_RADIUS_MIN_M), p3 < 0.0


@dataclass(frozen=True)
class _Leg:
    """What a navigation item does: its text, the plan waypoints it drives (first, last), its
    hold (s) and whether it waits for the operator."""

    where: str
    span: tuple[int, int] | None = None
    hold_s: float = 0.0
    forever: bool = False


class _Builder:
    """Turns the walk into plan waypoints and steps, following Rover's start_command."""

    def __init__(
        self,
        ctx: Context,
        options: ExpandOptions,
        waypoint_for: Callable[[WaypointSpec, XY, bool], PlanWaypoint],
    ) -> None:
        self.ctx = ctx
        self.options = options
        self.waypoint_for = waypoint_for
        self.waypoints: list[PlanWaypoint] = []
        self.steps: list[NavStep] = []
        self.problems: list[str] = []
        self.notes: list[str] = []
        self.noted: set[tuple[int, str]] = set()
        self.here: XY | None = ctx.start_xy_m  # None: not known yet (check, ENU mission)
        self.home: XY = ctx.home_xy_m
        self.speed = ctx.speed_mps if options.speed_mps is None else options.speed_mps
        self.carried = self.carried_actions()  # started with the first step

    def carried_actions(self) -> list[MissionAction]:
        """The speed and direction a walk starts with (:attr:`ExpandOptions.speed_mps`,
        :attr:`ExpandOptions.reverse`), set again as its first step starts."""
        out: list[MissionAction] = []
        item = max(self.options.first_item, 1)
        speed = self.options.speed_mps
        if speed is not None:
            text = f"cruise {speed:.2f} m/s, carried on from where the flight stopped"
            out.append(
                MissionAction(item, MAV_CMD_DO_CHANGE_SPEED, ActionKind.SPEED, speed, text=text)
            )
        if self.options.reverse and self.ctx.mode is not MotionMode.OMNI:
            text = "reverse, carried on from where the flight stopped"
            out.append(
                MissionAction(item, MAV_CMD_DO_SET_REVERSE, ActionKind.REVERSE, 1.0, text=text)
            )
        return out

    def problem(self, c: Cmd, text: str) -> None:
        line = f"{_label(c)}: {text}"
        if line not in self.problems:
            self.problems.append(line)

    def note(self, c: Cmd, text: str) -> None:
        if (c.index, text) not in self.noted:
            self.noted.add((c.index, text))
            self.notes.append(f"{_label(c)}: {text}")

    def skip_text(self, c: Cmd) -> str:
        why = c.wp.spec.why
        if c.role is Role.IGNORED:
            return f"ignored, as ArduPilot Rover ignores it here ({why})"
        return f"skipped, as ArduPilot Rover skips it ({why})"

    def passed_over(self, c: Cmd) -> str:
        """A navigation item Rover does not start, or one helixd cannot fly."""
        if c.role is Role.NAV_SKIPPED:
            text = self.skip_text(c)
            if self.options.strict:
                self.problem(c, f"{text}; --strict refuses it")
            else:
                self.note(c, text)
            return f"{_label(c)}: {text}"
        why = c.wp.spec.why
        self.problem(c, f"{why} (ArduPilot refuses it at upload)")
        return f"{_label(c)}: not a mission command"

    # -- do/condition items ----------------------------------------------------------------

    def actions(self, chain: Sequence[Cmd]) -> list[MissionAction]:
        out: list[MissionAction] = []
        for c in chain:
            out.append(self.action(c))
        return out

    def action(self, c: Cmd) -> MissionAction:
        role = c.role
        item, command = c.index, c.wp.command
        named = _named(c)
        text = f"{c.name} {named}".strip()
        if role is Role.SEND:
            return MissionAction(
                item, command, ActionKind.SEND, params=self.send_params(c), text=text
            )
        if role is Role.SET_HOME:
            return self.set_home(c)
        if role is Role.SPEED:
            return self.change_speed(c)
        if role is Role.REVERSE:
            back = stored_whole(c.p(0)) == 1
            if self.ctx.mode is MotionMode.OMNI:
                self.note(c, "ignored in OMNI: the rover drives any way without turning")
                return MissionAction(
                    item, command, ActionKind.NOTE, text=f"{text} (ignored in OMNI)"
                )
            return MissionAction(item, command, ActionKind.REVERSE, 1.0 if back else 0.0, text=text)
        if role is Role.CONDITION_DELAY:
            delay = max(0.0, c.p(0)) if math.isfinite(c.p(0)) else 0.0
            text = f"{c.name}: the items after it wait {delay:g} s"
            return MissionAction(item, command, ActionKind.WAIT_TIME, delay, text=text)
        if role is Role.CONDITION_DISTANCE:
            dist = c.p(0) if math.isfinite(c.p(0)) else 0.0
            text = f"{c.name}: the items after it wait until {dist:g} m from the target"
            return MissionAction(item, command, ActionKind.WAIT_DISTANCE, dist, text=text)
        if role is Role.TAG:
            return MissionAction(
                item, command, ActionKind.NOTE, text=f"JUMP_TAG {stored_whole(c.p(0))}"
            )
        if role in SKIP_ROLES:
            why = self.skip_text(c)
            if self.options.strict:
                self.problem(c, f"{why}; --strict refuses it")
            else:
                self.note(c, why)
            return MissionAction(item, command, ActionKind.NOTE, text=f"{text}: {why}")
        why = c.wp.spec.why or "helixd cannot run it"
        if self.options.skip_unsupported:
            self.note(c, f"passed over (--skip-unsupported): {why}")
            return MissionAction(item, command, ActionKind.NOTE, text=f"{text}: passed over")
        self.problem(c, f"{why} (--skip-unsupported passes over it)")
        return MissionAction(item, command, ActionKind.NOTE, text=text)

    def send_params(self, c: Cmd) -> tuple[float, float, float, float, float, float, float]:
        p = [c.p(i) for i in range(6)]
        p = [v if math.isfinite(v) else 0.0 for v in p]
        z = c.wp.z or 0.0
        if c.wp.spec.has_place:
            lat, lon = c.latlon if c.latlon is not None else (0.0, 0.0)
            return (p[0], p[1], p[2], p[3], lat, lon, z)
        return (p[0], p[1], p[2], p[3], p[4], p[5], z)

    def fmt(self, xy: XY) -> str:
        """A place in the steps' texts (from :attr:`Context.shown_from_xy_m`)."""
        return _fmt_xy(xy, self.ctx.shown_from_xy_m)

    def where_here(self) -> str:
        return "the start" if self.here is None else self.fmt(self.here)

    def set_home(self, c: Cmd) -> MissionAction:
        current = stored_whole(c.p(0)) == 1
        text = f"{c.name}: home where the rover is ({self.where_here()})"
        if current:
            self.home = self.here if self.here is not None else self.home
        elif c.xy is None:
            self.problem(
                c,
                "home at latitude/longitude 0, 0: ArduPilot's mission would put home there; "
                "give a place or use_current: 1",
            )
        elif not self.ctx.global_frame:
            self.problem(
                c,
                "a home with a place needs a global (lat/lon) mission to tell the autopilot "
                "where; use use_current: 1",
            )
        else:
            self.home = c.xy
            text = f"{c.name}: home at {self.fmt(c.xy)}"
        params = self.send_params(c)
        if current:
            params = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        return MissionAction(
            c.index, MAV_CMD_DO_SET_HOME, ActionKind.SEND, params=params, text=text
        )

    def change_speed(self, c: Cmd) -> MissionAction:
        asked = c.p(1)
        item, command = c.index, c.wp.command
        if speed_refused(asked):
            text = f"{c.name} {asked:g} m/s: no change (below {SPEED_MIN_MPS} m/s, as Rover)"
            return MissionAction(item, command, ActionKind.NOTE, text=text)
        lo = speed_floor_mps(self.ctx.min_speed_mps)
        bounded, side = bound_speed(asked, lo, self.ctx.max_speed_mps)
        text = f"{c.name} → {bounded:.2f} m/s"
        if side:
            limit = "control.max_speed_mps" if side == "high" else "control.min_speed_mps"
            self.note(c, f"{asked:g} m/s bounded to {bounded:.2f} m/s by {limit}")
            text += f" ({asked:g} asked, bounded by {limit})"
        self.speed = bounded
        return MissionAction(item, command, ActionKind.SPEED, bounded, text=text)

    # -- navigation items ------------------------------------------------------------------

    def go(self, wp: WaypointSpec, xy: XY, stop: bool) -> tuple[int, int] | None:
        """Add a plan waypoint to ``xy`` (none when the rover is already there)."""
        if self.here is not None and math.dist(xy, self.here) < SAME_PLACE_M:
            if stop:
                self.stop_here()
            return None
        self.waypoints.append(self.waypoint_for(wp, xy, stop))
        self.here = xy
        n = len(self.waypoints) - 1
        return n, n

    def stop_here(self) -> None:
        """The rover stops where the last leg ended (a hold or a delay follows it)."""
        if self.waypoints and not self.waypoints[-1].stop:
            self.waypoints[-1] = replace(self.waypoints[-1], stop=True)

    def step(
        self,
        c: Cmd,
        chain: Sequence[Cmd],
        passed: Sequence[str],
        via: str,
        endless_chain: bool,
    ) -> NavStep:
        """The navigation step of item ``c``: the do items of ``chain`` started with it (and
        what the walk carried on), then what ``c`` itself does (Rover's start_command)."""
        actions = [*self.carried, *self.actions(chain)]
        self.carried = []
        if endless_chain:
            first = chain[0]
            self.problem(
                first,
                "a DO_JUMP loops over do items only: ArduPilot would repeat them without end "
                "until the next waypoint",
            )
        leg = self.nav_leg(c)
        where = leg.where
        if leg.hold_s > 0.0 and c.role is not Role.NAV_DELAY:
            where += f", hold {leg.hold_s:g} s"
        if leg.forever:
            where += ", waits for the operator"
        text = f"{c.name} {where}".strip() + (f" {via}" if via else "")
        return NavStep(
            item=c.index,
            command=c.wp.command,
            first_waypoint=None if leg.span is None else leg.span[0],
            last_waypoint=None if leg.span is None else leg.span[1],
            hold_s=leg.hold_s,
            actions=tuple(actions),
            speed_mps=self.speed,
            text=text,
            forever=leg.forever,
            skipped=tuple(passed),
        )

    def nav_leg(self, c: Cmd) -> _Leg:
        """What navigation item ``c`` does, by its role (Rover/mode_auto.cpp)."""
        role = c.role
        if role in (Role.WAYPOINT, Role.LOITER_TIME, Role.LOITER_UNLIM):
            return self.drive_to(c)
        if role is Role.RETURN:
            return _Leg(f"→ home {self.fmt(self.home)}", self.go(c.wp, self.home, True))
        if role is Role.LOITER_TURNS:
            return self.circle(c)
        if role is Role.NAV_DELAY:
            return self.delay(c)
        # NAV_REFUSED: Rover would start it
        why = c.wp.spec.why
        if self.options.skip_unsupported:
            self.note(c, f"passed over (--skip-unsupported): {why}")
        else:
            self.problem(c, f"{why} (--skip-unsupported passes over it)")
        return _Leg("not flown")

    def drive_to(self, c: Cmd) -> _Leg:
        """NAV_WAYPOINT, NAV_LOITER_TIME, NAV_LOITER_UNLIM: drive to the place (none: stay),
        hold there ``param1`` whole seconds or until the operator continues."""
        role = c.role
        raw = c.p(0) if role is not Role.LOITER_UNLIM else 0.0
        hold = float(max(0, stored_whole(raw)))
        forever = role is Role.LOITER_UNLIM
        stop = hold > 0.0 or role is not Role.WAYPOINT
        span: tuple[int, int] | None = None
        if c.xy is None:
            where = f"stays where it is, at {self.where_here()}"
            if stop:
                self.stop_here()
        else:
            span = self.go(c.wp, c.xy, stop)
            where = f"→ {self.fmt(c.xy)}"
        if forever and not self.options.operator_continue:
            self.problem(
                c,
                "waits until the operator continues the mission; `helixd run` cannot "
                "continue it yet: use NAV_LOITER_TIME with a time",
            )
        return _Leg(where, span, hold, forever)

    def circle(self, c: Cmd) -> _Leg:
        """NAV_LOITER_TURNS: the circle's points, entered at the one nearest the rover."""
        turns, radius, ccw = loiter_turns(c.wp)
        centre = c.xy if c.xy is not None else (self.here or self.home)
        where = f"{turns:g} turns, radius {radius:g} m around {self.fmt(centre)}"
        if turns <= 0.0:
            return _Leg(where)
        begin = len(self.waypoints)
        for xy in _circle(centre, radius, turns, ccw, self.here or centre):
            self.go(c.wp, xy, False)
        if len(self.waypoints) == begin:
            return _Leg(where)
        where += f" ({len(self.waypoints) - begin} points)"
        return _Leg(where, (begin, len(self.waypoints) - 1))

    def delay(self, c: Cmd) -> _Leg:
        """NAV_DELAY: stop where the rover is for ``param1`` seconds."""
        delay = c.p(0)
        if not (math.isfinite(delay) and delay > 0.0):
            self.problem(
                c,
                "waits until a time of day (param1 not > 0): helixd has no clock for it; "
                "give delay_s",
            )
            delay = 0.0
        self.stop_here()
        return _Leg(f"stops {delay:g} s", hold_s=delay)


class _Patrol:
    """A DO_JUMP repeated forever (repeat −1): ArduPilot flies its loop until someone stops
    it. The walk unrolls laps until they outlast the time limit in force
    (:attr:`Context.patrol_s`, counted at cruise speed, which the flight never beats) and one
    lap more; the last step then holds where it ends until the rover is stopped, so the
    plan never "completes" a patrol."""

    def __init__(self) -> None:
        self.item = 0  # the DO_JUMP item
        self.lap_starts: list[int] = []  # step index where lap 2, 3, … starts
        self._counted = 0  # steps counted in the lower bound so far
        self._lower_s = 0.0  # the flight of those steps takes at least this long (s)
        self._at: XY | None = None  # where those steps end
        self._at_laps: list[float] = []  # the lower bound when each lap from lap 2 starts

    def planned(self, b: _Builder, ctx: Context) -> bool:
        """Enough laps: the flight up to the lap before this one already outlasts the time
        limit, so a whole lap lies beyond it."""
        if self._at is None:
            first = b.waypoints[0] if b.waypoints else None
            self._at = ctx.start_xy_m or ((first.x_m, first.y_m) if first else (0.0, 0.0))
        for step in b.steps[self._counted :]:
            if step.first_waypoint is not None and step.last_waypoint is not None:
                for w in b.waypoints[step.first_waypoint : step.last_waypoint + 1]:
                    metres = math.dist(self._at, (w.x_m, w.y_m))
                    self._lower_s += metres / max(step.speed_mps, SPEED_MIN_MPS)
                    self._at = (w.x_m, w.y_m)
            self._lower_s += step.hold_s
        self._counted = len(b.steps)
        self._at_laps.append(self._lower_s)
        return len(self._at_laps) >= 2 and self._at_laps[-2] > ctx.patrol_s

    def lap_done(self, walker: Walker, b: _Builder, ctx: Context) -> bool:
        """Count the lap a forever jump just started; True when enough laps are planned (or
        the plan holds all the steps it may)."""
        if not self.lap_starts:
            self.item = next(iter(walker.forever_taken))
        new_lap = sum(walker.forever_taken.values()) > len(self.lap_starts)
        if new_lap:
            self.lap_starts.append(len(b.steps))
        return (new_lap and self.planned(b, ctx)) or len(b.steps) >= PATROL_STEPS_MAX

    def end(self, b: _Builder, ctx: Context) -> str:
        if self.lap_starts and self.lap_starts[-1] >= len(b.steps):
            self.lap_starts.pop()  # the lap that would start now is not flown
        laps = len(self.lap_starts) + 1
        if b.steps:
            last = b.steps[-1]
            if last.first_waypoint is not None:
                b.stop_here()
            b.steps[-1] = replace(
                last,
                forever=True,
                text=f"{last.text}; the patrol's planned laps end here: it holds until stopped",
            )
        beyond = (
            "more than that limit"
            if len(b.steps) < PATROL_STEPS_MAX
            else f"all a plan holds ({PATROL_STEPS_MAX} steps); then it holds where it is"
        )
        return (
            f"item {self.item} DO_JUMP repeats forever: a patrol flown until it is stopped "
            f"(Ctrl-C, a mode change, the ground station) or its time limit "
            f"({ctx.patrol_s:.0f} s) ends it; {laps} laps planned, {beyond}"
        )


def expand(
    entries: Sequence[WaypointSpec],
    places: Sequence[XY | None],
    latlons: Sequence[tuple[float, float] | None],
    ctx: Context,
    waypoint_for: Callable[[WaypointSpec, XY, bool], PlanWaypoint],
    options: ExpandOptions = DEFAULT_OPTIONS,
) -> Expansion:
    """Walk the mission as ArduPilot does and build the flight: plan waypoints and program.

    ``places`` holds each entry's place in the mission frame (None: none or "here"),
    ``latlons`` a global mission's lat/lon (for commands sent to the autopilot), and
    ``waypoint_for(entry, xy, stop)`` makes the plan waypoint for an entry's place."""
    cmds = [
        Cmd(i + 1, wp, xy, ll)
        for i, (wp, xy, ll) in enumerate(zip(entries, places, latlons, strict=True))
    ]
    walker = Walker(cmds)
    walker.runs = dict(options.jumps_taken)
    b = _Builder(ctx, options, waypoint_for)
    first = min(max(options.first_item, 1), len(cmds))
    walk = _StepWalk(walker, b, cmds)
    walk.run(first)
    final = walk.final_actions() if walk.ran_out else []
    ending = walk.ending
    for jump, target in sorted(walker.bad_jumps):
        b.notes.append(
            f"item {jump} {cmds[jump - 1].name}: jumps to item {target}, which is not in the "
            "mission: ArduPilot ends the mission there"
        )
        ending = ending or f"item {jump} jumps to a missing item"
    _note_not_run(b, cmds, walk.visited, first)
    program = Program(
        steps=tuple(b.steps),
        final_actions=tuple(final),
        ending=ending,
        never_ends=walk.never_ends,
        patrol_item=walk.patrol.item,
        lap_starts=tuple(walk.patrol.lap_starts),
        notes=tuple(b.notes),
        start_xy_m=ctx.start_xy_m,
        items_total=len(cmds),
    )
    return Expansion(b.waypoints, program, b.problems, b.notes)


class _StepWalk:
    """The walk turned into steps, one navigation item after another, until the mission is
    complete (:attr:`ran_out`), waits for the operator or its patrol is planned long enough
    (:attr:`never_ends`), or it grows too long."""

    def __init__(self, walker: Walker, b: _Builder, cmds: Sequence[Cmd]) -> None:
        self.walker = walker
        self.b = b
        self.cmds = cmds
        self.visited: set[int] = set()
        self.patrol = _Patrol()
        self.ending = ""
        self.never_ends = False
        self.ran_out = False
        # when the walk runs out: the do item met and the navigation items passed over
        self.left_do: Cmd | None = None
        self.left_passed: list[Cmd] = []

    def run(self, first: int) -> None:
        walker, b, options = self.walker, self.b, self.b.options
        nav, first_do, passed = walker.advance_nav(None if first <= 1 else first - 1, rover_starts)
        jumps_before: dict[int, int] = {}
        while nav is not None:
            if walker.forever_taken and self.patrol.lap_done(walker, b, b.ctx):
                self.ending = self.patrol.end(b, b.ctx)
                self.never_ends = True
                return
            self.visited.add(nav.index)
            self.visited.update(p.index for p in passed)
            chain, endless = walker.do_chain(first_do) if first_do is not None else ([], False)
            self.visited.update(c.index for c in chain)
            via = _via(walker, jumps_before, self.cmds)
            passed_text = [b.passed_over(p) for p in passed]
            b.steps.append(b.step(nav, chain, passed_text, via, endless))
            if nav.role is Role.LOITER_UNLIM and not options.operator_continue:
                self.ending = f"item {nav.index} NAV_LOITER_UNLIM waits for the operator"
                self.never_ends = True
                return
            if len(b.steps) >= MAX_STEPS:
                b.problems.append(
                    f"the mission expands to more than {MAX_STEPS} navigation steps (jumps): "
                    "split it"
                )
                return
            jumps_before = dict(walker.runs)
            nav, first_do, passed = walker.advance_nav(nav.index, rover_starts)
        self.ran_out = True
        self.left_do, self.left_passed = first_do, passed

    def final_actions(self) -> list[MissionAction]:
        """The mission is complete: the navigation items passed over on the way, and the do
        item AP_Mission started before finding nothing more to fly."""
        self.visited.update(p.index for p in self.left_passed)
        for p in self.left_passed:
            self.b.passed_over(p)
        if self.left_do is None:
            return []
        self.visited.add(self.left_do.index)
        return self.b.actions([self.left_do])


def _note_not_run(b: _Builder, cmds: Sequence[Cmd], visited: set[int], first: int) -> None:
    """A note for each item the walk never started (jumps aside)."""
    for c in cmds:
        if c.index not in visited and c.wp.command not in (MAV_CMD_DO_JUMP, MAV_CMD_DO_JUMP_TAG):
            if c.index < first:
                b.notes.append(f"{_label(c)}: before the start at item {first}: not run")
                continue
            b.notes.append(
                f"{_label(c)}: never run (ArduPilot's walk through the mission never starts it)"
            )


def carried_at_step(
    program: Program, step: int, options: ExpandOptions
) -> tuple[float | None, bool]:
    """The cruise speed (m/s) and direction (reverse) in effect as step ``step`` (1-based) of
    ``program`` (walked with ``options``) starts, before its own do items: what the steps
    before it set, else what the walk started with. Speed None: none set (the configured
    cruise speed). A step past the program's end counts every step."""
    speed, reverse = options.speed_mps, options.reverse
    for s in program.steps[: max(step - 1, 0)]:
        for a in s.actions:
            if a.kind is ActionKind.SPEED:
                speed = s.speed_mps
            elif a.kind is ActionKind.REVERSE:
                reverse = a.value == 1.0
    return speed, reverse


def _via(walker: Walker, before: dict[int, int], cmds: Sequence[Cmd]) -> str:
    """Which jump the walk took to reach this step, e.g. "(DO_JUMP item 5, 1 of 2)"."""
    for index, runs in walker.runs.items():
        if runs > before.get(index, 0):
            c = cmds[index - 1]
            times = stored_whole(c.p(1))
            count = f"lap {runs + 1}, forever" if times == JUMP_FOREVER else f"{runs} of {times}"
            return f"(after {command_name(c.wp.command)} item {index}, {count})"
    return ""


__all__ = [
    "DEFAULT_OPTIONS",
    "Context",
    "ExpandOptions",
    "Expansion",
    "carried_at_step",
    "expand",
    "loiter_turns",
]
