"""Resolve a mission file into a plan: waypoints in the mission frame, ready for the navigator.

Pure: no I/O. ``global`` missions need the EKF origin (GPS_GLOBAL_ORIGIN) to resolve.
:class:`Plan` and :class:`PlanWaypoint` live in :mod:`helixd.base.plan` (re-exported here).

A plain list of waypoints resolves one plan waypoint per entry. A mission with commands is
walked as ArduPilot Rover flies it (:mod:`helixd.mission.expand`): the plan then carries the
:class:`~helixd.base.plan.Program` (jumps expanded, holds, returns, payload commands), and
``where`` says where the mission starts and where home is (``check``: the start point or the
mission's home; ``run``: the rover's pose and the autopilot's HOME_POSITION).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ParamSpec

from helixd.base.angles import wrap_pi
from helixd.base.frames import latlon_to_ne
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.control import ControlConfig
from helixd.config.mission import MissionLimits
from helixd.config.safety import SafetyConfig
from helixd.files.models import entry_label
from helixd.mav.constants import MAV_CMD_NAV_RETURN_TO_LAUNCH, MAV_CMD_NAV_WAYPOINT
from helixd.mission.commands import FLY_ROLES
from helixd.mission.expand import DEFAULT_OPTIONS, Context, ExpandOptions, expand
from helixd.mission.model import Mission, WaypointSpec

P = ParamSpec("P")

XY = tuple[float, float]
DEFAULT_TIME_LIMIT_S: float = SafetyConfig.model_fields["mission_time_limit_s"].default


# A ground station's way to pin a leg's mode without new software: NAV_WAYPOINT's param4
# ("Yaw" in QGroundControl's and Mission Planner's editors; ArduPilot Rover ignores it) set to
# one of these codes flies the leg to that waypoint in that mode, whatever the media map says.
GCS_MODE_CODES: dict[float, MotionMode] = {
    -1.0: MotionMode.ROLL,
    -2.0: MotionMode.SCROLL,
    -3.0: MotionMode.OMNI,
}


def leg_mode(wp: WaypointSpec) -> MotionMode | None:
    """The mode a waypoint pins on its leg: its own ``mode`` (YAML), else a ground station's
    mode code in NAV_WAYPOINT's param4 (:data:`GCS_MODE_CODES`), else None (the medium's)."""
    if wp.mode is not None:
        return wp.mode
    if wp.command != MAV_CMD_NAV_WAYPOINT or wp.params is None:
        return None
    return GCS_MODE_CODES.get(wp.param(3))


class PlanError(ValueError):
    """The mission cannot be resolved (e.g. a global point beyond the max range)."""


@dataclass(frozen=True)
class Where:
    """Where a mission with commands starts and where its home is, in the mission frame
    (x/y metres: start frame as written, ENU = east/north of the EKF origin). None: not known
    (``check``): the start point of a start-frame mission, else the mission's own home, else
    its first place stands in."""

    start_xy_m: XY | None = None
    home_xy_m: XY | None = None


NOWHERE = Where()


@dataclass(frozen=True)
class Resolved:
    """A resolved plan and what the walk through its commands found."""

    plan: Plan
    problems: tuple[str, ...] = field(default=())  # what run (and check) refuse
    notes: tuple[str, ...] = field(default=())  # what check lists (skipped items, …)


class _MissionToPlane:
    """The mission's coordinates → the control core's x/y (and compass headings → yaw)."""

    def __init__(self, mission: Mission, origin_latlon_deg: tuple[float, float] | None) -> None:
        self.kind = mission.frame
        if self.kind is MissionFrameKind.GLOBAL and origin_latlon_deg is None:
            raise PlanError("a global mission needs the EKF origin (GPS_GLOBAL_ORIGIN)")
        self.origin = origin_latlon_deg

    def xy(self, a: float, b: float) -> XY:
        """start frame: (x, y) as written. local_ned/global: x = East, y = North (ENU)."""
        if self.kind is MissionFrameKind.START:
            return a, b
        if self.kind is MissionFrameKind.GLOBAL:
            assert self.origin is not None
            north, east = latlon_to_ne(a, b, *self.origin)
        else:
            north, east = a, b
        return east, north

    def yaw(self, heading_deg: float | None) -> float | None:
        if heading_deg is None:
            return None
        if self.kind is MissionFrameKind.START:
            return wrap_pi(math.radians(heading_deg))
        return wrap_pi(math.pi / 2 - math.radians(heading_deg))


def _check_range(xy: XY, limits: MissionLimits, what: str) -> None:
    rng = math.hypot(*xy)
    if rng > limits.max_range_m:
        raise PlanError(
            f"{what}: {rng:.1f} m from the origin; allowed at most "
            f"mission.max_range_m = {limits.max_range_m} m"
        )


def resolve(
    mission: Mission,
    control: ControlConfig,
    limits: MissionLimits,
    origin_latlon_deg: tuple[float, float] | None = None,
    where: Where = NOWHERE,
    options: ExpandOptions = DEFAULT_OPTIONS,
    time_limit_s: float = DEFAULT_TIME_LIMIT_S,
) -> Resolved:
    """Convert the file's waypoints into the mission frame used by the control core, with
    what the walk through a mission's commands found (:func:`resolve_plan`: the plan alone).

    start frame: (x, y) as written.  local_ned/global: x = East, y = North (ENU), compass
    headings converted to CCW-from-East. ``time_limit_s``: the config's
    ``safety.mission_time_limit_s`` (the mission's own ``time_limit_s`` replaces it): how
    long a patrol (a DO_JUMP repeated forever) is planned."""
    frame = _MissionToPlane(mission, origin_latlon_deg)
    default_tol = mission.tolerance_m or control.waypoint_tolerance_m
    speed = min(mission.speed_mps or control.max_speed_mps, control.max_speed_mps)
    waypoint_for = _WaypointMaker(frame, default_tol)
    if not mission.has_commands():
        return Resolved(_plain_plan(mission, frame, limits, waypoint_for, speed))
    places, latlons = _command_places(mission, frame, limits)
    first = frame.xy(*mission.points()[0])
    start, home = _start_and_home(mission, frame, where, first)
    _check_range(home, limits, "home")
    ctx = Context(
        mode=mission.mode,
        speed_mps=speed,
        min_speed_mps=control.min_speed_mps,
        max_speed_mps=control.max_speed_mps,
        tolerance_m=default_tol,
        start_xy_m=start,
        home_xy_m=home,
        global_frame=mission.frame is MissionFrameKind.GLOBAL,
        shown_from_xy_m=first if mission.frame is MissionFrameKind.GLOBAL else (0.0, 0.0),
        patrol_s=mission.time_limit_s or time_limit_s,
    )
    got = expand(mission.waypoints, places, latlons, ctx, waypoint_for, options)
    if not got.waypoints:
        got.problems.append(
            "the mission as ArduPilot Rover flies it goes nowhere (every place is where the "
            "rover already is): nothing to fly"
        )
        got.waypoints.append(waypoint_for(mission.places()[0], first, True))
    plan = Plan(
        mission.name,
        mission.mode,
        mission.frame,
        tuple(got.waypoints),
        speed,
        program=got.program,
    )
    notes = list(got.notes)
    returns = any(s.command == MAV_CMD_NAV_RETURN_TO_LAUNCH for s in got.program.steps)
    if returns and where.home_xy_m is None:
        notes.append(_return_note(mission, start))
    return Resolved(plan, tuple(got.problems), tuple(notes))


@dataclass(frozen=True)
class _WaypointMaker:
    """The plan waypoint for an entry's place: its tolerance (else the mission's), its final
    heading as a yaw, the mode it pins on its leg."""

    frame: _MissionToPlane
    default_tol_m: float

    def __call__(self, wp: WaypointSpec, xy: XY, stop: bool) -> PlanWaypoint:
        """For the walk of a mission with commands (:func:`helixd.mission.expand.expand`)."""
        return self.make(wp, xy, stop=stop)

    def make(
        self, wp: WaypointSpec, xy: XY, *, stop: bool = False, via: bool = False
    ) -> PlanWaypoint:
        return PlanWaypoint(
            x_m=xy[0],
            y_m=xy[1],
            tolerance_m=wp.tolerance_m or self.default_tol_m,
            final_yaw_rad=self.frame.yaw(wp.heading_deg),
            via=via,
            stop=stop,
            mode=leg_mode(wp),
        )


def _plain_plan(
    mission: Mission,
    frame: _MissionToPlane,
    limits: MissionLimits,
    waypoint_for: _WaypointMaker,
    speed_mps: float,
) -> Plan:
    """A plain list of waypoints: one plan waypoint per entry."""
    out: list[PlanWaypoint] = []
    for i, (wp, (a, b)) in enumerate(zip(mission.waypoints, mission.points(), strict=True)):
        xy = frame.xy(a, b)
        _check_range(xy, limits, entry_label(i))
        out.append(waypoint_for.make(wp, xy, via=wp.via))
    return Plan(mission.name, mission.mode, mission.frame, tuple(out), speed_mps)


def _command_places(
    mission: Mission, frame: _MissionToPlane, limits: MissionLimits
) -> tuple[list[XY | None], list[tuple[float, float] | None]]:
    """Each item's place in the mission frame (None: none or "here"), checked in range where
    the rover drives to it, and a global mission's lat/lon (for commands sent)."""
    places: list[XY | None] = []
    latlons: list[tuple[float, float] | None] = []
    for i, wp in enumerate(mission.waypoints):
        pos = mission.position(wp)
        if pos is None:
            places.append(None)
            latlons.append(None)
            continue
        xy = frame.xy(*pos)
        if wp.spec.role in FLY_ROLES:
            _check_range(xy, limits, entry_label(i))
        places.append(xy)
        latlons.append(pos if mission.frame is MissionFrameKind.GLOBAL else None)
    return places, latlons


