"""The mission placed where the rover is, at preflight and again at arming: the autopilot's home,
the mission frame from the start pose, the plan resolved from the EKF origin (a resume re-enters
its leg; the media followed), the checks ``helixd check`` ran now with the pose and the
origin, the route against the autopilot's own fence, and the plan shown to the GCS. Each
returns what it found or raises :class:`helixd.runtime.setup.PreflightFailed` (a pose moved
out of the fence after arming: :class:`helixd.runtime.setup.StartRefused`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import structlog

from helixd.base.clock import now_s
from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne
from helixd.base.plan import MissionFrameKind, Numbering, Plan, program_numbering
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.vehicle import HomePosition
from helixd.mav.constants import MAV_CMD_NAV_RETURN_TO_LAUNCH
from helixd.mission.expand import ExpandOptions
from helixd.mission.judge import judge_flight
from helixd.mission.model import Mission
from helixd.mission.resolve import Where, resolve
from helixd.mission.resume import RunInputs, with_leg_start
from helixd.prepare.media import MediaRefused, media_path, placed_media_plan
from helixd.prepare.planned import Replanner
from helixd.runtime.autopilot_fence import autopilot_fence_check
from helixd.runtime.setup import (
    Checked,
    PreflightFailed,
    StartRefused,
    Vehicle,
    pose_invalid_too_long,
    until_stopped,
)
from helixd.runtime.show_plan import show_plan
from helixd.runtime.signals import StopRequest
from helixd.safety.watchdogs import Fault, FaultCause

log = structlog.get_logger(__name__)


async def autopilot_home(
    ap: Autopilot,
    cfg: HelixdConfig,
    mission: Mission,
    origin: tuple[float, float] | None,
    stop: StopRequest,
) -> HomePosition | None:
    """The autopilot's home, for a mission with commands (NAV_RETURN_TO_LAUNCH)."""
    if not mission.has_commands():
        return None
    home = await until_stopped(stop, ap.action.request_home(cfg.link.command_timeout_s * 3))
    if home is not None:
        log.info(
            "home_position",
            lat_deg=round(home.lat_deg, 7),
            lon_deg=round(home.lon_deg, 7),
            north_m=None if home.north_m is None else round(home.north_m, 2),
            east_m=None if home.east_m is None else round(home.east_m, 2),
        )
        if home.north_m is None and origin is not None:  # sent without north/east
            n, e = latlon_to_ne(home.lat_deg, home.lon_deg, *origin)
            home = HomePosition(home.lat_deg, home.lon_deg, n, e)
    return home


def mission_frame(mission: Mission, start: NedPose) -> MissionFrame:
    """The frame the plan is flown in: a ``start`` mission's starts at the rover."""
    if mission.frame is MissionFrameKind.START:
        return MissionFrame.start_at(start)
    return MissionFrame.enu()


def resolve_flight(
    mission: Mission,
    cfg: HelixdConfig,
    origin: tuple[float, float] | None,
    start: NedPose,
    home: HomePosition | None,
    options: ExpandOptions,
    inputs: RunInputs | None = None,
) -> tuple[Plan, Where]:
    """The plan, and for a mission with commands its program from where the rover is
    (``start``) and the autopilot's home; what the program cannot fly is refused."""
    frame = mission_frame(mission, start)
    where = Where()
    if mission.has_commands():
        here = frame.to_mission(start)
        home_xy = None
        if home is not None and home.north_m is not None and home.east_m is not None:
            at = frame.to_mission(NedPose(home.north_m, home.east_m, 0.0))
            home_xy = (at.x_m, at.y_m)
        where = Where(start_xy_m=(here.x_m, here.y_m), home_xy_m=home_xy)
    resolved = resolve(
        mission, cfg.control, cfg.mission, origin, where, options,
        cfg.safety.mission_time_limit_s,
    )  # fmt: skip
    if resolved.problems:
        raise PreflightFailed(list(resolved.problems))
    program = resolved.plan.program
    returns = program is not None and any(
        s.command == MAV_CMD_NAV_RETURN_TO_LAUNCH for s in program.steps
    )
    if returns and where.home_xy_m is None:
        raise PreflightFailed(
            [
                "the mission returns home (NAV_RETURN_TO_LAUNCH) but the autopilot sent no "
                "home position (HOME_POSITION): wait for its GPS home and try again"
            ]
        )
    for note in resolved.notes:
        log.info("mission_note", note=note)
    return follow_medium(resolved.plan, mission, cfg, origin, start, inputs), where


