"""The plan panels (``helixd check --map … --plot FILE``, ``helixd check --media … --plot
FILE``): the map, its inflation and the planned path; the media map with the path planned
through it, each leg in its mode. Matplotlib's object API on the Agg backend, as
:mod:`helixd.recorder.plots`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # before anything imports pyplot: no display on the rover

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from helixd.planning.media_modes import MediaPlan
from helixd.recorder.media_plot import (
    MODE_COLORS,
    PlacedMedia,
    draw_media,
    keep_view,
)
from helixd.recorder.plots import (
    DPI,
    PANEL_SIZE_IN,
    declutter_waypoint_labels,
    label_offsets_pt,
    label_waypoint,
    legend_outside,
)
from helixd.recorder.run_data import XY

PLAN_BLOCKED_RGBA = (0.15, 0.15, 0.15, 1.0)
PLAN_INFLATED_RGBA = (1.0, 0.55, 0.1, 0.45)
PLAN_MAX_IMAGE_PX = 2000  # larger grids are shown max-pooled down to about this many pixels


def _pooled(mask: npt.NDArray[np.bool_], step: int) -> npt.NDArray[np.bool_]:
    """Any-of ``step`` × ``step`` blocks, so a thin wall never disappears when shrunk."""
    if step <= 1:
        return mask
    rows, cols = mask.shape
    pr, pc = -rows % step, -cols % step
    padded = np.pad(mask, ((0, pr), (0, pc)))
    blocks = padded.reshape(padded.shape[0] // step, step, padded.shape[1] // step, step)
    out: npt.NDArray[np.bool_] = np.asarray(blocks.any(axis=(1, 3)), dtype=np.bool_)
    return out


def draw_route(ax: Axes, route: Any) -> None:
    """East right, north up: obstacles, their inflation, legs and intermediate points."""
    fr = route.grid.frame
    n0, n1, e0, e1 = fr.extent_ne_m()
    step = max(1, math.ceil(max(fr.rows, fr.cols) / PLAN_MAX_IMAGE_PX))
    blocked = _pooled(route.grid.blocked, step)
    inflated = _pooled(route.grid.inflated, step) & ~blocked
    img = np.zeros((*blocked.shape, 4))
    img[inflated] = PLAN_INFLATED_RGBA
    img[blocked] = PLAN_BLOCKED_RGBA
    ax.imshow(img, origin="lower", extent=(e0, e1, n0, n1), interpolation="nearest")
    ax.plot([], [], "s", color=PLAN_BLOCKED_RGBA, label="obstacle")
    ax.plot(
        [], [], "s", color=PLAN_INFLATED_RGBA,
        label=f"inflation ({route.grid.clearance_m:.2f} m)",
    )  # fmt: skip
    line = route.polyline_ne_m()
    if line:
        ax.plot([p[1] for p in line], [p[0] for p in line], "-", color="tab:blue", label="path")
    via = [p for leg in route.legs for p in leg.points_ne_m[1:-1]]
    if via:
        ax.plot([p[1] for p in via], [p[0] for p in via], "o", ms=4, color="tab:blue",
                label="intermediate")  # fmt: skip
    ends = [(leg.points_ne_m[-1][1], leg.points_ne_m[-1][0]) for leg in route.legs]  # (e, n)
    starts = [(route.legs[0].points_ne_m[0][1], route.legs[0].points_ne_m[0][0])] if ends else []
    offsets = label_offsets_pt([*starts, *ends])[len(starts) :]
    for leg, (e, n), off in zip(route.legs, ends, offsets, strict=True):
        ax.plot(e, n, "D", color="tab:green", ms=6)
        label_waypoint(ax, str(leg.to_index + 1), (e, n), off, fontsize=9, color="darkgreen",
                        weight="bold")  # fmt: skip
    if route.legs:
        n, e = route.legs[0].points_ne_m[0]
        ax.plot(e, n, "^", color="black", ms=7, label="start")
    around = getattr(route, "origin_latlon_deg", None)  # a global mission: around waypoint 1
    where = "" if around is None else " of waypoint 1"
    ax.set_xlabel(f"east{where} (m)")
    ax.set_ylabel(f"north{where} (m)")
    ax.set_aspect("equal")
    legend_outside(ax)


def render_route(
    route: Any, out_path: Path, *, title: str = "", media: PlacedMedia | None = None
) -> Path:
    """Draw :func:`draw_route` to ``out_path`` (PNG), over ``media``'s areas when the mission
    follows a media map; returns the path."""
    fig = Figure(figsize=PANEL_SIZE_IN, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    if media is not None:
        draw_media(ax, media)
    draw_route(ax, route)
    if media is not None:
        line = route.polyline_ne_m()
        keep_view(ax, [p[1] for p in line], [p[0] for p in line])
    ax.set_title(f"planned path {title}".strip())
    out_path.parent.mkdir(parents=True, exist_ok=True)
    declutter_waypoint_labels(fig).savefig(out_path, dpi=DPI)
    return out_path


def draw_media_plan(ax: Axes, media: PlacedMedia, plan: MediaPlan, start_xy_m: XY) -> None:
    """The media map's areas, the planned path from ``start_xy_m`` with each leg in its
    mode's colour (the legend by mode), the stops where the mode changes (a turn in place)
    and the operator's waypoints numbered (a local_ned or global plan: x east, y north)."""
    draw_media(ax, media)
    pts = [start_xy_m, *((w.x_m, w.y_m) for w in plan.plan.waypoints)]
    labelled: set[str] = set()
    for k in range(len(plan.plan.waypoints)):
        mode = plan.plan.mode_at(k).value
        label = None if mode in labelled else f"planned in {mode}"
        labelled.add(mode)
        (x0, y0), (x1, y1) = pts[k], pts[k + 1]
        ax.plot([x0, x1], [y0, y1], "-", color=MODE_COLORS.get(mode, "tab:gray"),
                linewidth=2.0, label=label, zorder=3)  # fmt: skip
    stops = [(w.x_m, w.y_m) for w in plan.plan.waypoints if w.media_stop]
    if stops:
        ax.plot([p[0] for p in stops], [p[1] for p in stops], "o", mfc="white", mec="black",
                ms=7, zorder=4, label="change of mode (turn in place)")  # fmt: skip
    own = [(w.x_m, w.y_m) for w in plan.plan.waypoints if not (w.media_stop or w.via)]
    ax.plot([p[0] for p in own], [p[1] for p in own], "D", color="tab:green", ms=6, zorder=4,
            label="waypoint")  # fmt: skip
    offsets = label_offsets_pt([start_xy_m, *own])[1:]
    for n, (xy, off) in enumerate(zip(own, offsets, strict=True), start=1):
        label_waypoint(ax, str(n), xy, off, fontsize=9, color="darkgreen", weight="bold")
    ax.plot(*start_xy_m, "^", color="black", ms=7, label="start (assumed)", zorder=4)
    keep_view(ax, [p[0] for p in pts], [p[1] for p in pts])
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    legend_outside(ax)


def render_media_plan(
    media: PlacedMedia,
    plan: MediaPlan,
    out_path: Path,
    *,
    start_xy_m: XY,
    axis_names: tuple[str, str] = ("east (m)", "north (m)"),
    title: str = "",
) -> Path:
    """Draw :func:`draw_media_plan` to ``out_path`` (PNG), titled by the mission's name and
    the modes planned; returns the path."""
    fig = Figure(figsize=PANEL_SIZE_IN, dpi=DPI, layout="constrained")
    ax = fig.subplots()
    draw_media_plan(ax, media, plan, start_xy_m)
    ax.set_xlabel(axis_names[0])
    ax.set_ylabel(axis_names[1])
    modes = ", ".join(
        dict.fromkeys(plan.plan.mode_at(k).value for k in range(len(plan.plan.waypoints)))
    )
    ax.set_title(f"planned path {title} — {modes}, following the media map".replace("  ", " "))
    out_path.parent.mkdir(parents=True, exist_ok=True)
    declutter_waypoint_labels(fig).savefig(out_path, dpi=DPI)
    return out_path


__all__ = [
    "draw_media_plan",
    "draw_route",
    "render_media_plan",
    "render_route",
]
