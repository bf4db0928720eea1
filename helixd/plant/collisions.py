"""Obstacles the simulated rover can run into: keep-out polygons and circles in local NED.

A contact is what happens in a pond: the rover's body (a disc of ``contact_radius_m``, by
default half its width, ``vehicle.ly_m / 2 + scroll_radius_m``) touches the pontoon and stops
there — the step that would move it closer is refused, its translation is zeroed, it may still
turn. That is all the simulator does about it on the wire, because that is all ArduPilot does:
Rover's only collision detector, ``crash_check()`` (Rover/crash_check.cpp, FS_CRASH_CHECK), runs
only in autopilot modes (AUTO, GUIDED, …) and returns at once in MANUAL, HOLD and ACRO, so while
helixd drives the scrolls through RC overrides in MANUAL no "Crash: Going to HOLD" STATUSTEXT
is ever sent. The fault is reported by the rover stopping: helixd's stall watchdog
(``safety.stall``: commanded speed, no measured speed) fires and the daemon stops the scrolls,
releases the overrides and asks for HOLD. For tests the simulator logs a ``contact`` history
event (not on the wire) with where it happened.

A map (``helixd run --sim --map``) reaches the simulator as an :class:`ObstacleRaster`: the
map_server image's **occupied** cells (unknown cells are not solid; only the planner treats them
as blocked). Each physics step looks up one cell of a precomputed "near" mask (occupied grown by
the contact reach); only near a wall is a small window of cells measured, so a step costs the
same on a 10 m or a 2 km map.

Pure: numbers in, numbers out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Annotated, Any

import numpy as np
import numpy.typing as npt
from pydantic import AfterValidator, Field, InstanceOf, PrivateAttr

from helixd.config.mission import KeepOutCircleConfig
from helixd.files.models import InputModel
from helixd.plant.state import PhysicsState

PointNE = tuple[float, float]
CONTACT_RELEASE_M = 0.05  # a contact ends once the body is this far clear of the obstacle


def _polygons(
    value: tuple[tuple[PointNE, ...], ...],
) -> tuple[tuple[PointNE, ...], ...]:
    for i, poly in enumerate(value):
        if len(poly) < 3:
            raise ValueError(f"polygon {i}: needs at least 3 (north_m, east_m) vertices")
        if not all(math.isfinite(n) and math.isfinite(e) for n, e in poly):
            raise ValueError(f"polygon {i}: every vertex must be finite")
    return value


RASTER_SLACK_M = 0.5  # raster distances are measured up to contact_radius_m + this; inf beyond
MAX_RASTER_CELLS = 64_000_000


@dataclass(frozen=True, eq=False)
class ObstacleRaster:
    """Solid cells on a north/east grid: cell (row, col) covers north ∈ [n0 + row·h, n0 +
    (row+1)·h) and east ∈ [e0 + col·h, …), rows northwards (the planning grid's convention)."""

    origin_north_m: float
    origin_east_m: float
    resolution_m: float
    occupied: npt.NDArray[np.bool_]  # [row (north), col (east)]

    def __post_init__(self) -> None:
        vals = (self.origin_north_m, self.origin_east_m, self.resolution_m)
        if not all(isinstance(v, int | float) and math.isfinite(v) for v in vals):
            raise ValueError("raster origin and resolution must be finite numbers")
        if not 0.001 <= self.resolution_m <= 100.0:
            raise ValueError(f"raster resolution {self.resolution_m} m outside 0.001..100")
        occ = self.occupied
        if not isinstance(occ, np.ndarray) or occ.ndim != 2 or occ.dtype != np.bool_:
            raise ValueError("raster occupied must be a 2-D bool array")
        if not 0 < occ.size <= MAX_RASTER_CELLS:
            raise ValueError(f"raster has {occ.size} cells, allowed 1..{MAX_RASTER_CELLS}")

    def cell_of(self, north_m: float, east_m: float) -> tuple[int, int]:
        h = self.resolution_m
        return (
            math.floor((north_m - self.origin_north_m) / h),
            math.floor((east_m - self.origin_east_m) / h),
        )

    def reach_cells(self, reach_m: float) -> int:
        return math.ceil(reach_m / self.resolution_m) + 1

    def near_mask(self, reach_m: float) -> npt.NDArray[np.bool_]:
        """Cells with an occupied cell within ``reach_cells`` rows and columns: a box dilation,
        done as two 1-D running sums (one pass per axis, whatever the map size)."""
        k = self.reach_cells(reach_m)
        return _box_any(_box_any(self.occupied, k, 0), k, 1)

    def distance_m(
        self, north_m: float, east_m: float, reach_m: float, near: npt.NDArray[np.bool_]
    ) -> float:
        """Exact distance from the point to the nearest occupied square within ``reach_m``
        (0 inside one); inf when none is that close or the point is off the raster's reach."""
        row, col = self.cell_of(north_m, east_m)
        rows, cols = self.occupied.shape
        k = self.reach_cells(reach_m)
        if not (-k <= row < rows + k and -k <= col < cols + k):
            return math.inf
        if 0 <= row < rows and 0 <= col < cols and not near[row, col]:
            return math.inf
        ra, rb = max(row - k, 0), min(row + k + 1, rows)
        ca, cb = max(col - k, 0), min(col + k + 1, cols)
        if ra >= rb or ca >= cb:
            return math.inf
        rr, cc = np.nonzero(self.occupied[ra:rb, ca:cb])
        if rr.size == 0:
            return math.inf
        h = self.resolution_m
        n_lo = self.origin_north_m + (rr + ra) * h
        e_lo = self.origin_east_m + (cc + ca) * h
        dn = np.maximum(np.maximum(n_lo - north_m, north_m - (n_lo + h)), 0.0)
        de = np.maximum(np.maximum(e_lo - east_m, east_m - (e_lo + h)), 0.0)
        d = float(np.sqrt(dn * dn + de * de).min())
        return d if d <= reach_m else math.inf


def _box_any(mask: npt.NDArray[np.bool_], k: int, axis: int) -> npt.NDArray[np.bool_]:
    """True where ``mask`` has a True within ``k`` cells along ``axis``."""
    m = np.moveaxis(mask, axis, 0)
    n = m.shape[0]
    run = np.zeros((n + 1, *m.shape[1:]), dtype=np.int32)
    np.cumsum(m, axis=0, dtype=np.int32, out=run[1:])
    idx = np.arange(n)
    hi = np.minimum(idx + k + 1, n)
    lo = np.maximum(idx - k, 0)
    out = (run[hi] - run[lo]) > 0
    return np.asarray(np.moveaxis(out, 0, axis), dtype=np.bool_)


class SimObstacles(InputModel):
    polygons_ne_m: Annotated[tuple[tuple[PointNE, ...], ...], AfterValidator(_polygons)] = Field(
        (), max_length=1000, description="solid polygons, (north_m, east_m) vertices"
    )
    circles: tuple[KeepOutCircleConfig, ...] = Field(
        (), max_length=10_000, description="solid discs (north_m, east_m, radius_m)"
    )
    contact_radius_m: float = Field(
        0.429,
        gt=0.0,
        le=5.0,
        description="rover body radius for contact: half-width ly/2 + scroll radius (m)",
    )

    raster: InstanceOf[ObstacleRaster] | None = Field(
        None, description="solid cells of a map (set in code by run --sim --map; not in YAML)"
    )
    _raster_near: Any = PrivateAttr(None)

    def model_post_init(self, context: Any, /) -> None:
        if self.raster is not None:
            self._raster_near = self.raster.near_mask(self.raster_reach_m)

    @property
    def raster_reach_m(self) -> float:
        return self.contact_radius_m + RASTER_SLACK_M

    @property
    def empty(self) -> bool:
        return not (self.polygons_ne_m or self.circles or self.raster is not None)


def _inside(poly: Sequence[PointNE], n: float, e: float) -> bool:
    inside = False
    j = len(poly) - 1
    for i in range(len(poly)):
        (ni, ei), (nj, ej) = poly[i], poly[j]
        if (ei > e) != (ej > e) and n < (nj - ni) * (e - ei) / (ej - ei) + ni:
            inside = not inside
        j = i
    return inside


def _segment_distance(n: float, e: float, a: PointNE, b: PointNE) -> float:
    dn, de = b[0] - a[0], b[1] - a[1]
    seg2 = dn * dn + de * de
    t = 0.0 if seg2 == 0.0 else ((n - a[0]) * dn + (e - a[1]) * de) / seg2
    t = min(max(t, 0.0), 1.0)
    return math.hypot(n - a[0] - t * dn, e - a[1] - t * de)


def distance_m(obstacles: SimObstacles, north_m: float, east_m: float) -> float:
    """Distance from the point to the nearest obstacle (0 inside one; inf with none; a map's
    cells count only within ``raster_reach_m``)."""
    best = math.inf
    if obstacles.raster is not None:
        best = obstacles.raster.distance_m(
            north_m, east_m, obstacles.raster_reach_m, obstacles._raster_near
        )
        if best == 0.0:
            return 0.0
    for c in obstacles.circles:
        best = min(best, max(math.hypot(north_m - c.north_m, east_m - c.east_m) - c.radius_m, 0.0))
    for poly in obstacles.polygons_ne_m:
        if _inside(poly, north_m, east_m):
            return 0.0
        for i in range(len(poly)):
            best = min(best, _segment_distance(north_m, east_m, poly[i], poly[(i + 1) % len(poly)]))
    return best


def constrain(
    obstacles: SimObstacles, before: PhysicsState, after: PhysicsState
) -> tuple[PhysicsState, bool]:
    """``after`` unless its body touches an obstacle and the step brought it closer: then the
    rover stays where it was (turning allowed), translation zeroed. Returns (state, contact)."""
    if obstacles.empty:
        return after, False
    d_after = distance_m(obstacles, after.north_m, after.east_m)
    if d_after >= obstacles.contact_radius_m:
        return after, False
    d_before = distance_m(obstacles, before.north_m, before.east_m)
    if d_after > d_before:  # moving away from the obstacle it touches: let it go
        return after, True
    blocked = replace(
        after,
        north_m=before.north_m,
        east_m=before.east_m,
        vx_body_mps=0.0,
        vy_body_mps=0.0,
        odometer_m=before.odometer_m,
    )
    return blocked, True


def contact_step(
    obstacles: SimObstacles, before: PhysicsState, after: PhysicsState, was_in_contact: bool
) -> tuple[PhysicsState, bool, tuple[str, dict[str, float]] | None]:
    """:func:`constrain` plus the history event (kind, details) when a contact starts or
    ends."""
    state, contact = constrain(obstacles, before, after)
    if was_in_contact and not contact:  # still pressed against it: no flicker of events
        gap = distance_m(obstacles, state.north_m, state.east_m)
        contact = gap < obstacles.contact_radius_m + CONTACT_RELEASE_M
    event: tuple[str, dict[str, float]] | None = None
    if contact and not was_in_contact:
        event = (
            "contact",
            {
                "north_m": round(state.north_m, 3),
                "east_m": round(state.east_m, 3),
                "distance_m": round(distance_m(obstacles, state.north_m, state.east_m), 3),
            },
        )
    elif was_in_contact and not contact:
        event = ("contact_end", {"north_m": state.north_m, "east_m": state.east_m})
    return state, contact, event
