"""A recorded run loaded for its plots (:mod:`helixd.recorder.plots`): flight.csv's columns
on the autopilot's clock (the wall clock beside it), the summary, the planned waypoints with
the operator's numbers, the arrivals, the fault and the pauses, the media map flown.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # before anything imports pyplot: no display on the rover

import numpy as np
import numpy.typing as npt
import structlog

from helixd.base.plan import MissionFrameKind, Numbering, program_numbering
from helixd.base.run_files import CONFIG_FILE, EVENTS_FILE, FLIGHT_FILE, MISSION_FILE, SUMMARY_FILE
from helixd.config.load import load_config
from helixd.files.models import ConfigFileError
from helixd.mission.model import load_mission
from helixd.mission.resolve import PlanError, resolve_plan
from helixd.mission.resume import with_leg_start
from helixd.recorder.clocks import autopilot_axis_s
from helixd.recorder.events import fault_time_mono_s, read_events
from helixd.recorder.media_plot import (
    PlacedMedia,
    flown_modes,
    run_media,
)
from helixd.recorder.outcome import (
    ending_color,
    ending_label,
    pause_spans,
)
from helixd.recorder.resume_dir import recorded_inputs
from helixd.recorder.rows import read_flight_columns
from helixd.recorder.summary import Arrival, RunSummary

log = structlog.get_logger(__name__)

LAP_TEXT = re.compile(r"lap (?P<k>\d+) of (?P<n>\d+)")  # Program.laps()' words
FAULT_LABEL_MAX_CHARS = 48  # long causes are cut in legends (the summary keeps them whole)
AUTOPILOT_AXIS_LABEL = "autopilot time since the first control step (s)"
WALL_AXIS_LABEL = "wall time since the first control step (s)"
Array = npt.NDArray[np.float64]
XY = tuple[float, float]


class PlotError(Exception):
    """The run directory has nothing that can be plotted."""


@dataclass
class RunData:
    """Everything the panels need, loaded once from a run directory."""

    name: str
    cols: dict[str, npt.NDArray[Any]]
    t_s: Array  # time axis: autopilot time since the first row (wall time if none recorded)
    wall_s: Array  # companion monotonic (wall) time since the first row
    on_autopilot_clock: bool  # t_s is autopilot time (False: it is the wall clock)
    summary: RunSummary | None
    waypoints: list[tuple[float, float, float]]  # x_m, y_m, tolerance_m
    path_start: tuple[float, float] | None  # a resumed run: the interrupted leg's start
    # the operator's waypoint number (with its lap where a DO_JUMP repeats it), t_s; no via
    # points
    arrivals: list[tuple[str, float]]
    fault: str | None
    fault_t_s: float | None
    clamp_pct: float | None
    notes: list[str] = field(default_factory=list)
    pauses: list[tuple[float, float]] = field(default_factory=list)  # held for the crew (t_s)
    # per waypoint: the operator's number ("3", numbered from 1 over the whole mission as a
    # ground station does); "" for a via point the planner inserted
    labels: list[str] = field(default_factory=list)
    # the trajectory's axis labels: what x and y are in the mission's frame
    axis_labels: tuple[str, str] = ("x (m)", "y (m)")
    # the media map the flight followed, placed as it was flown (None: none)
    media: PlacedMedia | None = None

    @property
    def modes_text(self) -> str:
        """The modes actually flown (``roll 62 %, scroll 38 %``), else the mission's own."""
        flown = flown_modes(self.cols.get("motion_mode"), self.col("x_m"), self.col("y_m"))
        if flown:
            return flown
        return self.summary.mode if self.summary else ""

    @property
    def time_label(self) -> str:
        return AUTOPILOT_AXIS_LABEL if self.on_autopilot_clock else WALL_AXIS_LABEL

    def wall_at(self, t_s: npt.ArrayLike) -> Array:
        """Wall time at axis times ``t_s`` (linear beyond the recorded span)."""
        return interp_linear(t_s, self.t_s, self.wall_s)

    def axis_at_wall(self, wall_s: npt.ArrayLike) -> Array:
        """Axis time at wall times ``wall_s`` (linear beyond the recorded span)."""
        return interp_linear(wall_s, self.wall_s, self.t_s)

    def col(self, name: str) -> Array:
        values = self.cols.get(name)
        if values is None:
            return np.full(self.t_s.shape, np.nan)
        return np.asarray(values, dtype=np.float64)

    @property
    def end_color(self) -> str:
        """Red for a fault, another colour for the crew's own ending (a pause, a handover)."""
        return ending_color(self.fault)

    def fault_label(self) -> str:
        text = ending_label(self.fault or "")
        if len(text) > FAULT_LABEL_MAX_CHARS:
            text = text[: FAULT_LABEL_MAX_CHARS - 1] + "…"
        return text

    def fault_index(self) -> int | None:
        if self.fault_t_s is None:
            return None
        return int(np.argmin(np.abs(self.t_s - self.fault_t_s)))


