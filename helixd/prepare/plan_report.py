"""What ``helixd check`` prints about a checked mission: the plan (the operator's waypoints
numbered from 1 as a ground station numbers mission items, the planner's via points marked
as such), the path as it will be flown (planned detours included), the time estimate from
the navigator's own speed profile (:mod:`helixd.control.estimate`) and its margin to the
mission time limit, the limits and the checks left for preflight.

Pure: lines of text out; the CLI prints them.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from helixd.base.media import MediaMap, Medium
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, waypoint_label
from helixd.config.root import HelixdConfig
from helixd.control.estimate import TimeEstimate, delivered_fractions
from helixd.mission.describe import DEFAULT_WIDTH, program_lines
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.judge import patrol_times_s, plan_time_estimate
from helixd.mission.model import Mission
from helixd.mission.resolve import places_from
from helixd.mission.validate import pending_checks, plan_for_check
from helixd.planning.media_modes import MediaPlan, ModePolicy, medium_under_mode_m, pinned_misfits
from helixd.planning.route import RoutePlan
from helixd.prepare.media import MediaCheck, check_media_plan, media_path, mode_policy
from helixd.prepare.planned import route_lines, route_time_estimate
from helixd.recorder.retention import DiskUsage, low_space

MAX_TABLE_ROWS = 200  # `check` lists at most this many waypoints (first and last ones)


def waypoint_table(plan: Plan) -> list[str]:
    """One row per waypoint: the operator's numbered 1…N, via points as ``via → N``."""
    modes = not plan.single_mode  # the mode follows the medium: each leg's mode
    rows = [f"{'#':>7} {'x_m':>9} {'y_m':>9} {'tol_m':>6} {'heading_deg':>11}"]
    rows[0] += "  mode" if modes else ""
    count = len(plan.waypoints)
    head = count if count <= MAX_TABLE_ROWS else MAX_TABLE_ROWS // 2
    for i, (wp, number) in enumerate(zip(plan.waypoints, plan.numbers(), strict=True)):
        if head <= i < count - (MAX_TABLE_ROWS - head):
            if i == head:
                rows.append(f"... {count - MAX_TABLE_ROWS} waypoints not shown ...")
            continue
        hdg = "-" if wp.final_yaw_rad is None else f"{math.degrees(wp.final_yaw_rad):.1f}"
        label = waypoint_label(number, wp.via)
        row = f"{label:>7} {wp.x_m:>9.2f} {wp.y_m:>9.2f} {wp.tolerance_m:>6.2f} {hdg:>11}"
        if modes:
            row += f"  {plan.mode_at(i).value}{' (stop)' if wp.stop else ''}"
        rows.append(row)
    return rows


def estimate_line(
    estimate: TimeEstimate,
    cfg: HelixdConfig,
    msn: Mission,
    note: str,
    patrol: tuple[float, float] | None = None,
) -> str:
    """The estimate, what it is made of, and its margin to the time limit in force; a patrol
    (``patrol``: its first lap's end and one lap, s) is flown until stopped, so its lap and
    the limit that ends it."""
    eta = estimate.total_s
    limit = cfg.safety.mission_time_limit_s
    source = (
        "the mission's time_limit_s"
        if msn.time_limit_s is not None
        else "safety.mission_time_limit_s"
    )
    if patrol is not None:
        first_s, lap_s = patrol
        head = (
            f"estimate: a patrol, flown until stopped: first lap done at {first_s:.0f} s"
            f"{note}, then {lap_s:.0f} s a lap; "
        )
        if eta < limit:  # fewer laps planned than the limit would fly
            return head + (
                f"its planned laps end at {eta:.0f} s, then it holds where it is until stopped "
                f"or limit {source} = {limit:.0f} s ends it (fault mission_time, exit 4)"
            )
        laps = f"about {1 + (limit - first_s) / lap_s:.0f} laps" if lap_s > 0 else "its laps"
        return head + (
            f"limit {source} = {limit:.0f} s ends it after {laps} (fault mission_time, exit 4) "
            "unless it is stopped before"
        )
    parts = f"{estimate.driving_s:.0f} s driving"
    if estimate.pivots:
        parts += f", {estimate.turning_s:.0f} s in {estimate.pivots} turns in place"
    if not math.isfinite(eta):
        return f"estimate: never arrives{note}; limit {source} = {limit:.0f} s"
    margin = limit - eta
    ratio = f"{limit / eta:.1f}× the estimate" if eta > 0 else "no time needed"
    return (
        f"estimate: {eta:.0f} s{note} ({eta / 60:.1f} min: {parts}); limit {source} = "
        f"{limit:.0f} s, margin {margin:.0f} s ({ratio})"
    )


