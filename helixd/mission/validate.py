"""The one mission-vs-config check, shared by ``helixd check`` and ``helixd run``'s preflight.

Pure: no I/O, no clocks. ``helixd check`` calls it without a start pose (and without the EKF
origin); the daemon calls it again in preflight with both, before anything is armed. What can
be decided without the pose is decided identically in both places:

* ``start`` missions: the geofence radius is around the start point, i.e. the frame's origin,
  so every waypoint is checked; the keep-in polygon (EKF-origin coordinates) needs the pose.
* ``local_ned`` missions: the polygon is checked; the radius needs the start pose.
* ``global`` missions: both need the EKF origin (and the radius the pose too). Until it is
  known, the home the mission carries (a ground-station file's home row or planned home, the
  autopilot's home) stands for it: ArduPilot sets both where the rover gets its GPS fix. Its
  places are judged against ``mission.max_range_m`` and its first waypoint against
  ``mission.max_start_distance_m`` from that home; once connected, from the EKF origin and the
  rover's pose instead.
* keep-out areas the mission carries: no waypoint inside one (nor a leg through one when
  nothing plans around it).

The estimated time against ``safety.mission_time_limit_s`` needs the navigator's speed
profile (:mod:`helixd.control.estimate`), which the mission loader does not load:
:func:`helixd.mission.judge.flight_problems` adds it.

Config-only rules (channel conflicts, timeouts, polygon shape) are pydantic validators in
:mod:`helixd.config`; they already ran when the config loaded.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TypedDict, Unpack

from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne
from helixd.base.plan import MissionFrameKind, Plan, program_numbering
from helixd.base.polygon import leg_leaves_polygon, point_in_polygon, segments_intersect
from helixd.config.root import HelixdConfig
from helixd.config.safety import GEOFENCE_RADIUS_MAX_M
from helixd.files.models import entry_label
from helixd.mission.commands import FLY_ROLES, SERVO_COMMANDS, stored_whole
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.model import Mission
from helixd.mission.resolve import NOWHERE, PlanError, Resolved, Where, resolve, resolve_plan

MAX_LISTED = 5  # offending waypoints named one by one; the rest are counted


def _listed(offenders: list[str], what: str) -> list[str]:
    out = offenders[:MAX_LISTED]
    if len(offenders) > MAX_LISTED:
        out.append(f"… and {len(offenders) - MAX_LISTED} more waypoints {what}")
    return out


def plan_point_labels(plan: Plan) -> list[str]:
    """How an error names each plan waypoint: the mission entry it flies, counted from 1
    (``waypoint 3 (waypoints[2])``, a ground-station file's ``item 3``; each lap of a DO_JUMP
    the same, said once), ``via point to`` before a point the planner inserted — never
    the plan's own 0-based index, which jumps, holds and via points move away from the
    entries."""
    numbering = program_numbering(plan)
    numbers = plan.numbers() if numbering is None else numbering.numbers
    return [
        f"via point to {entry_label(n - 1)}" if w.via else entry_label(n - 1)
        for w, n in zip(plan.waypoints, numbers, strict=True)
    ]


def _ned_points(
    plan: Plan, start_ned: NedPose | None, have_origin: bool
) -> list[tuple[float, float]] | None:
    """Waypoints as (north_m, east_m) from the EKF origin, or None if not yet knowable."""
    if plan.frame is MissionFrameKind.START:
        if start_ned is None:
            return None
        frame = MissionFrame.start_at(start_ned)
        return [frame.to_ned(w.x_m, w.y_m) for w in plan.waypoints]
    if plan.frame is MissionFrameKind.GLOBAL and not have_origin:
        return None
    return [(w.y_m, w.x_m) for w in plan.waypoints]  # ENU plan: x = east, y = north


def _radius_problems(
    plan: Plan, cfg: HelixdConfig, ned: list[tuple[float, float]] | None, start: NedPose | None
) -> list[str]:
    radius = cfg.safety.geofence_radius_m
    if radius is None:
        return []
    if plan.frame is MissionFrameKind.START:
        centre = (0.0, 0.0)
        pts = [(w.x_m, w.y_m) for w in plan.waypoints]
        where = "the start point"
    elif ned is not None and start is not None:
        centre = (start.north_m, start.east_m)
        pts = ned
        where = f"the start point (N {start.north_m:.1f} m, E {start.east_m:.1f} m)"
    else:
        return []
    offenders = []
    for label, (a, b) in zip(plan_point_labels(plan), pts, strict=True):
        dist = math.hypot(a - centre[0], b - centre[1])
        if dist > radius:
            offenders.append(
                f"{label}: {dist:.1f} m from {where}; allowed at most "
                f"safety.geofence_radius_m = {radius} m"
            )
    return _listed(_once(offenders), "outside safety.geofence_radius_m")


def _once(texts: list[str]) -> list[str]:
    """Each text once, in order (a DO_JUMP flies the same item again: one line for it)."""
    return list(dict.fromkeys(texts))


def _polygon_problems(
    cfg: HelixdConfig,
    ned: list[tuple[float, float]] | None,
    start: NedPose | None,
    name: str = "safety.geofence_polygon_ne_m",
    labels: Sequence[str] = (),
) -> list[str]:
    poly = cfg.safety.geofence_polygon_ne_m
    if len(poly) < 3 or ned is None:
        return []
    problems: list[str] = []
    if start is not None and not point_in_polygon(start.north_m, start.east_m, poly):
        problems.append(
            f"the start point (N {start.north_m:.1f} m, E {start.east_m:.1f} m) is outside {name}"
            ": drive the rover inside it (a survey's: the area grown by mission survey --margin-m)"
        )
    names = list(labels) or [entry_label(i) for i in range(len(ned))]
    offenders = [
        f"{label}: N {n:.1f} m, E {e:.1f} m is outside {name}"
        for label, (n, e) in zip(names, ned, strict=True)
        if not point_in_polygon(n, e, poly)
    ]
    problems.extend(_listed(_once(offenders), f"outside {name}"))
    if offenders or problems:
        return problems
    legs = [] if start is None else [((start.north_m, start.east_m), ned[0], f"start → {names[0]}")]
    legs.extend((ned[i - 1], ned[i], f"{names[i - 1]} → {names[i]}") for i in range(1, len(ned)))
    crossing = [
        f"leg {leg} leaves {name} (both ends are inside)"
        for a, b, leg in legs
        if leg_leaves_polygon(a, b, poly)
    ]
    return _listed(_once(crossing), "whose legs leave the polygon")


def _keep_out_problems(mission: Mission, cfg: HelixdConfig) -> list[str]:
    """The mission's own keep-out areas: a waypoint inside one is refused; a leg through one
    too when nothing plans around it (``planning.enabled: false``)."""
    if not mission.keep_out_polygons:
        return []
    areas = mission.keep_outs_ne()  # a global mission: around its first waypoint
    if mission.frame is MissionFrameKind.GLOBAL:
        lat0, lon0 = mission.points()[0]
        pts = [latlon_to_ne(a, b, lat0, lon0) for a, b in mission.points()]
    else:
        pts = mission.points()
    inside = [
        f"{entry_label(i)}: inside keep_out_polygons.{k} (a keep-out area)"
        for i, (n, e) in enumerate(pts)
        for k, area in enumerate(areas)
        if point_in_polygon(n, e, area)
    ]
    if inside or cfg.planning.enabled:
        return _listed(inside, "inside keep-out areas")
    crossing = [
        f"leg {entry_label(i - 1)} → waypoint {i + 1} crosses keep_out_polygons.{k} "
        "(planning.enabled is false: nothing plans around it)"
        for i in range(1, len(pts))
        for k, area in enumerate(areas)
        if _crosses(pts[i - 1], pts[i], area)
    ]
    return _listed(crossing, "whose legs cross keep-out areas")


def _crosses(
    a: tuple[float, float], b: tuple[float, float], area: Sequence[tuple[float, float]]
) -> bool:
    """The segment a → b enters the polygon (an edge crossed, or an end inside it)."""
    if point_in_polygon(*a, area) or point_in_polygon(*b, area):
        return True
    n = len(area)
    return any(segments_intersect(a, b, area[j], area[(j + 1) % n]) for j in range(n))


def _start_distance_problems(
    plan: Plan, cfg: HelixdConfig, start: NedPose | None, home: tuple[float, float] | None
) -> list[str]:
    """The first waypoint of a ``local_ned``/``global`` mission must be near the rover
    (``mission.max_start_distance_m``): a global mission planned for another pond, or an EKF
    origin that moved, is refused here. Judged against the start pose once connected; before
    that, a global mission is judged against the home its file (or the autopilot) carries:
    ``home`` is its (north_m, east_m) in the plan's frame."""
    limit = cfg.mission.max_start_distance_m
    first = plan.waypoints[0]
    if plan.frame is MissionFrameKind.START:
        return []  # a start-frame mission is placed at the rover by definition
    if start is not None:
        at = (start.north_m, start.east_m)
        where = f"the rover (N {start.north_m:.1f} m, E {start.east_m:.1f} m)"
        why = "wrong mission, wrong place, or an EKF origin that moved?"
    elif home is not None:
        at = home
        where = "the file's home"
        why = "if the rover starts there"
    else:
        return []
    dist = math.hypot(first.x_m - at[1], first.y_m - at[0])
    if not dist <= limit:
        return [
            f"{plan_point_labels(plan)[0]}: {dist:.1f} m from {where}; the first waypoint may "
            "be at most "
            f"mission.max_start_distance_m = {limit} m away ({why})"
        ]
    return []