def _start_and_home(
    mission: Mission, frame: _MissionToPlane, where: Where, first: XY
) -> tuple[XY | None, XY]:
    """Where the walk starts (a start-frame mission: its origin; else None when not known)
    and where home is (the autopilot's, else the mission's, else the start or ``first``)."""
    start = where.start_xy_m
    if mission.frame is MissionFrameKind.START and start is None:
        start = (0.0, 0.0)  # the frame's origin is the start, by definition
    home = where.home_xy_m
    if home is None:
        home = frame.xy(*mission.home) if mission.home is not None else (start or first)
    return start, home


def _return_note(mission: Mission, start: XY | None) -> str:
    """Where a check shows NAV_RETURN_TO_LAUNCH going, where a run's goes instead."""
    if mission.home is not None:
        said = "the mission's home"
    else:
        said = "the start" if start is not None else "the first place (the start is not known)"
    return (
        f"NAV_RETURN_TO_LAUNCH shown going to {said}; a run returns to the autopilot's own "
        "home (HOME_POSITION, where it was armed)"
    )


def _plan_only(resolved: Callable[P, Resolved]) -> Callable[P, Plan]:
    def plan(*args: P.args, **kwargs: P.kwargs) -> Plan:
        return resolved(*args, **kwargs).plan

    plan.__doc__ = ":func:`resolve`'s plan alone (same arguments)."
    return plan


resolve_plan = _plan_only(resolve)


def places_from(frame: MissionFrameKind) -> str:
    """What the places in a mission's texts (``check``'s table, the steps ``run`` logs) are
    measured from: the same in both, whatever EKF origin the flight has."""
    if frame is MissionFrameKind.GLOBAL:
        return "x east / y north of waypoint 1"
    if frame is MissionFrameKind.LOCAL_NED:
        return "x east / y north of the EKF origin"
    return "x forward / y left of the start"


__all__ = ["PlanError", "Resolved", "Where", "places_from", "resolve", "resolve_plan"]
