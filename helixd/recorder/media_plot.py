"""The ground under the plots: a media map's areas drawn beneath a flown track or a planned
path, and the motion modes a run actually flew.

A flight that follows a media map logs it (the ``media_plan`` event: the map's file and the
rover's start pose), so ``helixd plot`` places the map's areas exactly as the flight placed
them: a lat/lon map around the run's EKF origin, a ``start``-frame mission from the pose it
started at. ``helixd check --plot`` draws them under the planned stretches, each in its mode's
colour.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import structlog
from matplotlib.axes import Axes
from matplotlib.patches import PathPatch
from matplotlib.path import Path as MplPath

from helixd.base.frames import MissionFrame, NedPose
from helixd.base.media import MediaMapNe, Medium
from helixd.files.media import MediaMapError, read_media_map

log = structlog.get_logger(__name__)

# light fills, so the track and the plan stay readable on top
MEDIUM_COLORS: dict[Medium, str] = {
    Medium.HARD: "#d9d9d9",
    Medium.GRASS: "#b8dfa0",
    Medium.SAND: "#eedc9a",
    Medium.MUD: "#b59470",
    Medium.WATER: "#9ecae1",
}
MEDIA_ALPHA = 0.55
MODE_COLORS = {"roll": "tab:blue", "scroll": "tab:orange", "omni": "tab:purple"}
MEDIA_EVENT = "media_plan"
# the media map may reach far beyond the flight: shown this far around the track and the plan
MEDIA_VIEW_MARGIN_FRACTION = 0.15
MEDIA_VIEW_MARGIN_MIN_M = 3.0


@dataclass(frozen=True)
class PlacedMedia:
    """A media map in north/east metres and the mission frame it is drawn in."""

    areas: MediaMapNe
    frame: MissionFrame

    def xy(self, ring: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
        """A ring of (north, east) in the mission frame's (x, y)."""
        out = []
        for north, east in ring:
            p = self.frame.to_mission(NedPose(north, east, 0.0))
            out.append((p.x_m, p.y_m))
        return out


def run_media(
    events: Sequence[dict[str, Any]], origin_latlon_deg: tuple[float, float] | None
) -> tuple[PlacedMedia | None, str]:
    """The media map a run followed, placed as the flight placed it, from its ``media_plan``
    event; (None, why) when it had none or the map cannot be read again (``why`` empty: no
    map)."""
    event = next((e for e in events if e.get("event") == MEDIA_EVENT), None)
    if event is None or not event.get("media_map"):
        return None, ""
    path = Path(str(event["media_map"]))
    try:
        media = read_media_map(path)
        placed = media.to_ne(origin_latlon_deg, fallback=Medium.HARD)
    except (MediaMapError, ValueError, OSError) as exc:
        log.warning("plot_media_unavailable", path=str(path), error=str(exc))
        return None, f"media map {path.name} unavailable"
    start = [event.get(k) for k in ("start_north_m", "start_east_m", "start_yaw_ned_rad")]
    frame = MissionFrame.enu()
    if event.get("frame") == "start" and all(isinstance(v, int | float) for v in start):
        frame = MissionFrame.start_at(NedPose(*(float(v) for v in start)))  # type: ignore[arg-type]
    return PlacedMedia(placed, frame), ""


def _ring_path(points: list[tuple[float, float]], clockwise: bool) -> MplPath:
    """One closed ring, turned to ``clockwise`` (holes run against their outer ring)."""
    pairs = zip(points, points[1:] + points[:1], strict=True)
    area2 = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in pairs)
    if (area2 < 0) != clockwise:
        points = points[::-1]
    verts = [*points, points[0]]
    codes = [MplPath.MOVETO] + [MplPath.LINETO] * (len(points) - 1) + [MplPath.CLOSEPOLY]
    return MplPath(verts, codes)


def draw_media(ax: Axes, media: PlacedMedia) -> None:
    """Each area of the map under everything else (zorder 0), holes left open, one legend
    entry per medium (and the medium everywhere else). The view is not widened by it."""
    shown: set[Medium] = set()
    for area in media.areas.areas:
        outer = media.xy(area.outer_ne)
        if len(outer) < 3:
            continue
        rings = [_ring_path(outer, clockwise=False)]
        rings += [_ring_path(media.xy(h), clockwise=True) for h in area.holes_ne if len(h) >= 3]
        color = MEDIUM_COLORS.get(area.medium, "0.8")
        first = area.medium not in shown
        shown.add(area.medium)
        ax.add_patch(
            PathPatch(
                MplPath.make_compound_path(*rings),
                facecolor=color,
                edgecolor="0.45",
                linewidth=0.6,
                alpha=MEDIA_ALPHA,
                zorder=0,
                label=f"{area.medium.value} (media map)" if first else None,
            )
        )
    default = media.areas.default_medium
    if default not in shown:
        ax.fill([], [], facecolor="white", edgecolor="0.45", linewidth=0.6,
                label=f"{default.value} elsewhere (media map)")  # fmt: skip


def keep_view(ax: Axes, xs: Sequence[float], ys: Sequence[float]) -> None:
    """Limit the view to the flight (``xs``, ``ys``: the track and the plan) with a margin, so
    a map larger than the flight does not shrink it to a speck."""
    x = np.asarray([v for v in xs if math.isfinite(v)], dtype=np.float64)
    y = np.asarray([v for v in ys if math.isfinite(v)], dtype=np.float64)
    if x.size == 0 or y.size == 0:
        return
    span = max(float(np.ptp(x)), float(np.ptp(y)))
    margin = max(MEDIA_VIEW_MARGIN_MIN_M, MEDIA_VIEW_MARGIN_FRACTION * span)
    corners = np.array([[x.min() - margin, y.min() - margin], [x.max() + margin, y.max() + margin]])
    # the data limits replaced (not the view fixed): an equal aspect may still widen them
    ax.ignore_existing_data_limits = True
    ax.update_datalim(corners)
    ax.autoscale_view()


def flown_modes(
    modes: npt.NDArray[Any] | None, x_m: npt.NDArray[np.float64], y_m: npt.NDArray[np.float64]
) -> str:
    """The motion modes a run flew, by the share of the distance driven in each, largest
    first: ``roll 62 %, scroll 38 %``; one mode: its name; "" when none was recorded."""
    if modes is None or len(modes) == 0:
        return ""
    names = np.asarray([str(m) for m in modes], dtype=object)
    known = [str(m) for m in dict.fromkeys(names) if str(m) in MODE_COLORS]
    if len(known) <= 1:
        return known[0] if known else ""
    step = np.hypot(np.diff(x_m), np.diff(y_m))
    step = np.where(np.isfinite(step), step, 0.0)
    dist = {m: float(step[names[1:] == m].sum()) for m in known}
    total = sum(dist.values())
    if total <= 0.0:
        return ", ".join(known)
    shares = sorted(((d / total, m) for m, d in dist.items()), reverse=True)
    return ", ".join(f"{m} {round(100 * share)} %" for share, m in shares if share >= 0.005)


__all__ = [
    "MEDIUM_COLORS",
    "MODE_COLORS",
    "PlacedMedia",
    "draw_media",
    "flown_modes",
    "keep_view",
    "run_media",
]