def ground_line(cfg: HelixdConfig, msn: Mission, mode: MotionMode) -> str:
    """The ground the estimate counts (the mission's, else the config's) and what of the
    command it delivers in ``mode`` with the slip feed-forward."""
    slip = cfg.control.slip
    source = "the mission's ground" if msn.ground is not None else "control.slip.ground_*"
    fractions = (slip.ground_roll_fraction, slip.ground_scroll_fraction, slip.ground_yaw_fraction)
    if all(f >= 1.0 for f in fractions):
        return (
            f"ground  : no slip assumed ({source} = 1); where the ground slips the flight takes "
            f"longer: an axis that gets a fraction f of its command, 1 / min(1, f × "
            f"{slip.max_gain:g}) times"
        )
    move, turn = delivered_fractions(mode, slip)
    return (
        f"ground  : {source}: roll {fractions[0]:.2f}, scroll {fractions[1]:.2f}, yaw "
        f"{fractions[2]:.2f} of the command; with the slip feed-forward (at most "
        f"{slip.max_gain:g}×) {mode.value} drives at {move:.2f} and turns at {turn:.2f} of the "
        "navigator's command, counted in the estimate"
    )


def dig_in_warning(mode: MotionMode, pivots: int, sand_m: float | None = None) -> str | None:
    """SCROLL turns in place at its corners; in dry sand that digs the scrolls in (thesis Field
    Test 1). Without a media map ``check`` cannot see the ground, so it says so whenever a
    SCROLL mission pivots; with one (``sand_m``: metres of sand scrolled over) only where the
    map has sand under a scroll stretch."""
    if sand_m is not None:
        if sand_m <= 0.0 or pivots == 0:
            return None
        return (
            f"warning : the map has sand under {sand_m:.1f} m of scroll stretches: turning in "
            "place in scroll there digs the scrolls in and the rover cannot turn (Field Test "
            "1; the run stops with fault stall, exit 4) — give those legs shallow corners"
        )
    if mode is not MotionMode.SCROLL or pivots == 0:
        return None
    return (
        f"warning : scroll turns in place {pivots}× (its corners and headings): on sand, "
        "turning in place in scroll digs the scrolls in and the rover cannot turn (Field Test "
        "1; the run stops with fault stall, exit 4) — on sand, give its legs shallow corners "
        "or fly it in roll"
    )


def _straight_note(cfg: HelixdConfig, msn: Mission) -> str:
    """A planned route's detours, against the straight legs from the same start."""
    original, _ = plan_for_check(msn, cfg)
    first = original.waypoints[0]
    start_xy = (first.x_m, first.y_m)
    if msn.frame is MissionFrameKind.LOCAL_NED:
        start_xy = (cfg.planning.start_ne_m[1], cfg.planning.start_ne_m[0])
    return f", planned around obstacles (straight legs {original.path_length_m(start_xy):.1f} m)"


def _speeds(plan: Plan) -> str:
    """The speeds flown: the plan's, or each step's of a program (and its holds)."""
    if plan.program is None:
        return f"{plan.speed_mps:.2f} m/s"
    steps = plan.program.steps
    flown = sorted({s.speed_mps for s in steps if s.first_waypoint is not None})
    speeds = f"{', '.join(f'{v:.2f}' for v in flown) or f'{plan.speed_mps:.2f}'} m/s"
    return speeds + f", {plan.waits_s():.0f} s of holds"


