"""Run summary (``summary.json``): what a run achieved, computed row by row. Pure: no I/O.

:class:`SummaryBuilder` keeps running sums only (no row storage), so feeding it from a 50 Hz
loop for hours costs constant memory.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field

from helixd import __version__
from helixd.files.models import StrictModel
from helixd.mission.resume import ResumedFrom
from helixd.recorder.rows import FlightRow

# Driven path length is summed over pose steps of at least this length, so pose noise (GPS
# jitter while standing still) does not inflate it. Poses that are not fresh are skipped.
PATH_MIN_STEP_M = 0.1


class Arrival(StrictModel):
    index: int = Field(
        description="plan index (0-based, via points included: flight.csv's "
        "target_index, what --resume counts)"
    )
    t_boot_s: float = Field(description="autopilot time of arrival (s)")
    error_m: float = Field(description="distance to the waypoint when it was declared reached (m)")
    number: int | None = Field(
        None,
        description="the operator's waypoint number (1-based over the whole mission, as the "
        "ground station numbers mission items; a via point: the waypoint it leads to); a "
        "mission with commands: the mission item (home 0, the first item 1) being flown",
    )
    via: bool = Field(False, description="a via point the planner inserted")
    lap: str | None = Field(
        None, description='"lap 2 of 3" where a DO_JUMP repeats the item; None: flown once'
    )


class RunSummary(StrictModel):
    mission_name: str
    mode: str = Field(description="motion mode: roll | scroll | omni")
    completed: bool = Field(description="every waypoint reached")
    fault: str | None = Field(description="cause that ended the run early, None if none")
    exit_code: int
    waypoints_reached: int = Field(
        description="arrivals at the operator's waypoints (no via points); a mission with "
        "commands counts them as flown: a waypoint a DO_JUMP repeats counts on each lap "
        "(arrivals[].number and .lap name the item), so it can exceed items_total"
    )
    waypoints_total: int = Field(
        description="the operator's waypoints in this run, counted like waypoints_reached "
        "(never fewer than it)"
    )
    items_total: int | None = Field(
        None,
        description="a mission with commands: its items as the ground station numbers them "
        "(home 0 not counted), the N of 'item 3/N'; None: a plain list of waypoints",
    )
    patrol_item: int | None = Field(
        None,
        description="a patrol: the DO_JUMP item repeated forever (repeat -1), flown until "
        "stopped; waypoints_total and estimated_s then count the laps planned beyond the time "
        "limit, not an end. None: not a patrol",
    )
    via_points_reached: int = Field(0, description="via points (inserted by the planner) reached")
    via_points_total: int = Field(0, description="via points in this run")
    arrivals: tuple[Arrival, ...] = ()
    duration_s: float = Field(
        description="first to last recorded step on the autopilot's clock (time_boot_ms), so a "
        "simulator speed-up does not shrink it; the monotonic clock if the autopilot rebooted (s)"
    )
    duration_clock: Literal["autopilot", "monotonic"] = Field(
        "autopilot",
        description="clock duration_s was measured on: the autopilot's time_boot_ms, or the "
        "companion's monotonic clock when the autopilot clock stepped back (reboot)",
    )
    duration_mono_s: float | None = Field(
        None,
        description="the same first-to-last recorded step on the companion's monotonic (wall) "
        "clock; differs from duration_s under a simulator speed-up (s)",
    )
    estimated_s: float | None = Field(
        None,
        description="the navigator's own estimate of the flight at preflight, from the start "
        "pose (autopilot clock, s; helixd.control.estimate): compare with duration_s",
    )
    start_t_boot_s: float | None = Field(
        None, description="autopilot time (time_boot_ms) of the first recorded step (s)"
    )
    wall_duration_s: float | None = Field(
        None,
        description="whole run including connect/preflight/stop on the companion's wall "
        "(monotonic) clock, if given (s)",
    )
    companion_clock: Literal["wall", "simulated"] = Field(
        "wall",
        description="what the companion's clock was (duration_mono_s, wall_duration_s): the "
        "wall's monotonic clock, or one simulated clock shared with the built-in simulator "
        "(run --sim --sim-clock simulated), whose seconds are not the wall's",
    )
    path_length_m: float = Field(description="driven path length from the recorded poses (m)")
    cross_track_rms_m: float | None = Field(description="RMS distance from the planned legs (m)")
    cross_track_max_m: float | None = Field(description="max |cross-track| (m)")
    final_error_m: float | None = Field(description="last pose to the final waypoint (m)")
    rows: int = Field(0, description="control steps recorded")
    slip_vx_frac: float | None = Field(
        None,
        description="last slip estimate: fraction of the commanded roll-axis velocity the "
        "ground delivered (1 = no slip); None if never recorded",
    )
    slip_vy_frac: float | None = Field(
        None, description="last slip estimate for the scroll-axis velocity (1 = no slip)"
    )
    slip_w_frac: float | None = Field(
        None, description="last slip estimate for the yaw rate (1 = no slip)"
    )
    origin_latlon_deg: tuple[float, float] | None = Field(
        None,
        description="the EKF origin (GPS_GLOBAL_ORIGIN) the autopilot reported at preflight, "
        "recorded for every run where it has one: local_ned and start tracks hang from it "
        "(lat, lon deg)",
    )
    resumed_from: ResumedFrom | None = Field(
        None, description="the run this one resumed (`helixd run --resume`), None if none"
    )
    record_cut_at_s: float | None = Field(
        None,
        description="the flight record (flight.csv) is missing from this time on, counted like "
        "duration_s from the first recorded step (disk full or unwritable); None: complete (s)",
    )
    record_cut_files: tuple[str, ...] = Field(
        (), description="the run directory's files whose writing stopped (record cut)"
    )
    ground: dict[str, Any] | None = Field(
        None,
        description="what each medium delivered in each mode in this run (per 'medium/mode': "
        "samples, metres, fractions, sigmas, power_w_per_mps), added after the run when it "
        "had a media map (helixd.prepare.ground_learning); None: not learnt",
    )
    helixd_version: str = __version__

    def to_json(self) -> str:
        return self.model_dump_json(indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> RunSummary:
        return cls.model_validate_json(text)


class SummaryBuilder:
    """Accumulates a RunSummary from FlightRows and arrival notices."""

    def __init__(
        self,
        mission_name: str = "",
        mode: str = "",
        waypoints_total: int = 0,
        final_xy_m: tuple[float, float] | None = None,
        *,
        via_points_total: int = 0,
        path_min_step_m: float = PATH_MIN_STEP_M,
        join_m: float | None = None,
        estimated_s: float | None = None,
    ) -> None:
        """``final_xy_m``: the last waypoint in the mission frame (for ``final_error_m``; the
        last row's ``distance_error_m`` is used without it). ``join_m``: a resumed run's
        cross-track counts from the first row within this of the interrupted leg (or the
        first arrival): the approach to the leg is not the mission's error. Identity fields
        may also be given to :meth:`build`."""
        self._name = mission_name
        self._mode = mode
        self._total = waypoints_total
        self._via_total = via_points_total
        self._final_xy = final_xy_m
        self._min_step = path_min_step_m
        self._origin: tuple[float, float] | None = None
        self._rows = 0
        self._t_first: float | None = None
        self._t_last: float | None = None
        self._tb_first: float | None = None  # autopilot clock (t_boot_s)
        self._tb_last: float | None = None
        self._tb_monotonic = True  # False once the autopilot clock stepped back (reboot)
        self._anchor: tuple[float, float] | None = None
        self._path_m = 0.0
        self._xt_sq = 0.0
        self._xt_n = 0
        self._xt_max = 0.0
        self._last_xy: tuple[float, float] | None = None
        self._last_dist_err: float | None = None
        self._arrivals: dict[int, Arrival] = {}
        self._join_m = join_m
        self._estimated_s = (
            estimated_s if estimated_s is None or math.isfinite(estimated_s) else None
        )
        self._joined = join_m is None
        self._slip: tuple[float, float, float] | None = None  # last finite (vx, vy, w) estimate

    def set_origin(self, lat_deg: float, lon_deg: float) -> None:
        """Record the autopilot's EKF origin (plots and export place the run with it)."""
        self._origin = (lat_deg, lon_deg)

    def add(self, row: FlightRow) -> None:
        """Account for one control step (O(1), no row kept)."""
        self._rows += 1
        t = row.t_mono_s
        if math.isfinite(t):
            if self._t_first is None:
                self._t_first = t
            self._t_last = t
        tb = row.t_boot_s
        if math.isfinite(tb):
            if self._tb_first is None:
                self._tb_first = tb
            self._tb_monotonic = self._tb_monotonic and (
                self._tb_last is None or tb >= self._tb_last
            )
            self._tb_last = tb
        x, y = row.x_m, row.y_m
        if row.pose_fresh and math.isfinite(x) and math.isfinite(y):
            self._last_xy = (x, y)
            if self._anchor is None:
                self._anchor = (x, y)
            else:
                step = math.hypot(x - self._anchor[0], y - self._anchor[1])
                if step >= self._min_step:
                    self._path_m += step
                    self._anchor = (x, y)
        xt = row.cross_track_m
        if not self._joined and self._join_m is not None and abs(xt) <= self._join_m:
            self._joined = True  # on the leg: the approach to it is over
        if self._joined and math.isfinite(xt):
            self._xt_sq += xt * xt
            self._xt_n += 1
            self._xt_max = max(self._xt_max, abs(xt))
        if math.isfinite(row.distance_error_m):
            self._last_dist_err = row.distance_error_m
        slip = (row.slip_vx_frac, row.slip_vy_frac, row.slip_w_frac)
        if all(math.isfinite(f) for f in slip):
            self._slip = slip

    def arrival(
        self,
        index: int,
        t_boot_s: float,
        error_m: float,
        *,
        number: int | None = None,
        via: bool = False,
        lap: str = "",
    ) -> None:
        """A waypoint (plan index ``index``; the operator's ``number``) was reached (the first
        notice per index counts)."""
        self._joined = True
        if index not in self._arrivals:
            self._arrivals[index] = Arrival(
                index=index,
                t_boot_s=t_boot_s,
                error_m=error_m,
                number=number,
                via=via,
                lap=lap or None,
            )

    @property
    def start_t_boot_s(self) -> float | None:
        """Autopilot time of the first recorded step (s), None before any."""
        return self._tb_first

    @property
    def waypoints_reached(self) -> int:
        """The operator's waypoints reached (via points not counted)."""
        return sum(not a.via for a in self._arrivals.values())

    def build(
        self,
        completed: bool,
        fault: str | None,
        exit_code: int,
        *,
        mission_name: str | None = None,
        mode: str | None = None,
        waypoints_total: int | None = None,
        via_points_total: int | None = None,
        wall_duration_s: float | None = None,
        items_total: int | None = None,
    ) -> RunSummary:
        """The summary so far; keyword arguments override the constructor's identity fields."""
        mono: float | None = (
            None if self._t_first is None or self._t_last is None else self._t_last - self._t_first
        )
        duration = 0.0 if mono is None else mono
        clock: Literal["autopilot", "monotonic"] = "monotonic"
        if self._tb_monotonic and self._tb_first is not None and self._tb_last is not None:
            duration = self._tb_last - self._tb_first
            clock = "autopilot"
        elif mono is None:
            clock = "autopilot"  # nothing recorded: no clock was used at all
        if self._final_xy is not None and self._last_xy is not None:
            final_error: float | None = math.hypot(
                self._last_xy[0] - self._final_xy[0], self._last_xy[1] - self._final_xy[1]
            )
        else:
            final_error = self._last_dist_err
        path_m = self._path_m
        if self._anchor is not None and self._last_xy is not None:
            path_m += math.hypot(
                self._last_xy[0] - self._anchor[0], self._last_xy[1] - self._anchor[1]
            )
        return RunSummary(
            mission_name=self._name if mission_name is None else mission_name,
            mode=self._mode if mode is None else mode,
            completed=completed,
            fault=fault,
            exit_code=exit_code,
            waypoints_reached=self.waypoints_reached,
            waypoints_total=max(
                self._total if waypoints_total is None else waypoints_total,
                self.waypoints_reached,
            ),
            items_total=items_total,
            via_points_reached=len(self._arrivals) - self.waypoints_reached,
            via_points_total=self._via_total if via_points_total is None else via_points_total,
            arrivals=tuple(sorted(self._arrivals.values(), key=lambda a: a.t_boot_s)),
            duration_s=duration,
            duration_clock=clock,
            duration_mono_s=mono,
            estimated_s=self._estimated_s,
            start_t_boot_s=self._tb_first,
            wall_duration_s=wall_duration_s,
            path_length_m=path_m,
            cross_track_rms_m=math.sqrt(self._xt_sq / self._xt_n) if self._xt_n else None,
            cross_track_max_m=self._xt_max if self._xt_n else None,
            final_error_m=final_error,
            rows=self._rows,
            slip_vx_frac=None if self._slip is None else self._slip[0],
            slip_vy_frac=None if self._slip is None else self._slip[1],
            slip_w_frac=None if self._slip is None else self._slip[2],
            origin_latlon_deg=self._origin,
        )


__all__ = ["PATH_MIN_STEP_M", "Arrival", "RunSummary", "SummaryBuilder"]