def _home_ne(mission: Mission) -> tuple[float, float] | None:
    """A global mission's home as (north_m, east_m) from its waypoint 0 (the frame of the plan
    ``check`` resolves); None without a home."""
    if mission.frame is not MissionFrameKind.GLOBAL or mission.home is None:
        return None
    return latlon_to_ne(*mission.home, *mission.points()[0])


def _home_range_problems(mission: Mission, cfg: HelixdConfig) -> list[str]:
    """Before the EKF origin is known, a global mission's home (a ground-station file's home
    row or planned home, the autopilot's home) stands for it: ArduPilot sets both where the
    rover gets its first GPS fix. A place farther than ``mission.max_range_m`` from it would be
    refused from the EKF origin in preflight; it is refused here."""
    if mission.frame is not MissionFrameKind.GLOBAL or mission.home is None:
        return []
    limit = cfg.mission.max_range_m
    commands = mission.has_commands()
    offenders = []
    for i, wp in enumerate(mission.waypoints):
        pos = mission.position(wp)
        if pos is None or (commands and wp.spec.role not in FLY_ROLES):
            continue
        rng = math.hypot(*latlon_to_ne(*pos, *mission.home))
        if rng > limit:
            offenders.append(
                f"{entry_label(i)}: {rng:.1f} m from the mission's home (where the EKF origin "
                f"will be); allowed at most mission.max_range_m = {limit} m"
            )
    return _listed(offenders, "beyond mission.max_range_m from the mission's home")


