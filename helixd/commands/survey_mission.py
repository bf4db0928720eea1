"""``helixd mission survey``: the mission a survey of an area becomes.

The transects come from :func:`helixd.mission.survey.plan_survey`, exactly ``spacing_m`` apart.
What the rover needs around them comes from the config:

* the default inset keeps the rover's body inside the area: its half-width
  (:func:`helixd.planning.obstacles.rover_half_width_m`, 0.43 m for the Helix-25);
* the holes (islands, exclusion zones) travel with the mission as ``keep_out_polygons``, so
  ``check``/``run`` plan every leg around them; the transects keep the planner's clearance
  (half-width + ``planning.margin_m``, plus two grid cells) off them, so no waypoint lies in
  a keep-out's inflated border;
* the fence is the area grown by ``margin_m``; it is also where the rover must start: ``run``
  refuses a start outside the mission's ``geofence_polygon``, and the approach to the first
  transect is driven inside it (routed around the keep-outs when planning is on);
* the time limit is ``time_factor`` × (the navigator's own estimate from the first waypoint
  (:mod:`helixd.control.estimate`) + the longest approach preflight allows: a turn about and
  ``mission.max_start_distance_m`` to the first waypoint). The fence is usually tighter than
  that (the start must lie inside it); the slack covers an approach routed around the
  keep-outs and a slow start (a budget cut to the fence's corners ran out on the simulator:
  ``tests/integration/test_survey_flight.py``).

Pure: no printing; :class:`SurveyRefused` carries the one-line reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pydantic import ValidationError

from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.root import HelixdConfig
from helixd.control.estimate import TimeEstimate, estimate_time
from helixd.mission.formats.areas import SurveyArea
from helixd.mission.model import Mission
from helixd.mission.resolve import PlanError, resolve_plan
from helixd.mission.survey import SurveyError, SurveyResult, plan_survey
from helixd.planning.obstacles import clearance_m, rover_half_width_m

TIME_LIMIT_MAX_S = 86_400.0  # Mission.time_limit_s's bound
GRID_SLACK_M = 0.01  # beyond the planner's cell geometry (rounding, the flat-earth map)


class SurveyRefused(ValueError):
    """The survey cannot become a mission; ``str()`` is the reason."""


@dataclass(frozen=True)
class SurveyMission:
    mission: Mission
    result: SurveyResult
    inset_m: float  # off the outer edge
    keep_out_inset_m: float  # off the holes
    estimate: TimeEstimate  # from the first waypoint
    approach: TimeEstimate  # the longest approach preflight lets through
    time_factor: float
    time_limit_s: float


def default_insets(cfg: HelixdConfig, inset_m: float | None) -> tuple[float, float]:
    """(off the edge, off the holes): the rover's half-width unless ``inset_m`` is given; off
    the holes, when planning is on, at least what keeps a waypoint out of the planner's
    inflated cells: the clearance plus two cell diagonals (a blocked cell reaches one past
    the obstacle, the waypoint's own cell one towards it; :mod:`helixd.planning.grid`)."""
    edge = rover_half_width_m(cfg) if inset_m is None else inset_m
    if not cfg.planning.enabled:
        return edge, edge
    cells_m = 2.0 * math.sqrt(2.0) * cfg.planning.resolution_m + GRID_SLACK_M
    return edge, max(edge, clearance_m(cfg) + cells_m)


def approach_estimate(cfg: HelixdConfig, mode: MotionMode, speed_mps: float) -> TimeEstimate:
    """The longest approach preflight allows: turned about, ``mission.max_start_distance_m``
    from the first waypoint."""
    distance = cfg.mission.max_start_distance_m
    plan = Plan(
        "approach",
        mode,
        MissionFrameKind.START,
        (PlanWaypoint(distance, 0.0, cfg.control.waypoint_tolerance_m),),
        speed_mps,
    )
    return estimate_time(plan, cfg.control, (0.0, 0.0), math.pi)


def survey_mission(
    area: SurveyArea,
    cfg: HelixdConfig,
    name: str,
    mode: MotionMode,
    *,
    spacing_m: float,
    angle_deg: float,
    margin_m: float,
    inset_m: float | None,
    time_factor: float,
) -> SurveyMission:
    """The survey of ``area`` as a global mission with its fence, keep-outs and time limit."""
    edge_m, hole_m = default_insets(cfg, inset_m)
    try:
        result = plan_survey(
            area,
            spacing_m=spacing_m,
            angle_deg=angle_deg,
            margin_m=margin_m,
            inset_m=edge_m,
            keep_out_inset_m=hole_m,
        )
    except SurveyError as exc:
        raise SurveyRefused(str(exc)) from None
    if len(result.fence_latlon_deg) > 1000:
        raise SurveyRefused(
            f"{area.source}: the fence has {len(result.fence_latlon_deg)} vertices (> 1000)"
        )
    data: dict[str, object] = {
        "name": name,
        "mode": mode.value,
        "frame": "global",
        "waypoints": [{"lat": a, "lon": b} for a, b in result.waypoints_latlon_deg],
        "geofence_polygon": [list(v) for v in result.fence_latlon_deg],
        "keep_out_polygons": [[list(v) for v in poly] for poly in result.keep_outs_latlon_deg],
    }
    try:
        msn = Mission.model_validate(data, context={"limits": cfg.mission})
        plan = resolve_plan(msn, cfg.control, cfg.mission, result.waypoints_latlon_deg[0])
    except (ValidationError, PlanError) as exc:
        raise SurveyRefused(f"{area.source}: the survey is not a valid mission: {exc}") from None
    estimate = estimate_time(plan, cfg.control)  # from the first waypoint, facing the second
    approach = approach_estimate(cfg, mode, plan.speed_mps)
    limit_s = float(math.ceil(time_factor * (estimate.total_s + approach.total_s)))
    if not limit_s <= TIME_LIMIT_MAX_S:
        raise SurveyRefused(
            f"{area.source}: estimated {estimate.total_s / 3600:.1f} h (+ "
            f"{approach.total_s / 60:.0f} min approach) x {time_factor} exceeds 24 h; split "
            "the area"
        )
    msn = msn.model_copy(update={"time_limit_s": limit_s})
    return SurveyMission(msn, result, edge_m, hole_m, estimate, approach, time_factor, limit_s)


def survey_lines(
    got: SurveyMission, source: object, out: object, angle_deg: float, margin_m: float
) -> list[str]:
    """What ``mission survey`` prints about the mission it wrote."""
    r, msn = got.result, got.mission
    est, app = got.estimate, got.approach
    keep = len(msn.keep_out_polygons)
    return [
        f"survey  : {source} → {out}  area {r.area_m2:.0f} m², {r.transects} transects "
        f"{r.spacing_m:g} m apart, angle {angle_deg:g}°",
        f"inset   : {got.inset_m:.2f} m inside the edges"
        + (f", {got.keep_out_inset_m:.2f} m off {keep} keep-out areas" if keep else ""),
        f"path    : {r.path_length_m:.0f} m, {len(msn.waypoints)} waypoints, estimated "
        f"{est.total_s:.0f} s ({est.total_s / 3600:.2f} h: {est.driving_s:.0f} s driving, "
        f"{est.turning_s:.0f} s in {est.pivots} turns in place) from waypoint 1",
        f"limit   : time limit {got.time_limit_s:.0f} s = {got.time_factor:g} x ("
        f"{est.total_s:.0f} s + {app.total_s:.0f} s for an approach of up to "
        "mission.max_start_distance_m), rounded up",
        f"fence   : the polygon grown by {margin_m:g} m ({len(msn.geofence_polygon)} vertices)"
        + (f"; {keep} keep-out areas (the holes) travel with the mission" if keep else ""),
        f"start   : the rover must start inside the fence (at most {margin_m:g} m outside the "
        "area; run refuses a start outside it): drive it there, or grow --margin-m",
    ]


__all__ = [
    "SurveyMission",
    "SurveyRefused",
    "approach_estimate",
    "default_insets",
    "survey_lines",
    "survey_mission",
]