# ---------------------------------------------------------------------------------------------
# Clocks (pure)


def autopilot_axis(t_boot_s: Array, t_mono_s: Array) -> Array | None:
    """Autopilot time since the first row (see :func:`helixd.recorder.clocks.autopilot_axis_s`);
    None without autopilot times."""
    axis = autopilot_axis_s([float(t) for t in t_boot_s], [float(t) for t in t_mono_s])
    return None if axis is None else np.asarray(axis, dtype=np.float64)


def interp_linear(x_in: npt.ArrayLike, xp: Array, fp: Array) -> Array:
    """``np.interp`` with straight-line extension beyond ``xp`` (secondary axes need it)."""
    x = np.atleast_1d(np.asarray(x_in, dtype=np.float64))
    if xp.size == 0:
        return x.copy()
    span_x = float(xp[-1] - xp[0])
    slope = float(fp[-1] - fp[0]) / span_x if span_x > 0 else 1.0
    slope = slope if math.isfinite(slope) and slope > 0 else 1.0
    out = np.interp(x, xp, fp)
    lo, hi = x < xp[0], x > xp[-1]
    out[lo] = fp[0] + (x[lo] - xp[0]) * slope
    out[hi] = fp[-1] + (x[hi] - xp[-1]) * slope
    return out


# ---------------------------------------------------------------------------------------------
# Loading


def load_run(run_dir: Path) -> RunData:
    flight = run_dir / FLIGHT_FILE
    if not flight.is_file():
        raise PlotError(f"{run_dir}: no {FLIGHT_FILE} (is this a helixd run directory?)")
    cols = read_flight_columns(flight)
    if len(cols.get("t_mono_s", ())) == 0:
        raise PlotError(f"{flight}: no rows recorded, nothing to plot")
    t_mono = np.asarray(cols["t_mono_s"], dtype=np.float64)
    t0 = float(t_mono[0])
    summary = _load_summary(run_dir / SUMMARY_FILE)
    notes: list[str] = []
    waypoints, start, labels = _load_plan(run_dir, summary, cols, notes)
    t_boot = np.asarray(cols.get("t_boot_s", np.full(t_mono.shape, np.nan)), dtype=np.float64)
    wall_s = t_mono - t0
    ap = autopilot_axis(t_boot, t_mono)
    t_s = wall_s if ap is None else ap
    arrivals = []
    for arr in summary.arrivals if summary else ():
        if arr.via:
            continue  # the planner's via points are not the operator's waypoints
        idx = int(np.nanargmin(np.abs(t_boot - arr.t_boot_s))) if np.isfinite(t_boot).any() else 0
        arrivals.append((arrival_mark(arr), float(t_s[idx])))
    fault = summary.fault if summary else None
    fault_t: float | None = None
    events = read_events(run_dir / EVENTS_FILE)
    if fault is not None:
        mono = fault_time_mono_s(events, fault)
        fault_wall = float(wall_s[-1]) if mono is None else mono - t0
        fault_t = float(interp_linear(np.array([fault_wall]), wall_s, t_s)[0])
    media, why = run_media(events, summary.origin_latlon_deg if summary else None)
    if why:
        notes.append(why)
    pauses = [
        (a, b)
        for start, end in pause_spans(events)
        for a, b in [interp_linear(np.array([start - t0, (end or t_mono[-1]) - t0]), wall_s, t_s)]
    ]
    return RunData(
        name=summary.mission_name if summary else run_dir.name,
        cols=cols,
        t_s=t_s,
        wall_s=wall_s,
        on_autopilot_clock=ap is not None,
        summary=summary,
        waypoints=waypoints,
        path_start=start,
        arrivals=arrivals,
        fault=fault,
        fault_t_s=fault_t,
        clamp_pct=_clamp_pct(run_dir),
        notes=notes,
        pauses=[(float(a), float(b)) for a, b in pauses],
        labels=labels,
        axis_labels=axis_labels(
            _mission_frame(run_dir), summary.origin_latlon_deg if summary else None
        ),
        media=media,
    )


