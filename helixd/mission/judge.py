"""A mission judged against the config, whole: what :mod:`helixd.mission.validate` finds, and
how long it takes against its time limit on the navigator's own speed profile
(:func:`helixd.control.estimate.estimate_time`, on the plan as it will be flown).

:func:`mission_vs_config` is every check that needs no vehicle (the plan resolved for the
check, servo outputs, the time), so ``check``, ``run``, ``serve`` and the daemon's preflight
refuse the same missions; :func:`flight_problems` is
:func:`helixd.mission.validate.mission_problems` plus the time check. The mission loader
itself (:mod:`helixd.mission.validate` and below) loads nothing of the controller; this module
is the one of the mission layer that does.

* ``start`` missions are estimated from the start point, facing +x;
* ``local_ned``/``global`` missions from the pose at preflight; before it (``check``) from
  waypoint 1 — the first leg is unknown, which only shortens the estimate — or, for a route
  planned around obstacles, from ``planning.start_ne_m`` where its first leg was planned from.

Pure: no I/O, no clocks. The last estimate is remembered (one entry, by equal plan, controller
and start): ``check`` times the mission it validates and then reports it, and a 100 000-waypoint
plan costs a second and a half per estimate on this machine.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Unpack

from helixd.base.frames import NedPose
from helixd.base.plan import MissionFrameKind, Plan
from helixd.config.control import ControlConfig
from helixd.config.root import HelixdConfig
from helixd.control.estimate import TimeEstimate, estimate_time
from helixd.files.yamlio import paused_gc
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.model import Mission
from helixd.mission.resolve import NOWHERE, PlanError, resolve_plan
from helixd.mission.validate import (
    Judged,
    Placing,
    judge_mission,
    plan_for_check,
    resolved_for_check,
    servo_problems,
    start_warnings,
)

_EstimateKey = tuple[Plan, ControlConfig, tuple[float, float] | None, float | None]
_last_estimate: list[tuple[_EstimateKey, TimeEstimate]] = []  # at most one entry


def _estimate(
    plan: Plan,
    control: ControlConfig,
    start_xy_m: tuple[float, float] | None,
    start_yaw_rad: float | None = None,
) -> TimeEstimate:
    """:func:`estimate_time`, answered from the last call when it had equal inputs (equal, not
    the same objects: each caller resolves its own plan)."""
    key: _EstimateKey = (plan, control, start_xy_m, start_yaw_rad)
    if _last_estimate and _last_estimate[0][0] == key:
        return _last_estimate[0][1]
    estimate = estimate_time(plan, control, start_xy_m, start_yaw_rad)
    _last_estimate[:] = [(key, estimate)]
    return estimate


def plan_time_estimate(
    plan: Plan,
    cfg: HelixdConfig,
    start_ned: NedPose | None = None,
    start_xy_m: tuple[float, float] | None = None,
) -> TimeEstimate:
    """The navigator's time for ``plan``: a ``start`` mission from its origin facing +x; an
    ENU mission from ``start_ned`` (the pose at preflight), else from ``start_xy_m`` (mission
    frame, facing the first leg), else from its first waypoint."""
    if plan.frame is MissionFrameKind.START:
        return _estimate(plan, cfg.control, (0.0, 0.0), 0.0)
    if start_ned is not None:
        yaw = math.pi / 2 - start_ned.yaw_ned_rad  # compass → counter-clockwise from East
        return _estimate(plan, cfg.control, (start_ned.east_m, start_ned.north_m), yaw)
    return _estimate(plan, cfg.control, start_xy_m)


def time_problems(estimate: TimeEstimate, limit_s: float, note: str = "") -> list[str]:
    """The refusal when the estimate does not fit the mission time limit (else nothing)."""
    eta = estimate.total_s
    if math.isfinite(eta) and eta <= limit_s:
        return []
    return [
        f"estimated time{note} {eta:.0f} s ({estimate.path_length_m:.1f} m with acceleration, "
        f"braking and {estimate.pivots} turns in place) exceeds safety.mission_time_limit_s = "
        f"{limit_s:.0f} s; the run would be aborted (split the mission or raise the limit)"
    ]


def _done_s(plan: Plan, estimate: TimeEstimate, steps: int) -> float:
    """When the program's first ``steps`` steps are done: the last waypoint they drive to
    reached, and their holds waited (s)."""
    program = plan.program
    assert program is not None
    done = program.steps[:steps]
    last = [s.last_waypoint for s in done if s.last_waypoint is not None]
    arrived = estimate.arrivals_s[last[-1]] if last and estimate.arrivals_s else 0.0
    return arrived + sum(s.hold_s for s in done)


def patrol_times_s(plan: Plan, estimate: TimeEstimate) -> tuple[float, float] | None:
    """A patrol (a DO_JUMP repeated forever): when its first lap ends and how long one lap
    takes (s, from the estimate); None: not a patrol."""
    program = plan.program
    lap = None if program is None else program.first_lap()
    if lap is None:
        return None
    start, end = lap
    first_end = _done_s(plan, estimate, end)
    starts = program.lap_starts if program is not None else ()
    if len(starts) >= 2:  # lap 2 whole: from the end of lap 1 to the end of lap 2
        return first_end, _done_s(plan, estimate, starts[1]) - first_end
    return first_end, first_end - _done_s(plan, estimate, start)


def patrol_time_problems(first_lap_end_s: float, limit_s: float, note: str = "") -> list[str]:
    """A patrol is ended by its time limit, so only its first lap has to fit in it."""
    if math.isfinite(first_lap_end_s) and first_lap_end_s <= limit_s:
        return []
    return [
        f"a patrol (DO_JUMP repeated forever) whose first lap ends at an estimated "
        f"{first_lap_end_s:.0f} s{note}, beyond safety.mission_time_limit_s = {limit_s:.0f} s: "
        "not one lap would be flown (shorten the loop or raise the limit)"
    ]


def limit_problems(plan: Plan, estimate: TimeEstimate, limit_s: float, note: str = "") -> list[str]:
    """The time check of ``plan``: the whole flight within the limit; a patrol, flown until
    stopped and ended by the limit, its first lap."""
    patrol = patrol_times_s(plan, estimate)
    if patrol is not None:
        return patrol_time_problems(patrol[0], limit_s, note)
    return time_problems(estimate, limit_s, note)


def judge_flight(mission: Mission, cfg: HelixdConfig, **placing: Unpack[Placing]) -> Judged:
    """:func:`helixd.mission.validate.judge_mission`, and the estimated time against the
    time limit in force (the mission's own, else the config's)."""
    judged = judge_mission(mission, cfg, **placing)
    start_ned = placing.get("start_ned")
    origin_latlon_deg = placing.get("origin_latlon_deg")
    checked_plan = placing.get("checked_plan")
    try:
        if checked_plan is not None and origin_latlon_deg is None:
            plan = checked_plan[0]
        elif mission.frame is MissionFrameKind.GLOBAL and origin_latlon_deg is not None:
            plan = resolve_plan(
                mission, cfg.control, cfg.mission, origin_latlon_deg,
                placing.get("where", NOWHERE), placing.get("options", DEFAULT_OPTIONS),
                cfg.safety.mission_time_limit_s,
            )  # fmt: skip
        else:
            plan = plan_for_check(mission, cfg)[0]
    except PlanError:
        return judged  # judge_mission said so
    limited = judged.cfg  # its time limit, and its ground
    limit_s = limited.safety.mission_time_limit_s
    ned = None if plan.frame is MissionFrameKind.START else start_ned
    note = "" if plan.frame is MissionFrameKind.START or ned is not None else " from waypoint 1"
    estimate = plan_time_estimate(plan, limited, ned)
    judged.problems.extend(limit_problems(plan, estimate, limit_s, note))
    return judged


def flight_problems(mission: Mission, cfg: HelixdConfig, **placing: Unpack[Placing]) -> list[str]:
    """:func:`judge_flight`'s problems."""
    return judge_flight(mission, cfg, **placing).problems