def follow_medium(
    plan: Plan, mission: Mission, cfg: HelixdConfig, origin: tuple[float, float] | None,
    start: NedPose, inputs: RunInputs | None = None,
) -> Plan:  # fmt: skip
    """``plan`` with each stretch in its medium's mode when the flight has a media map
    (``inputs``: a resume's, to number the changes of mode as the whole mission)."""
    try:
        got = placed_media_plan(cfg, mission, plan, origin, start)
    except MediaRefused as exc:
        raise PreflightFailed(exc.problems) from None
    if got is None:
        return plan
    flown = got.plan
    vias = [w.via for w in flown.waypoints]
    numbering = program_numbering(flown) if flown.program is not None else None
    if numbering is None:
        numbering = Numbering.of(vias) if inputs is None else inputs.numbering(vias)
    for t in got.transitions:
        wp = flown.waypoints[t.index]
        log.info(
            "media_transition",
            # numbered as the operator numbers waypoints ("via → 2/9" at an inserted stop)
            waypoint=numbering.label(t.index), stop="media" if wp.media_stop else "waypoint",
            before=t.before.value, after=t.after.value,
            x_m=round(t.xy_m[0], 2), y_m=round(t.xy_m[1], 2), medium=t.medium.value,
        )  # fmt: skip
    where = media_path(cfg, mission)
    log.info(
        "media_plan", stretches=len(got.stretches), transitions=len(got.transitions),
        # what `helixd plot` draws the map's areas from, placed as the flight placed them
        media_map=None if where is None else str(where.resolve()), frame=plan.frame.value,
        start_north_m=round(start.north_m, 3), start_east_m=round(start.east_m, 3),
        start_yaw_ned_rad=round(start.yaw_ned_rad, 4),
    )  # fmt: skip
    return got.plan


async def checked_from_rover(
    ap: Autopilot,
    cfg: HelixdConfig,
    mission: Mission,
    vehicle: Vehicle,
    stop: StopRequest,
    *,
    replan_from: Replanner | None = None,
    inputs: RunInputs | None = None,
    options: ExpandOptions,
) -> Checked:
    """The mission placed from the rover's pose and the EKF origin: its first leg re-planned
    from the rover (a route planned around obstacles), its plan (from the autopilot's home
    for a mission with commands; a resume re-enters the interrupted leg), and the checks
    ``helixd check`` ran, now with the start pose and the EKF origin (geofence radius and
    polygon, distance to the first waypoint, time)."""
    pose, origin = vehicle.pose, vehicle.origin
    if replan_from is not None:  # planned legs: the first from the rover
        try:
            mission = replan_from((pose.north_m, pose.east_m), origin)
        except ValueError as exc:
            raise PreflightFailed(str(exc).splitlines()) from None
    home = await autopilot_home(ap, cfg, mission, origin, stop)
    plan, where = resolve_flight(mission, cfg, origin, pose, home, options, inputs)
    if inputs is not None:  # a resume re-enters the interrupted leg
        plan = with_leg_start(plan, mission, inputs.leg_start, cfg.control, cfg.mission, origin)
    judged = judge_flight(
        mission, cfg, start_ned=pose, origin_latlon_deg=origin, options=options, where=where
    )
    if judged.problems:
        raise PreflightFailed(judged.problems)
    return Checked(pose, origin, plan, mission, judged.cfg, home)


async def show_checked_plan(
    ap: Autopilot, cfg: HelixdConfig, checked: Checked, stop: StopRequest
) -> str | None:
    """Upload the resolved plan for the GCS to draw (never flown: helixd.runtime.show_plan);
    a warning when it could not."""
    timeout_s = cfg.link.command_timeout_s * 3
    return await until_stopped(
        stop, show_plan(ap, checked.plan, checked.start_ned, checked.origin, timeout_s)
    )


def start_pose(
    checked: Checked,
    now: NedPose | None,
    ap: Autopilot,
    cfg: HelixdConfig,
    options: ExpandOptions,
) -> Checked:
    """The mission frame starts where the rover is now, after the pilot's start switch: the
    flight checked again from there (its start pose and the config in force from it); never
    from an invalid pose: armed with pose telemetry rejected is a fault
    (:class:`StartRefused`)."""
    invalid = pose_invalid_too_long(ap, cfg)
    if now is None and invalid is not None:
        raise StartRefused(invalid, now_s())
    if now is not None and now != checked.start_ned:
        # The rover may have been moved while the start gate waited: check again from here.
        moved = judge_flight(
            checked.mission,
            cfg,
            start_ned=now,
            origin_latlon_deg=checked.origin,
            options=options,
        )
        if moved.problems:
            why = "from the pose at arming: " + "; ".join(moved.problems)
            raise StartRefused(Fault(FaultCause.PREFLIGHT, why), now_s())
        return replace(checked, start_ned=now, cfg=moved.cfg)
    return checked


async def judge_autopilot_fence(
    ap: Autopilot, checked: Checked, warn: Callable[[str | None], None]
) -> None:
    """The route from the rover through every waypoint against the autopilot's own fence
    (:mod:`helixd.runtime.autopilot_fence`): a route it would stop is refused (exit 3)."""
    frame = mission_frame(checked.mission, checked.start_ned)
    start = checked.start_ned
    points = [(start.north_m, start.east_m)]
    labels = ["the start"]
    n = 0
    for w in checked.plan.waypoints:
        points.append(frame.to_ned(w.x_m, w.y_m))
        if w.via:
            labels.append(f"the via point → {n + 1}")
        else:
            n += 1
            labels.append(f"waypoint {n}")
    problems, warnings = await autopilot_fence_check(ap, checked.origin, points, labels)
    for warning in warnings:
        warn(warning)
    if problems:
        raise PreflightFailed(problems)