def _own_limit_lines(msn: Mission) -> list[str]:
    """The limits the mission brings itself, and the start its geofence polygon asks for."""
    own = [
        *(
            [f"geofence polygon ({len(msn.geofence_polygon)} vertices)"]
            if msn.geofence_polygon
            else []
        ),
        *([f"geofence radius {msn.geofence_radius_m} m"] if msn.geofence_radius_m else []),
        *([f"time limit {msn.time_limit_s:.0f} s"] if msn.time_limit_s is not None else []),
    ]
    lines = [f"limits  : the mission's own {', '.join(own)} replace the config's"] if own else []
    if msn.geofence_polygon:
        lines.append(
            "warning : the rover must start inside the mission's geofence_polygon: run refuses "
            "a start outside it (a survey's fence is its area grown by --margin-m)"
        )
    return lines


def check_lines(
    cfg: HelixdConfig,
    msn: Mission,
    path: Path,
    config_label: str,
    planned: Mission,
    route: RoutePlan | None,
    options: ExpandOptions = DEFAULT_OPTIONS,
    width: int = DEFAULT_WIDTH,
    media: MediaMap | None = None,
) -> list[str]:
    """Everything ``check`` prints after the inputs passed (``planned``: the mission with the
    planner's via points, ``msn`` itself when nothing was planned). A mission with commands
    shows its flight (each step, its actions and when it ends) instead of the waypoint table,
    its texts wrapped to ``width`` columns."""
    plan, provisional = plan_for_check(planned, cfg, options)
    followed = check_media_plan(cfg, msn, plan, media) if media is not None else None
    if followed is not None and followed.media is not None:
        plan = followed.media.plan
    note = (
        " (global: places from waypoint 1, as `run` gives them; it flies through the EKF origin)"
        if provisional
        else ""
    )
    vias = len(plan.waypoints) - plan.operator_count
    numbered = (
        "mission items numbered as the ground station shows them (home 0, the first item 1)"
        if plan.program is not None
        else "waypoints numbered from 1"
    )
    lines = [
        f"config  : {config_label}  OK",
        f"mission : {path}  OK",
        f"plan    : {plan.name}  mode={modes_text(plan)}  frame={plan.frame.value}{note}",
        f"axes    : {places_from(plan.frame)} (metres); {numbered}"
        + (f", {vias} via points inserted by the planner" if vias else ""),
    ]
    if plan.program is not None:
        start = plan.assumed_start_xy_m()
        lines.extend(program_lines(plan, cfg.control.max_yaw_rate_radps, start, width))
    else:
        lines.extend(waypoint_table(plan))
    estimate, start_note = route_time_estimate(cfg, planned, route, path)
    if followed is not None:
        lines.extend(_media_lines(cfg, msn, followed, shown_path(media_path(cfg, msn))))
        if followed.media is not None:  # the stretches' modes and the turns between them
            estimate = plan_time_estimate(plan, cfg, start_xy_m=plan.assumed_start_xy_m())
    straight = _straight_note(cfg, msn) if route is not None else ""
    laps = " (the patrol's planned laps)" if plan.program and plan.program.patrol_item else ""
    lines.append(
        f"path    : {estimate.path_length_m:.1f} m{start_note}{straight}{laps} at {_speeds(plan)}"
    )
    patrol = patrol_times_s(plan, estimate)
    lines.append(estimate_line(estimate, cfg, msn, start_note, patrol))
    lines.append(ground_line(cfg, msn, plan.mode))
    mapped = followed.media if followed is not None else None
    sand_m = None if mapped is None else medium_under_mode_m(mapped, Medium.SAND, MotionMode.SCROLL)
    dig = dig_in_warning(plan.mode, estimate.pivots, sand_m)
    if dig is not None:
        lines.append(dig)
    lines.extend(_own_limit_lines(msn))
    later = pending_checks(msn, cfg)
    if later:
        lines.append(f"preflight: run checks with the start pose: {', '.join(later)}")
    if route is not None:
        lines.extend(route_lines(route, planned))
    return lines


def _media_lines(cfg: HelixdConfig, msn: Mission, followed: MediaCheck, source: str) -> list[str]:
    """The media map, each stretch and each change of mode (or why not before preflight)."""
    lines = [f"media   : {source}  OK"]
    if followed.media is None:
        return [*lines, f"media   : stretches at preflight ({followed.why})"]
    got = followed.media
    lines.extend(stretch_lines(got))
    turns = sum(t.turn_rad > 0.0 for t in got.transitions)
    lines.append(
        f"modes   : {len(got.stretches)} stretches, {len(got.transitions)} changes of mode "
        f"({turns} turns in place on the firm side, {cfg.media.transition_margin_m:g} m from "
        "the boundary); the estimate counts them"
    )
    lines.extend(pinned_warnings(got, mode_policy(cfg, msn)))
    return lines