class MissionChecked(NamedTuple):
    """:func:`mission_vs_config`'s plan, whether it is provisional, and the config in force."""

    plan: Plan
    provisional: bool  # a global plan shown relative to waypoint 0 (EKF origin not known)
    cfg: HelixdConfig  # with the mission's own limits applied


def mission_vs_config(
    cfg: HelixdConfig,
    msn: Mission,
    label: str,
    problems: list[str],
    options: ExpandOptions = DEFAULT_OPTIONS,
    notes: list[str] | None = None,
) -> MissionChecked | None:
    """The plan as :func:`plan_for_check` resolves it and the config in force for the mission
    (its own limits applied), after the mission-vs-config checks (what can be checked without
    the vehicle); problems are appended, prefixed by ``label``, and what the walk through the
    mission's commands noted (skipped items, …) to ``notes``."""
    try:
        with paused_gc():  # large acyclic plan: see yamlio.paused_gc
            resolved, provisional = resolved_for_check(msn, cfg, options)
    except PlanError as exc:
        problems.append(f"{label}: {exc}")
        return None
    checked = (resolved.plan, provisional)
    problems.extend(f"{label}: {p}" for p in (*resolved.problems, *servo_problems(msn, cfg)))
    if notes is not None:
        notes.extend(f"note: {n}" for n in resolved.notes)
    judged = judge_flight(msn, cfg, checked_plan=checked, options=options)
    problems.extend(f"{label}: {p}" for p in judged.problems)
    if notes is not None and provisional:
        notes.extend(f"warning: {label}: {w}" for w in start_warnings(msn, cfg, resolved.plan))
    return MissionChecked(resolved.plan, provisional, judged.cfg)


__all__ = [
    "MissionChecked",
    "flight_problems",
    "judge_flight",
    "limit_problems",
    "mission_vs_config",
    "patrol_time_problems",
    "patrol_times_s",
    "plan_time_estimate",
    "time_problems",
]