def arrival_mark(arrival: Arrival) -> str:
    """A time marker's waypoint: its number as the ground station shows it, with the lap
    where a DO_JUMP flies the item again (``3 lap 2/3``), so each lap's arrival is told apart
    as in the log and the ground station's texts."""
    number = arrival.index + 1 if arrival.number is None else arrival.number
    lap = LAP_TEXT.fullmatch(arrival.lap or "")
    if lap is None:
        return str(number) if not arrival.lap else f"{number} {arrival.lap}"
    return f"{number} lap {lap['k']}/{lap['n']}"


def _load_summary(path: Path) -> RunSummary | None:
    try:
        return RunSummary.from_json(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        log.warning("plot_summary_unreadable", path=str(path), error=str(exc))
        return None


def axis_labels(
    frame: MissionFrameKind | None, origin_latlon_deg: tuple[float, float] | None
) -> tuple[str, str]:
    """The trajectory's axes in the mission frame (rows.py: a start mission's x forward and
    y left of the start pose; local_ned and global: x East, y North of the EKF origin)."""
    if frame is MissionFrameKind.START:
        return ("x, forward of the start pose (m)", "y, left of the start pose (m)")
    if frame is None:
        return ("x (m)", "y (m)")
    where = "the EKF origin"
    if origin_latlon_deg is not None:
        where += f" {origin_latlon_deg[0]:.6f}°, {origin_latlon_deg[1]:.6f}°"
    return (f"x, east of {where} (m)", f"y, north of {where} (m)")


def _mission_frame(run_dir: Path) -> MissionFrameKind | None:
    try:
        return load_mission(run_dir / MISSION_FILE).frame
    except (ConfigFileError, PlanError, OSError):
        return None


def _load_plan(
    run_dir: Path,
    summary: RunSummary | None,
    cols: dict[str, npt.NDArray[Any]],
    notes: list[str],
) -> tuple[list[tuple[float, float, float]], tuple[float, float] | None, list[str]]:
    """The planned waypoints, where the planned path starts (a resumed run: at the start of
    the interrupted leg, not where the rover stood) and the waypoints' labels."""
    inputs = recorded_inputs(run_dir)
    try:
        cfg = load_config(run_dir / CONFIG_FILE)
        msn = load_mission(run_dir / MISSION_FILE, cfg.mission)
        origin = summary.origin_latlon_deg if summary else None
        plan = resolve_plan(
            msn, cfg.control, cfg.mission, origin,
            time_limit_s=cfg.safety.mission_time_limit_s,
        )  # fmt: skip
        if inputs is not None and inputs.leg_start is not None:
            plan = with_leg_start(plan, msn, inputs.leg_start, cfg.control, cfg.mission, origin)
    except (ConfigFileError, PlanError) as exc:
        log.warning("plot_plan_unavailable", run_dir=str(run_dir), error=str(exc))
        notes.append("planned path unavailable")
        return [], None, []
    vias = [w.via for w in plan.waypoints]
    numbering = program_numbering(plan)  # a mission with commands: its items, as QGC shows
    if numbering is None:
        numbering = Numbering.of(vias) if inputs is None else inputs.numbering(vias)
    labels = [
        "" if via else str(n) for n, via in zip(numbering.numbers, numbering.vias, strict=True)
    ]
    wps = [(w.x_m, w.y_m, w.tolerance_m) for w in plan.waypoints]
    if plan.leg_start_xy_m is not None:
        return wps, plan.leg_start_xy_m, labels
    if msn.frame is MissionFrameKind.START:
        return wps, (0.0, 0.0), labels
    x = np.asarray(cols["x_m"], dtype=np.float64)
    y = np.asarray(cols["y_m"], dtype=np.float64)
    ok = np.isfinite(x) & np.isfinite(y)
    start = (float(x[ok][0]), float(y[ok][0])) if ok.any() else None
    return wps, start, labels


def _clamp_pct(run_dir: Path) -> float | None:
    try:
        return 100.0 * load_config(run_dir / CONFIG_FILE).vehicle.output_clamp
    except ConfigFileError:
        return None


__all__ = [
    "AUTOPILOT_AXIS_LABEL",
    "FAULT_LABEL_MAX_CHARS",
    "WALL_AXIS_LABEL",
    "XY",
    "Array",
    "PlotError",
    "RunData",
    "arrival_mark",
    "autopilot_axis",
    "axis_labels",
    "interp_linear",
    "load_run",
]