def record_space_warning(
    cfg: HelixdConfig,
    planned: Mission,
    route: RoutePlan | None,
    path: Path,
    disk_usage: DiskUsage | None = None,
) -> str | None:
    """What ``run`` would warn in preflight when ``recorder.run_root`` has less free space than
    this flight's record (by the same estimate ``check`` prints); None when enough."""
    estimate, _ = route_time_estimate(cfg, planned, route, path)
    root = cfg.recorder.run_root
    check = low_space(root, estimate.total_s, disk_usage)
    return None if check is None else f"{check.text(root)} (recorder.run_root)"


def stretch_lines(got: MediaPlan) -> list[str]:
    """``check``'s lines: each stretch's medium and mode, each change of mode."""
    lines: list[str] = []
    transitions = iter(got.transitions)
    for k, st in enumerate(got.stretches):
        media = ", ".join(f"{m.value} {length:.1f} m" for m, length in st.media_m if length > 0.05)
        pinned = " (the waypoint's own mode)" if st.pinned else ""
        lines.append(
            f"stretch : {k + 1}  {st.start_m:6.1f} → {st.end_m:6.1f} m  {st.mode.value:<6} "
            f"over {media or st.main_medium.value}{pinned}"
        )
        after = got.stretches[k + 1] if k + 1 < len(got.stretches) else None
        # a change of mode stands between two stretches in different modes only (a pinned
        # stretch and its unpinned neighbour in the same mode have none between them)
        t = next(transitions, None) if after is not None and after.mode is not st.mode else None
        if t is not None:
            turn = "stop, turn 90° in place" if t.turn_rad > 0.0 else "stop, no turn (OMNI)"
            lines.append(
                f"change  : {t.before.value} → {t.after.value} at ({t.xy_m[0]:.1f}, "
                f"{t.xy_m[1]:.1f}) on {t.medium.value}: {turn}"
            )
    return lines


def pinned_warnings(got: MediaPlan, policy: ModePolicy) -> list[str]:
    """``check``'s warning for each leg a waypoint pins to a mode over ground that mode cannot
    move in (the map's modes say another): rolling barely moves in water and mud."""
    lines: list[str] = []
    for k, st, misfit in pinned_misfits(got, policy):
        where = ", ".join(f"{m.value} {length:.1f} m" for m, length in misfit)
        wants = "/".join(dict.fromkeys(policy.mode_for(m).value for m, _ in misfit))
        lines.append(
            f"warning : stretch {k + 1} is pinned to {st.mode.value} by its waypoint's mode "
            f"across {where}, which the map's modes fly in {wants}: {st.mode.value} barely "
            "moves there, the estimate does not count it, and in flight the ground check "
            "changes the mode where the rover bogs down — drop the waypoint's `mode:` to let "
            "the map choose"
        )
    return lines


def shown_path(path: Path | None) -> str:
    """A file as a crew reads it: relative to the working directory (as a mission names its
    map, ``../maps/pond-media.geojson``) unless the absolute path is shorter."""
    if path is None:
        return "(none)"
    try:
        relative = os.path.relpath(path, Path.cwd())
    except ValueError:  # another drive
        return str(path)
    return relative if len(relative) <= len(str(path)) else str(path)


def modes_text(plan: Plan) -> str:
    """``roll``, or ``roll/scroll`` for a plan whose mode follows the medium."""
    seen: list[MotionMode] = []
    for i in range(len(plan.waypoints)):
        m = plan.mode_at(i)
        if m not in seen:
            seen.append(m)
    return "/".join(m.value for m in seen) or plan.mode.value


__all__ = [
    "MAX_TABLE_ROWS",
    "check_lines",
    "dig_in_warning",
    "estimate_line",
    "ground_line",
    "modes_text",
    "pinned_warnings",
    "record_space_warning",
    "shown_path",
    "stretch_lines",
    "waypoint_table",
]