GEOFENCE_FALLBACK_SLACK = 1.005  # 0.5 %: the EKF map seen from another origin differs less


def mission_fence_ne(
    mission: Mission,
    *,
    origin_latlon_deg: tuple[float, float] | None = None,
    start_ned: NedPose | None = None,
) -> tuple[tuple[float, float], ...] | None:
    """The mission's ``geofence_polygon`` as (north_m, east_m) from the EKF origin; ``()`` when
    the mission has none, None when it cannot be placed yet (global without the EKF origin,
    start frame without the start pose)."""
    poly = mission.geofence_polygon
    if not poly:
        return ()
    if mission.frame is MissionFrameKind.LOCAL_NED:
        return poly
    if mission.frame is MissionFrameKind.GLOBAL:
        if origin_latlon_deg is None:
            return None
        return tuple(latlon_to_ne(a, b, *origin_latlon_deg) for a, b in poly)
    if start_ned is None:
        return None
    frame = MissionFrame.start_at(start_ned)
    return tuple(frame.to_ned(x, y) for x, y in poly)


def _fallback_radius_m(mission: Mission, cfg: HelixdConfig) -> float:
    """A radius around the start point that contains the mission's polygon, usable before the
    pose/origin is known: start frame, the farthest vertex from the start (exact); global, the
    farthest vertex from waypoint 0 plus ``mission.max_start_distance_m`` (the start is at
    most that far from waypoint 0, checked in preflight)."""
    poly = mission.geofence_polygon
    if mission.frame is MissionFrameKind.START:
        return max(math.hypot(x, y) for x, y in poly) * GEOFENCE_FALLBACK_SLACK
    lat0, lon0 = mission.points()[0]
    far = max(math.hypot(*latlon_to_ne(a, b, lat0, lon0)) for a, b in poly)
    return (far + cfg.mission.max_start_distance_m) * GEOFENCE_FALLBACK_SLACK


