"""Plots of a recorded run, after the thesis's Tables 2–9 panels (a)–(e).

(a) trajectory in the mission frame against the planned path, waypoints numbered with their
tolerance circles; (b) x, y and yaw against time; (c) commanded and measured velocities;
(d) distance, cross-track and heading errors; (e) scroll commands in % of max RPM; (f) the
cross-track error against the distance travelled along the path (where on the path the rover
strays, independent of speed).
Waypoint arrivals are dotted vertical markers (labelled sparsely, so a 25-point circle stays
readable), a fault is marked in red, intervals with the link or the pose lost are shaded.
Legends sit outside the data. One PNG per panel plus ``overview.png``.

Time axes run on the autopilot's clock (``t_boot_s``, seconds since the first control step),
the same clock as the result's flight time; the wall clock (``t_mono_s``) is a second axis on
top — they differ under a simulator speed-up. Without autopilot times the wall clock is used.

Uses matplotlib's Agg backend through the object API (no pyplot state, safe in a daemon).
The run is loaded by :mod:`helixd.recorder.run_data`; the plan panels of ``helixd check
--plot`` are :mod:`helixd.recorder.plan_plots`.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # before anything imports pyplot: no display on the rover

import numpy as np
import numpy.typing as npt
import structlog
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from matplotlib.transforms import Bbox

from helixd.recorder.media_plot import (
    MODE_COLORS,
    draw_media,
    keep_view,
)
from helixd.recorder.outcome import (
    CREW_COLOR,
    crew_ending,
    result_word,
)
from helixd.recorder.run_data import FAULT_LABEL_MAX_CHARS, Array, RunData, load_run
from helixd.recorder.summary import PATH_MIN_STEP_M, RunSummary

log = structlog.get_logger(__name__)

DPI = 100
PANEL_SIZE_IN = (10.0, 7.5)
OVERVIEW_SIZE_IN = (18.0, 10.0)
PANEL_SIZE_PX = (int(PANEL_SIZE_IN[0] * DPI), int(PANEL_SIZE_IN[1] * DPI))  # width, height
OVERVIEW_SIZE_PX = (int(OVERVIEW_SIZE_IN[0] * DPI), int(OVERVIEW_SIZE_IN[1] * DPI))
PLOTS_DIR = "plots"
PANEL_FILES = {
    "a": "a_trajectory.png",
    "b": "b_position.png",
    "c": "c_velocity.png",
    "d": "d_errors.png",
    "e": "e_scrolls.png",
    "f": "f_cross_track.png",
}
OVERVIEW_FILE = "overview.png"
ARRIVAL_STYLE: dict[str, Any] = {"color": "0.45", "linestyle": ":", "linewidth": 1.0}
LOST_SHADE: dict[str, Any] = {"color": "orange", "alpha": 0.15, "linewidth": 0}
# waypoint labels on time axes: at least this fraction of the axis width apart
LABEL_MIN_GAP_PANEL = 0.06
LABEL_MIN_GAP_OVERVIEW = 0.12
SAME_POINT_M = 0.05  # waypoints closer than this share one number label on the trajectory
# waypoint number labels: off the point on the outer side of its turn, every other one farther
# out, so the labels of neighbouring turns (a survey's transect ends) do not print over each
# other (points)
LABEL_OFFSET_PT = 9.0
LABEL_STAGGER_PT = 10.0
SCROLL_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red")
SCROLL_STYLES = ("-", "--", "-", "--")  # paired scrolls overlap: keep both visible


def waypoint_labels(
    points_m: list[tuple[float, float]],
    same_m: float = SAME_POINT_M,
    labels: Sequence[str] | None = None,
) -> list[tuple[str, tuple[float, float]]]:
    """One label per distinct point: waypoints closer than ``same_m`` share it (``1,25``: a
    closed circle's first and last point), instead of printing numbers on top of each other.
    ``labels``: per point (default its 1-based number); an empty label (a via point) is not
    printed."""
    names = [str(i + 1) for i in range(len(points_m))] if labels is None else list(labels)
    groups: list[tuple[list[int], tuple[float, float]]] = []
    for i, (x, y) in enumerate(points_m):
        if not names[i]:
            continue
        for members, (gx, gy) in groups:
            if math.hypot(x - gx, y - gy) < same_m:
                members.append(i)
                break
        else:
            groups.append(([i], (x, y)))
    # an item a DO_JUMP flies again is named once: "1", not "1,1,1"
    return [(",".join(dict.fromkeys(names[i] for i in members)), xy) for members, xy in groups]


def label_offsets_pt(points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """Per point of a path (equal axes): where its label goes, in points from it — away from
    both legs at the point (the outer side of the turn; left of a straight pass; away from the
    one neighbour at an end), :data:`LABEL_OFFSET_PT` out, every other point
    :data:`LABEL_STAGGER_PT` farther, so neighbouring labels land apart."""
    out: list[tuple[float, float]] = []
    for i, (x, y) in enumerate(points):
        away = [0.0, 0.0]
        for j in (i - 1, i + 1):
            if 0 <= j < len(points):
                dx, dy = points[j][0] - x, points[j][1] - y
                d = math.hypot(dx, dy)
                if d > 0.0:
                    away[0] -= dx / d
                    away[1] -= dy / d
        norm = math.hypot(*away)
        if norm < 1e-6:  # a straight pass (or a lone point): to the left of the path
            j = i + 1 if i + 1 < len(points) else i - 1
            dx, dy = (points[j][0] - x, points[j][1] - y) if 0 <= j < len(points) else (1.0, 0.0)
            d = math.hypot(dx, dy) or 1.0
            away, norm = [-dy / d, dx / d], 1.0
        dist = LABEL_OFFSET_PT + (LABEL_STAGGER_PT if i % 2 else 0.0)
        out.append((away[0] / norm * dist, away[1] / norm * dist))
    return out


WAYPOINT_LABEL_GID = "waypoint_label"
LABEL_TIERS = (1.0, 1.8, 2.6)  # a label that would overlap another moves out this many times
LABEL_MARKER_CLEAR_PX = 4.0  # around a waypoint's marker: no label there


def label_waypoint(ax: Axes, text: str, xy: tuple[float, float], offset_pt: tuple[float, float],
                    **style: Any) -> None:  # fmt: skip
    ax.annotate(text, xy, textcoords="offset points", xytext=offset_pt, ha="center",
                va="center", gid=WAYPOINT_LABEL_GID, **style)  # fmt: skip


def declutter_waypoint_labels(fig: Figure) -> Figure:
    """Move each waypoint label that would print over an earlier one (or a waypoint's marker):
    farther out, then mirrored across the point, until it is clear (else where it was). Call
    on the finished figure: the layout decides where the labels land."""
    labels = [t for ax in fig.axes for t in ax.texts if t.get_gid() == WAYPOINT_LABEL_GID]
    if len(labels) < 2:
        return fig
    # a real render (autoscale, aspect, layout: where the labels land); a bare Figure's
    # canvas draws nothing
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()  # type: ignore[no-untyped-call]
    placed: list[Any] = []
    for t in labels:  # the waypoints' markers: no label over one
        x, y = t.axes.transData.transform(t.xy)  # type: ignore[attr-defined, union-attr]
        r = LABEL_MARKER_CLEAR_PX
        placed.append(Bbox.from_extents(x - r, y - r, x + r, y + r))
    for label in labels:
        dx, dy = label.xyann  # type: ignore[attr-defined]
        tries = [
            (sx * dx * k, sy * dy * k)
            for k in LABEL_TIERS
            for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1))
        ]
        for offset in tries:
            label.xyann = offset  # type: ignore[attr-defined]
            box = label.get_window_extent()
            if not any(box.overlaps(other) for other in placed):
                break
        else:
            label.xyann = (dx, dy)  # type: ignore[attr-defined]
            box = label.get_window_extent()
        placed.append(box)
    return fig


def sparse_label_mask(times_s: list[float], span_s: float, min_gap_frac: float) -> list[bool]:
    """Which time markers get a text label: greedily, each at least ``min_gap_frac`` of the
    axis span after the previous labelled one (the first always; the last if it fits)."""
    gap = max(span_s, 0.0) * min_gap_frac
    mask: list[bool] = []
    last: float | None = None
    for t in times_s:
        ok = last is None or (math.isfinite(t) and t - last >= gap)
        mask.append(ok)
        if ok and math.isfinite(t):
            last = t
    return mask


def position_legend(labels: tuple[str, str]) -> tuple[str, str]:
    """The position panel's x and y in the trajectory's words, short: ``x, east (m)`` for
    ``x, east of the EKF origin … (m)``, ``x, forward (m)`` for a start mission."""
    return (
        labels[0].split(" of ", 1)[0] + " (m)" if " of " in labels[0] else labels[0],
        labels[1].split(" of ", 1)[0] + " (m)" if " of " in labels[1] else labels[1],
    )


# ---------------------------------------------------------------------------------------------
# Shared decorations


def distance_along_m(
    x_m: Array, y_m: Array, fresh: npt.NDArray[np.bool_] | None = None,
    min_step_m: float = PATH_MIN_STEP_M,
) -> Array:  # fmt: skip
    """Distance travelled along the recorded path at each row (m), counted as ``summary.json``
    counts ``path_length_m``: only steps of at least ``min_step_m`` from the last counted
    point add up, so pose noise while standing still does not. Rows whose pose is not finite
    (or not ``fresh``) are NaN; the distance carries on from the last good pose.
    """
    out = np.full(x_m.shape, np.nan)
    anchor: tuple[float, float] | None = None
    path = 0.0
    for i in range(x_m.size):
        x, y = float(x_m[i]), float(y_m[i])
        if not (math.isfinite(x) and math.isfinite(y)) or (fresh is not None and not fresh[i]):
            continue
        if anchor is None:
            anchor = (x, y)
        else:
            step = math.hypot(x - anchor[0], y - anchor[1])
            if step >= min_step_m:
                path += step
                anchor = (x, y)
        out[i] = path
    return out


def _unwrap_deg(yaw_rad: Array) -> Array:
    out = np.full(yaw_rad.shape, np.nan)
    ok = np.isfinite(yaw_rad)
    out[ok] = np.degrees(np.unwrap(yaw_rad[ok]))
    return out


def _lost_intervals(data: RunData) -> list[tuple[float, float]]:
    healthy = np.asarray(data.cols.get("link_ok", []), dtype=bool) & np.asarray(
        data.cols.get("pose_fresh", []), dtype=bool
    )
    if healthy.size == 0:
        return []
    spans: list[tuple[float, float]] = []
    start: float | None = None
    for i, ok in enumerate(healthy):
        if not ok and start is None:
            start = float(data.t_s[i])
        elif ok and start is not None:
            spans.append((start, float(data.t_s[i])))
            start = None
    if start is not None:
        spans.append((start, float(data.t_s[-1])))
    return spans


def _arrival_lines(
    ax: Axes,
    marks: Sequence[tuple[str, float]],
    span: float,
    min_gap_frac: float,
    *,
    labels: bool,
) -> None:
    """A dotted line at each (waypoint number, x) arrival; ``WPn`` labels spaced sparsely."""
    show = sparse_label_mask([x for _, x in marks], span, min_gap_frac)
    for k, (index, x) in enumerate(marks):
        ax.axvline(x, **ARRIVAL_STYLE, label="waypoint reached" if k == 0 and labels else None)
        if labels and show[k]:
            ax.text(
                x,
                0.99,
                f" WP{index}",
                transform=ax.get_xaxis_transform(),
                fontsize=8,
                va="top",
                color="0.35",
            )


def _time_markers(
    ax: Axes, data: RunData, *, labels: bool, min_gap_frac: float = LABEL_MIN_GAP_PANEL
) -> None:
    span = float(data.t_s[-1] - data.t_s[0]) if data.t_s.size else 0.0
    _arrival_lines(ax, data.arrivals, span, min_gap_frac, labels=labels)
    for k, (a, b) in enumerate(_lost_intervals(data)):
        ax.axvspan(a, b, **LOST_SHADE, label="link/pose lost" if k == 0 and labels else None)
    for k, (a, b) in enumerate(data.pauses):
        label = "paused by the crew" if k == 0 and labels else None
        ax.axvspan(a, b, color=CREW_COLOR, alpha=0.12, label=label)
    if data.fault_t_s is not None:
        ax.axvline(
            data.fault_t_s,
            color=data.end_color,
            linewidth=2.0,
            label=data.fault_label() if labels else None,
        )


def legend_outside(*axes: Axes, below: bool = False) -> None:
    """One legend for ``axes``, outside the data: right of the axes, or ``below`` them (the
    overview's cells, whose right side holds a twin y axis)."""
    handles: list[Any] = []
    names: list[str] = []
    for ax in axes:
        h, n = ax.get_legend_handles_labels()
        handles += h
        names += n
    if not handles:
        return
    if below:
        axes[0].legend(
            handles,
            names,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.16),
            ncol=3,
            fontsize=7,
            frameon=False,
        )
    else:
        axes[0].legend(handles, names, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)


def _wall_axis(ax: Axes, data: RunData) -> None:
    """The wall clock as a second time axis on top (only when the main axis is autopilot)."""
    if not data.on_autopilot_clock:
        return
    sec = ax.secondary_xaxis("top", functions=(data.wall_at, data.axis_at_wall))
    sec.set_xlabel("wall time (s)", fontsize=8)
    sec.tick_params(labelsize=7)


# ---------------------------------------------------------------------------------------------
# Panels: each draws on axes it is given (a panel figure or a cell of the overview)


def _draw_driven(ax: Axes, data: RunData, x: Array, y: Array) -> None:
    """The driven path, each stretch in its motion mode's colour and the legend by mode
    ("driven in roll"; a media map or the ground check changes it on the way)."""
    modes = data.cols.get("motion_mode")
    known = set() if modes is None else {str(m) for m in modes} & set(MODE_COLORS)
    if modes is None or not known:
        ax.plot(x, y, "-", color="tab:blue", linewidth=1.5, label="driven")
        return
    labelled: set[str] = set()
    start = 0
    for k in range(1, len(modes) + 1):
        if k < len(modes) and modes[k] == modes[start]:
            continue
        mode = str(modes[start])
        end = min(k + 1, len(modes))  # joined to the next stretch's first point
        label = None if mode in labelled else f"driven in {mode}"
        labelled.add(mode)
        color = MODE_COLORS.get(mode, "tab:gray")
        ax.plot(x[start:end], y[start:end], "-", color=color, linewidth=1.5, label=label)
        start = k


def draw_trajectory(ax: Axes, data: RunData, *, overview: bool = False) -> None:
    """(a) driven path vs planned path, mission frame, equal axes."""
    x, y = data.col("x_m"), data.col("y_m")
    if data.waypoints and data.path_start is not None:
        px = [data.path_start[0]] + [w[0] for w in data.waypoints]
        py = [data.path_start[1]] + [w[1] for w in data.waypoints]
        ax.plot(px, py, "--", color="0.5", linewidth=1.2, label="planned path")
    labels = data.labels or [str(i + 1) for i in range(len(data.waypoints))]
    first_wp = first_via = True
    for (wx, wy, tol), text in zip(data.waypoints, labels, strict=True):
        if not text:  # a via point the planner inserted: not one of the operator's waypoints
            ax.plot(wx, wy, ".", color="tab:gray", markersize=5,
                    label="via point (planned)" if first_via else None)  # fmt: skip
            first_via = False
            continue
        ax.add_patch(Circle((wx, wy), tol, fill=False, linestyle=":", color="tab:green"))
        ax.plot(
            wx,
            wy,
            "o",
            color="tab:green",
            markersize=6,
            label="waypoint (tolerance circle)" if first_wp else None,
        )
        first_wp = False
    points = [(w[0], w[1]) for w in data.waypoints]
    path = points if data.path_start is None else [data.path_start, *points]
    offsets = label_offsets_pt(path)[len(path) - len(points) :]
    at = {xy: off for xy, off in zip(points, offsets, strict=True)}
    for text, xy in waypoint_labels(points, labels=labels):
        label_waypoint(ax, text, xy, at[xy], fontsize=9, color="darkgreen", weight="bold")
    _draw_driven(ax, data, x, y)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.any():
        ax.plot(x[ok][0], y[ok][0], "s", color="black", markersize=7, label="start")
        ax.plot(x[ok][-1], y[ok][-1], "^", color="tab:blue", markersize=8, label="end")
    k = data.fault_index()
    if k is not None and math.isfinite(float(x[k])) and math.isfinite(float(y[k])):
        marker = "o" if crew_ending(data.fault) else "X"  # the crew's ending is no ✖
        ax.plot(x[k], y[k], marker, color=data.end_color, markersize=12, label=data.fault_label())
    if data.media is not None:  # the ground under the track, the view kept on the flight
        draw_media(ax, data.media)
        keep_view(ax, [*x, *(w[0] for w in data.waypoints)], [*y, *(w[1] for w in data.waypoints)])
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(data.axis_labels[0])
    ax.set_ylabel(data.axis_labels[1])
    ax.grid(True, alpha=0.3)
    legend_outside(ax, below=overview)


def draw_position(top: Axes, bottom: Axes, data: RunData, *, twin: bool = False) -> None:
    """(b) x, y (m) and yaw (deg) against time."""
    x_label, y_label = position_legend(data.axis_labels)
    top.plot(data.t_s, data.col("x_m"), label=x_label, color="tab:blue")
    top.plot(data.t_s, data.col("y_m"), label=y_label, color="tab:orange")
    bottom.plot(data.t_s, _unwrap_deg(data.col("yaw_rad")), label="yaw (deg)", color="tab:purple")
    top.set_ylabel("position (m)")
    bottom.set_ylabel("yaw, CCW, unwrapped (deg)")
    _finish_time_axes(top, bottom, data, twin=twin)


def draw_velocity(top: Axes, bottom: Axes, data: RunData, *, twin: bool = False) -> None:
    """(c) commanded body velocities and measured speed."""
    vx, vy = data.col("vx_cmd_mps"), data.col("vy_cmd_mps")
    # the measured speed first, broad and light, under the commands: a command the ground
    # delivered in full shows as a thin line inside the broad one, not hidden beneath it
    top.plot(data.t_s, data.col("speed_meas_mps"), label="speed measured (m/s)",
             color="tab:green", linewidth=3.0, alpha=0.45, zorder=1.5)  # fmt: skip
    top.plot(data.t_s, vx, label="v_x cmd (m/s)", color="tab:blue", linewidth=1.2, zorder=3)
    top.plot(data.t_s, vy, label="v_y cmd (m/s)", color="tab:orange", linewidth=1.2, zorder=3)
    top.plot(data.t_s, np.hypot(vx, vy), "--", label="|v| cmd (m/s)", color="black",
             linewidth=1.0, zorder=3.5)  # fmt: skip
    bottom.plot(data.t_s, data.col("wz_cmd_radps"), label="ω_z cmd (rad/s)", color="tab:purple")
    top.set_ylabel("linear velocity (m/s)")
    bottom.set_ylabel("yaw rate (rad/s)")
    _finish_time_axes(top, bottom, data, twin=twin)


def draw_errors(top: Axes, bottom: Axes, data: RunData, *, twin: bool = False) -> None:
    """(d) distance and cross-track errors (m), heading error (deg)."""
    top.plot(data.t_s, data.col("distance_error_m"), label="distance to target (m)")
    top.plot(data.t_s, data.col("cross_track_m"), label="cross-track (m)", color="tab:orange")
    bottom.plot(
        data.t_s,
        np.degrees(data.col("heading_error_rad")),
        color="tab:purple",
        label="heading error (deg)",
    )
    top.set_ylabel("error (m)")
    bottom.set_ylabel("heading error (deg)")
    _finish_time_axes(top, bottom, data, twin=twin)


def draw_scrolls(ax: Axes, data: RunData, *, overview: bool = False) -> None:
    """(e) scroll commands, % of max RPM (thesis: 'wheel power')."""
    for i in range(4):
        ax.plot(
            data.t_s,
            100.0 * data.col(f"scroll{i + 1}"),
            SCROLL_STYLES[i],
            color=SCROLL_COLORS[i],
            label=f"scroll {i + 1}",
        )
    if data.clamp_pct is not None:
        for sign in (1.0, -1.0):
            ax.axhline(
                sign * data.clamp_pct,
                color="0.5",
                linestyle="--",
                linewidth=0.8,
                label="output clamp" if sign > 0 else None,
            )
    ax.set_ylabel("scroll command (% of max RPM)")
    _finish_time_axes(ax, None, data, overview=overview)


def draw_cross_track_along(ax: Axes, data: RunData) -> None:
    """(f) cross-track error (m, + left of the leg) against the distance travelled (m)."""
    fresh = data.cols.get("pose_fresh")
    along = distance_along_m(
        data.col("x_m"),
        data.col("y_m"),
        None if fresh is None else np.asarray(fresh, dtype=bool),
    )
    xt = data.col("cross_track_m")
    ok = np.isfinite(along) & np.isfinite(xt)
    label = "cross-track (m)"
    if ok.any():
        rms = float(np.sqrt(np.mean(xt[ok] ** 2)))
        label = f"cross-track (m): rms {rms:.2f}, max |{float(np.max(np.abs(xt[ok]))):.2f}|"
    ax.plot(along[ok], xt[ok], color="tab:orange", linewidth=1.3, label=label)
    ax.axhline(0.0, color="0.3", linewidth=0.8)

    def along_at(t_s: float) -> float | None:
        """Distance at the last good row at or before ``t_s``."""
        k = int(np.searchsorted(data.t_s, t_s, side="right")) - 1
        good = np.flatnonzero(np.isfinite(along[: max(k, 0) + 1]))
        return float(along[good[-1]]) if good.size else None

    marks = [(number, d) for number, t in data.arrivals if (d := along_at(t)) is not None]
    span = float(np.nanmax(along)) if ok.any() else 0.0
    _arrival_lines(ax, marks, span, LABEL_MIN_GAP_PANEL, labels=True)
    if data.fault_t_s is not None and (d_fault := along_at(data.fault_t_s)) is not None:
        ax.axvline(d_fault, color=data.end_color, linewidth=2.0, label=data.fault_label())
    ax.set_xlabel("distance travelled along the path (m)")
    ax.set_ylabel("cross-track error, + left of the leg (m)")
    ax.grid(True, alpha=0.3)
    legend_outside(ax)


def _finish_time_axes(
    top: Axes, bottom: Axes | None, data: RunData, *, twin: bool = False, overview: bool = False
) -> None:
    """Markers, grids, clock-named time labels and legends outside the data.

    ``twin``: ``bottom`` is ``top.twinx()`` (the overview's cells); else it is a second row.
    ``overview``: a cell of the overview (denser labels gap, legend below the cell).
    """
    gap = LABEL_MIN_GAP_OVERVIEW if overview or twin else LABEL_MIN_GAP_PANEL
    _time_markers(top, data, labels=True, min_gap_frac=gap)
    _wall_axis(top, data)
    if bottom is not None and not twin:
        _time_markers(bottom, data, labels=False)
        bottom.grid(True, alpha=0.3)
        bottom.set_xlabel(data.time_label)
        legend_outside(bottom)
        legend_outside(top)
    else:
        top.set_xlabel(data.time_label)
        if bottom is not None:
            legend_outside(top, bottom, below=True)
        else:
            legend_outside(top, below=overview)
    top.grid(True, alpha=0.3)


# ---------------------------------------------------------------------------------------------
# Figures


def _title(data: RunData, panel: str) -> str:
    """The mission, the modes it actually flew (not the file's nominal mode), the panel."""
    modes = data.modes_text
    mode = f" — {modes}" if modes else ""
    note = f" ({'; '.join(data.notes)})" if data.notes else ""
    return f"{data.name}{mode} — {panel}{note}"


def _panel_figure(data: RunData, key: str) -> Figure:
    fig = Figure(figsize=PANEL_SIZE_IN, dpi=DPI, layout="constrained")
    titles = {
        "a": "(a) trajectory followed",
        "b": "(b) position with time",
        "c": "(c) velocity with time",
        "d": "(d) errors with time",
        "e": "(e) scroll commands (wheel power)",
        "f": "(f) cross-track error along the path",
    }
    if key == "a":
        draw_trajectory(fig.add_subplot(), data)
    elif key == "f":
        draw_cross_track_along(fig.add_subplot(), data)
    elif key == "e":
        draw_scrolls(fig.add_subplot(), data)
    else:
        top, bottom = fig.subplots(2, 1, sharex=True)
        {"b": draw_position, "c": draw_velocity, "d": draw_errors}[key](top, bottom, data)
    fig.suptitle(_title(data, titles[key]))
    return fig


def _summary_text(data: RunData) -> str:
    s = data.summary
    if s is None:
        return "no summary.json (run did not finish cleanly)"

    def num(v: float | None, unit: str) -> str:
        return "-" if v is None else f"{v:.2f} {unit}"

    lines = [
        f"mission   {s.mission_name} ({data.modes_text or s.mode})",
        f"result    {result_word(s.completed, s.fault)}  exit {s.exit_code}",
        f"{'ended' if crew_ending(s.fault) else 'fault'}     "
        f"{textwrap.shorten(s.fault or '-', FAULT_LABEL_MAX_CHARS)}",
        f"waypoints {s.waypoints_reached}/{s.waypoints_total}"
        + ("" if s.items_total is None else f" as flown (items 1–{s.items_total})"),
        f"flight    {_flight_time_text(s)}",
        f"path      {s.path_length_m:.1f} m",
        f"x-track   rms {num(s.cross_track_rms_m, 'm')}  max {num(s.cross_track_max_m, 'm')}",
        f"final err {num(s.final_error_m, 'm')}",
        f"helixd    {s.helixd_version}",
    ]
    return "\n".join(lines)


def _flight_time_text(s: RunSummary) -> str:
    wall = "-" if s.duration_mono_s is None else f"{s.duration_mono_s:.1f} s wall"
    if s.duration_clock != "autopilot":
        return f"{wall} (autopilot rebooted)"
    return f"{s.duration_s:.1f} s autopilot / {wall}"


def _overview_figure(data: RunData) -> Figure:
    fig = Figure(figsize=OVERVIEW_SIZE_IN, dpi=DPI, layout="constrained")
    grid = fig.subplots(2, 3)
    draw_trajectory(grid[0][0], data, overview=True)
    grid[0][0].set_title("(a) trajectory")
    for ax, draw, title in (
        (grid[0][1], draw_position, "(b) position / yaw"),
        (grid[0][2], draw_velocity, "(c) velocity"),
        (grid[1][0], draw_errors, "(d) errors"),
    ):
        draw(ax, ax.twinx(), data, twin=True)
        ax.set_title(title)
    draw_scrolls(grid[1][1], data, overview=True)
    grid[1][1].set_title("(e) scroll commands")
    text_ax = grid[1][2]
    text_ax.axis("off")
    text_ax.text(
        0.02,
        0.98,
        _summary_text(data),
        va="top",
        family="monospace",
        fontsize=11,
        color=data.end_color if data.fault else "black",
        transform=text_ax.transAxes,
    )
    fig.suptitle(_title(data, "overview"))
    return fig


def render_run(run_dir: Path, out_dir: Path | None = None) -> list[Path]:
    """Render every panel and the overview as PNGs; returns the files written.

    ``out_dir`` defaults to ``<run_dir>/plots``. Raises PlotError when there is nothing to plot.
    """
    data = load_run(run_dir)
    out = out_dir if out_dir is not None else run_dir / PLOTS_DIR
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for key, name in PANEL_FILES.items():
        path = out / name
        declutter_waypoint_labels(_panel_figure(data, key)).savefig(path, dpi=DPI)
        written.append(path)
    path = out / OVERVIEW_FILE
    declutter_waypoint_labels(_overview_figure(data)).savefig(path, dpi=DPI)
    written.append(path)
    log.info("plots_written", run_dir=str(run_dir), out_dir=str(out), files=len(written))
    return written


__all__ = [
    "DPI",
    "OVERVIEW_SIZE_PX",
    "PANEL_FILES",
    "PANEL_SIZE_IN",
    "PANEL_SIZE_PX",
    "declutter_waypoint_labels",
    "distance_along_m",
    "label_offsets_pt",
    "label_waypoint",
    "legend_outside",
    "render_run",
    "sparse_label_mask",
    "waypoint_labels",
]
