"""What a control step becomes once its command has left: the flight.csv row and the
operator's progress line.

Pure builders from :class:`helixd.runtime.flight.StepReport` (and the plan): the flight loop
stays free
of the recorder's schema and of the terminal UI's types, and none of this runs before the
command is sent. :class:`StepJournal` batches the rows: a step only appends its report, and
the rows are built and handed on in one go, a few times a second (one warm pass over a batch
costs a fraction of a row built per step, when the loop wakes with cold caches every 20 ms).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from helixd.base.plan import Numbering, Plan
from helixd.recorder.rows import FlightRow
from helixd.report.display import ProgressInfo
from helixd.runtime.flight import PoseRejectedReport, StepReport

MediumAt = Callable[[float, float], str]  # (north_m, east_m) → the medium's name


def flight_row(report: StepReport, plan: Plan, medium_at: MediumAt | None = None) -> FlightRow:
    """The flight.csv row of one step (``medium_at``: the media map's lookup, if any)."""
    sample = report.sample
    step = report.step
    out = step.nav
    mpose = step.mpose
    ned = sample.ned
    waypoints = plan.waypoints
    target = waypoints[min(out.target_index, len(waypoints) - 1)]
    fractions = step.fractions
    pwm = report.pwm_us
    slip = step.slip
    command = out.command
    return FlightRow(
        t_boot_s=sample.time_boot_ms / 1000.0,
        t_mono_s=report.now_s,
        north_m=ned.north_m,
        east_m=ned.east_m,
        yaw_ned_rad=ned.yaw_ned_rad,
        x_m=mpose.x_m,
        y_m=mpose.y_m,
        yaw_rad=mpose.yaw_rad,
        target_index=out.target_index,
        target_x_m=target.x_m,
        target_y_m=target.y_m,
        distance_error_m=out.distance_error_m,
        heading_error_rad=out.heading_error_rad,
        cross_track_m=out.cross_track_m,
        dist_p=out.distance_pid.p,
        dist_i=out.distance_pid.i,
        dist_d=out.distance_pid.d,
        yaw_p=out.yaw_pid.p,
        yaw_i=out.yaw_pid.i,
        yaw_d=out.yaw_pid.d,
        vx_cmd_mps=command.vx_mps,
        vy_cmd_mps=command.vy_mps,
        wz_cmd_radps=command.wz_radps,
        speed_meas_mps=math.hypot(sample.vn_mps, sample.ve_mps),
        scroll1=fractions[0],
        scroll2=fractions[1],
        scroll3=fractions[2],
        scroll4=fractions[3],
        pwm1_us=pwm[0],
        pwm2_us=pwm[1],
        pwm3_us=pwm[2],
        pwm4_us=pwm[3],
        mode=report.mode,
        armed=report.armed,
        nav_state=out.state.value,
        link_ok=report.link_ok,
        pose_fresh=report.pose_fresh,
        slip_vx_frac=slip.vx_frac,
        slip_vy_frac=slip.vy_frac,
        slip_w_frac=slip.w_frac,
        motion_mode=step.motion_mode,
        medium="" if medium_at is None else medium_at(ned.north_m, ned.east_m),
    )


def step_progress(report: StepReport, numbering: Numbering) -> ProgressInfo:
    """The progress line of one step (the operator's numbering: 1-based over the whole
    mission, via points shown as the leg to a waypoint)."""
    out, sample = report.step.nav, report.sample
    speed_mps = math.hypot(sample.vn_mps, sample.ve_mps)
    heading_deg = math.degrees(out.heading_error_rad)
    moving = (out.distance_error_m, speed_mps, heading_deg, report.pose_fresh)
    return _progress(numbering, out.target_index, moving, report, out.state.value)


def rejected_progress(report: PoseRejectedReport, numbering: Numbering) -> ProgressInfo:
    """The progress line while the pose telemetry is rejected: no distance, speed or heading
    (shown as "-"), the pose not fresh."""
    unknown = (math.nan, math.nan, math.nan, False)
    return _progress(numbering, report.last_target_index, unknown, report, "pose_invalid")


def _progress(
    numbering: Numbering,
    index: int,
    moving: tuple[float, float, float, bool],
    report: StepReport | PoseRejectedReport,
    nav_state: str,
) -> ProgressInfo:
    """The progress line toward plan waypoint ``index``; ``moving``: the distance to go, the
    speed, the heading error (°) and whether the pose is fresh."""
    distance_m, speed_mps, heading_deg, pose_fresh = moving
    return ProgressInfo(
        waypoint_index=numbering.number(index),
        waypoints_total=numbering.total,
        via=numbering.via(index),
        lap=numbering.lap(index),
        distance_to_go_m=distance_m,
        speed_mps=speed_mps,
        heading_error_deg=heading_deg,
        link_ok=report.link_ok,
        pose_fresh=pose_fresh,
        elapsed_s=report.elapsed_s,
        phase="fly",
        nav_state=nav_state,
    )


class StepJournal:
    """Step reports turned into flight.csv rows (and whatever else ``on_row`` feeds) in batches.

    :meth:`add` is called after each step's command left; it builds the pending rows once the
    oldest is ``batch_s`` old (by the steps' monotonic stamps), so a batch is built right after
    a send, never before one. :meth:`maybe_drain` (from the loop's tick) hands rows on when
    steps pause; :meth:`drain` before anything reads what the rows feed (a waypoint arrival,
    the summary at the end). No clock inside: times come in with the reports and the ticks.
    """

    def __init__(
        self,
        plan: Plan,
        on_row: Callable[[FlightRow], None],
        batch_s: float,
        medium_at: MediumAt | None = None,
    ) -> None:
        self._plan = plan
        self._medium_at = medium_at
        self._on_row = on_row
        self._batch_s = batch_s
        self._pending: list[StepReport] = []

    def add(self, report: StepReport) -> None:
        pending = self._pending
        pending.append(report)
        if report.now_s - pending[0].now_s >= self._batch_s:
            self.drain()

    def maybe_drain(self, now_s: float) -> None:
        """Hand the pending rows on if the newest is ``batch_s`` old (the steps paused)."""
        if self._pending and now_s - self._pending[-1].now_s >= self._batch_s:
            self.drain()

    def drain(self) -> None:
        pending, self._pending = self._pending, []
        plan, on_row, medium_at = self._plan, self._on_row, self._medium_at
        for report in pending:
            on_row(flight_row(report, plan, medium_at))

    @property
    def pending(self) -> int:
        return len(self._pending)