# Mission.gps_min_fix → GPS_RAW_INT fix_type (GPS_FIX_TYPE_RTK_FLOAT, GPS_FIX_TYPE_RTK_FIXED)
GPS_FIX_TYPE_OF = {"rtk_float": 5, "rtk_fixed": 6}


def apply_mission_limits(
    cfg: HelixdConfig,
    mission: Mission,
    *,
    origin_latlon_deg: tuple[float, float] | None = None,
    start_ned: NedPose | None = None,
) -> HelixdConfig:
    """The config with the mission's own fence and time limit in ``safety`` and its ground in
    ``control.slip`` (pure).

    * ``time_limit_s`` replaces ``safety.mission_time_limit_s``.
    * ``gps_min_fix`` raises ``safety.gps_min_fix_type`` (RTK float 5, RTK fixed 6).
    * ``geofence_polygon`` replaces ``safety.geofence_polygon_ne_m`` and the mission's
      ``geofence_radius_m`` (None: no radius) replaces ``safety.geofence_radius_m``. While the
      polygon cannot be placed yet (see :func:`mission_fence_ne`), a radius around the start
      point that contains it fences the run instead, and the config's polygon stays.
    * without a polygon, a given ``geofence_radius_m`` replaces the config's radius.
    * ``ground`` replaces ``control.slip.ground_*_fraction``.

    Idempotent: applying it again with the origin/pose known gives the exact fence.
    """
    saf = cfg.safety
    update: dict[str, object] = {}
    if mission.time_limit_s is not None:
        update["mission_time_limit_s"] = mission.time_limit_s
    if mission.gps_min_fix is not None:
        wanted = GPS_FIX_TYPE_OF[mission.gps_min_fix]
        update["gps_min_fix_type"] = max(saf.gps_min_fix_type, wanted)
    fence = mission_fence_ne(mission, origin_latlon_deg=origin_latlon_deg, start_ned=start_ned)
    if fence is None:
        # bounded like safety.geofence_radius_m, so the run's config.yaml loads back
        radius = min(_fallback_radius_m(mission, cfg), GEOFENCE_RADIUS_MAX_M)
        if mission.geofence_radius_m is not None:
            radius = min(radius, mission.geofence_radius_m)
        update["geofence_radius_m"] = radius
    elif fence:
        update["geofence_polygon_ne_m"] = fence
        update["geofence_radius_m"] = mission.geofence_radius_m
    elif mission.geofence_radius_m is not None:
        update["geofence_radius_m"] = mission.geofence_radius_m
    limited = (
        cfg if not update else cfg.model_copy(update={"safety": saf.model_copy(update=update)})
    )
    ground = mission.ground
    if ground is None:
        return limited
    slip = cfg.control.slip.model_copy(
        update={
            "ground_roll_fraction": ground.roll_fraction,
            "ground_scroll_fraction": ground.scroll_fraction,
            "ground_yaw_fraction": ground.yaw_fraction,
        }
    )
    control = cfg.control.model_copy(update={"slip": slip})
    return limited.model_copy(update={"control": control})


def _ground_problems(mission: Mission, cfg: HelixdConfig) -> list[str]:
    """A declared ground below ``control.slip.stuck_fraction`` is a stall, not a ground."""
    if mission.ground is None:
        return []
    stuck = cfg.control.slip.stuck_fraction
    return [
        f"ground.{name} = {value:g} is below control.slip.stuck_fraction = {stuck:g}: a ground "
        f"that delivers that little is a stall, and the stall watchdog would stop the run "
        f"(allowed range {stuck:g} .. 1)"
        for name, value in mission.ground
        if value < stuck
    ]


def plan_for_check(
    mission: Mission, cfg: HelixdConfig, options: ExpandOptions = DEFAULT_OPTIONS
) -> tuple[Plan, bool]:
    """Resolve without the EKF origin; a global mission is shown relative to waypoint 1.

    Returns the plan and whether it is only provisional (global without origin)."""
    resolved, provisional = resolved_for_check(mission, cfg, options)
    return resolved.plan, provisional


