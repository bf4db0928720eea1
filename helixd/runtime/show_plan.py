"""``helixd run --show-plan``: upload helixd's resolved plan as the autopilot's mission, so a
ground station (QGC, Mission Planner) draws the path helixd is about to fly.

Why this never makes ArduPilot fly it: ArduPilot Rover executes its stored mission only in AUTO
mode (``ModeAuto::_enter`` starts or resumes the mission; no other mode reads it), and the
only ways into AUTO are a mode change (SET_MODE / MAV_CMD_DO_SET_MODE, the RC mode switch) or
MAV_CMD_MISSION_START, which Rover answers by switching to AUTO. helixd sends neither: it
drives in MANUAL by RC override and ends every run in HOLD. The upload happens before arming;
if the autopilot is in AUTO at that moment (where a new mission is followed at once, as
``helixd mission upload`` warns) nothing is uploaded. Only the mission list is replaced; the
autopilot's fence is left as it is. A pilot who deliberately switches to AUTO gets the very
path helixd would fly (NAV_WAYPOINT items only).

The plan goes up as ``MAV_FRAME_GLOBAL_RELATIVE_ALT`` NAV_WAYPOINTs (seq 0 = home, here the
rover's pose at preflight): mission-frame points → NED through the run's mission frame → lat/lon
through the EKF origin (ArduPilot's own flat-earth map, :func:`helixd.base.frames.ne_to_latlon`),
so QGC draws them where LOCAL_POSITION_NED puts the rover.
"""

from __future__ import annotations

import structlog

from helixd.base.frames import MissionFrame, NedPose, ne_to_latlon
from helixd.base.plan import MissionFrameKind, Plan
from helixd.link.connection import Autopilot
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.mav.url import LinkError
from helixd.mission.formats.items import FormatError, GcsMission, waypoint_item
from helixd.mission.formats.wire import gcs_to_wire

__all__ = ["plan_as_gcs", "show_plan"]

log = structlog.get_logger(__name__)

AUTO_MODE = "AUTO"


def plan_as_gcs(
    plan: Plan, start_ned: NedPose, origin_latlon_deg: tuple[float, float]
) -> GcsMission:
    """The plan's waypoints in lat/lon as the run flies them (pure). Raises ValueError on a
    non-finite point or an origin that is not a place."""
    frame = (
        MissionFrame.start_at(start_ned)
        if plan.frame is MissionFrameKind.START
        else MissionFrame.enu()
    )
    items = []
    for i, wp in enumerate(plan.waypoints):
        north_m, east_m = frame.to_ned(wp.x_m, wp.y_m)
        lat, lon = ne_to_latlon(north_m, east_m, *origin_latlon_deg)
        items.append(waypoint_item(i + 1, lat, lon))
    home = ne_to_latlon(start_ned.north_m, start_ned.east_m, *origin_latlon_deg)
    return GcsMission(items=tuple(items), home_latlon_deg=home)


async def show_plan(
    ap: Autopilot,
    plan: Plan,
    start_ned: NedPose,
    origin_latlon_deg: tuple[float, float] | None,
    timeout_s: float,
) -> str | None:
    """Upload the plan for the ground station to draw; None when done, else a warning line
    (never raises but CancelledError: showing the plan is a convenience, not a condition)."""
    if ap.state.mode == AUTO_MODE:
        return "--show-plan: the autopilot is in AUTO (it would follow a new mission): not uploaded"
    try:
        origin = origin_latlon_deg or await ap.action.request_gps_origin(timeout_s)
        if origin is None:
            return "--show-plan: the autopilot sent no GPS_GLOBAL_ORIGIN: plan not uploaded"
        wire = gcs_to_wire(plan_as_gcs(plan, start_ned, origin))
        await ap.mission.upload(wire.mission, None)
    except (MissionTransferError, LinkError, TimeoutError, FormatError, ValueError) as exc:
        log.warning("show_plan_failed", error=str(exc))
        return f"--show-plan: plan not uploaded: {exc}"
    log.info("show_plan_uploaded", waypoints=len(plan.waypoints))
    return None