def resolved_for_check(
    mission: Mission, cfg: HelixdConfig, options: ExpandOptions = DEFAULT_OPTIONS
) -> tuple[Resolved, bool]:
    """:func:`plan_for_check` with what the walk through the mission's commands found."""
    if mission.frame is MissionFrameKind.GLOBAL:
        lat, lon = mission.points()[0]
        try:
            return resolve(
                mission, cfg.control, cfg.mission, (lat, lon), options=options,
                time_limit_s=cfg.safety.mission_time_limit_s,
            ), True  # fmt: skip
        except PlanError as exc:  # the origin here is waypoint 1: say so
            said = "from waypoint 1 (check's stand-in for the EKF origin a run measures from)"
            raise PlanError(str(exc).replace("from the origin", said, 1)) from None
    return resolve(
        mission, cfg.control, cfg.mission, None, options=options,
        time_limit_s=cfg.safety.mission_time_limit_s,
    ), False  # fmt: skip


def servo_problems(mission: Mission, cfg: HelixdConfig) -> list[str]:
    """DO_SET_SERVO / DO_REPEAT_SERVO on an output that drives a scroll or on one of the
    pilot's switch channels: the latched output would fight helixd's commands or the pilot's
    switch (ArduPilot keeps a DO_SET_SERVO output latched, even after disarm)."""
    if not mission.has_commands():
        return []
    scrolls = {c.channel: i for i, c in enumerate(cfg.actuation.channels)}
    saf = cfg.safety
    pilot: dict[int, str] = {}
    if saf.takeover.switch_channel is not None:
        pilot[saf.takeover.switch_channel] = "safety.takeover.switch_channel"
    if cfg.startup.start_switch_channel is not None:
        pilot[cfg.startup.start_switch_channel] = "startup.start_switch_channel"
    for i, ch in enumerate(saf.takeover.stick_channels):
        pilot.setdefault(ch, f"safety.takeover.stick_channels.{i}")
    out: list[str] = []
    for n, wp in enumerate(mission.waypoints, start=1):
        if wp.command not in SERVO_COMMANDS:
            continue
        channel = stored_whole(wp.param(0))
        if channel in scrolls:
            k = scrolls[channel]
            out.append(
                f"item {n} {wp.name}: output {channel} drives scroll {k + 1} "
                f"(actuation.channels.{k}.channel = {channel}); a servo command there would "
                "latch it against helixd's own commands"
            )
        elif channel in pilot:
            out.append(
                f"item {n} {wp.name}: channel {channel} is the pilot's switch ({pilot[channel]}); "
                "a latched servo command there would hide the pilot's switch"
            )
    return out


class Placing(TypedDict, total=False):
    """Where a mission is judged from (:func:`judge_mission`); each may be left out."""

    start_ned: NedPose | None  # the rover's pose (None: not known yet)
    origin_latlon_deg: tuple[float, float] | None  # the EKF origin (None: not known yet)
    checked_plan: tuple[Plan, bool] | None  # :func:`plan_for_check`'s, if the caller has it
    options: ExpandOptions  # the walk through a mission's commands
    where: Where  # where the mission's places are (home, place; NOWHERE: not known)


@dataclass(frozen=True)
class Judged:
    """What :func:`judge_mission` found: the problems (one line each), and the config in force
    for the mission as far as it is placed (:attr:`cfg`)."""

    problems: list[str]
    mission: Mission
    given: HelixdConfig  # the config as loaded
    start_ned: NedPose | None = None
    origin_latlon_deg: tuple[float, float] | None = None

    @cached_property
    def cfg(self) -> HelixdConfig:
        """The config with the mission's own fence, time limit and ground in force, placed
        from the start pose and the EKF origin where they are known: the one place
        :func:`apply_mission_limits` is applied."""
        return apply_mission_limits(
            self.given,
            self.mission,
            origin_latlon_deg=self.origin_latlon_deg,
            start_ned=self.start_ned,
        )


def judge_mission(mission: Mission, cfg: HelixdConfig, **placing: Unpack[Placing]) -> Judged:
    """Everything that would make ``helixd run`` refuse or abort this mission with this
    config, and the config in force for it (:attr:`Judged.cfg`). One line per problem naming
    the field or waypoint and the allowed range."""
    start_ned = placing.get("start_ned")
    judged = Judged([], mission, cfg, start_ned, placing.get("origin_latlon_deg"))
    try:
        plan, provisional = _plan_to_judge(mission, cfg, placing)
    except PlanError as exc:
        judged.problems.append(str(exc))
        return judged
    judged.problems.extend(_placed_problems(mission, judged.cfg, plan, provisional, start_ned))
    return judged


def _plan_to_judge(mission: Mission, cfg: HelixdConfig, placing: Placing) -> tuple[Plan, bool]:
    """The plan :func:`judge_mission` judges, and whether it is only provisional."""
    origin_latlon_deg = placing.get("origin_latlon_deg")
    checked_plan = placing.get("checked_plan")
    options = placing.get("options", DEFAULT_OPTIONS)
    where = placing.get("where", NOWHERE)
    if checked_plan is not None and origin_latlon_deg is None:
        return checked_plan
    if mission.frame is MissionFrameKind.GLOBAL and origin_latlon_deg is not None:
        return resolve_plan(
            mission, cfg.control, cfg.mission, origin_latlon_deg, where, options,
            cfg.safety.mission_time_limit_s,
        ), False  # fmt: skip
    if where is not NOWHERE:
        return resolve_plan(
            mission, cfg.control, cfg.mission, None, where, options,
            cfg.safety.mission_time_limit_s,
        ), False  # fmt: skip
    return plan_for_check(mission, cfg, options)


def mission_problems(mission: Mission, cfg: HelixdConfig, **placing: Unpack[Placing]) -> list[str]:
    """:func:`judge_mission`'s problems."""
    return judge_mission(mission, cfg, **placing).problems


def _placed_problems(
    mission: Mission, cfg: HelixdConfig, plan: Plan, provisional: bool, start_ned: NedPose | None
) -> list[str]:
    """The checks of :func:`judge_mission` on the plan, with the mission's limits in ``cfg``."""
    ned = None if provisional else _ned_points(plan, start_ned, have_origin=True)
    problems = _radius_problems(plan, cfg, ned, start_ned)
    fence_name = (
        "the mission's geofence_polygon"
        if mission.geofence_polygon
        else "safety.geofence_polygon_ne_m"
    )
    problems += _polygon_problems(cfg, ned, start_ned, fence_name, plan_point_labels(plan))
    problems += _keep_out_problems(mission, cfg)
    problems += _ground_problems(mission, cfg)
    if provisional:  # before the EKF origin is known, the mission's home stands for it
        problems += _home_range_problems(mission, cfg)
        # the start distance from the file's home is only a warning (start_warnings): that
        # home is where the planner stood; preflight judges the rover's real position
    else:
        problems += _start_distance_problems(plan, cfg, start_ned, None)
    return problems


def start_warnings(mission: Mission, cfg: HelixdConfig, plan: Plan) -> list[str]:
    """Before the rover's position is known: a global mission's first waypoint farther than
    ``mission.max_start_distance_m`` from the home its file carries (a .waypoints home row, a
    .plan's planned home). That home is where the planner stood — QGroundControl puts it where
    the map was, ArduPilot's own example missions far from their first item — not where the
    rover will start, so ``check`` warns; preflight refuses from the rover's real position."""
    home = _home_ne(mission)
    if home is None:
        return []
    found = _start_distance_problems(plan, cfg, None, home)
    return [
        f"{text} — the file's home is where it was planned, not the rover: preflight "
        "checks the distance from the rover's real position"
        for text in found
    ]


def pending_checks(mission: Mission, cfg: HelixdConfig) -> list[str]:
    """What :func:`mission_problems` could not check without the pose/origin (for ``check``)."""
    later: list[str] = []
    radius = cfg.safety.geofence_radius_m
    if mission.geofence_polygon:  # the mission's fence replaces the config's at preflight
        radius = mission.geofence_radius_m
    if radius is not None and mission.frame is not MissionFrameKind.START:
        later.append("geofence radius around the start point")
    polygon = mission.geofence_polygon or cfg.safety.geofence_polygon_ne_m
    if polygon and mission.frame is not MissionFrameKind.LOCAL_NED:
        later.append("keep-in polygon")
    if mission.frame is not MissionFrameKind.START:
        later.append("time of the first leg")
        later.append("distance from the rover to waypoint 1")
    return later
