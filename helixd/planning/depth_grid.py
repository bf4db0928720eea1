"""The depth map of a survey: readings gridded, the cells without data, the legs that fill them.

Pure: arrays in, arrays out (no files, no clock). The method is the geoscientist's two steps
(verde's ``BlockReduce`` then ``Spline``; GMT's ``blockmean`` then ``surface``):

1. **block means**: the readings of each ``cell_m`` square cell are reduced to their count,
   mean depth, spread (standard deviation) and mean position
   (:func:`scipy.stats.binned_statistic_2d`), which averages the sonar's noise down by √n and
   gives one datum per cell, so a slow pass does not outweigh a fast one;
2. **a thin-plate (biharmonic) spline** through those block means, each at the mean position
   of its readings, evaluated at the cell centres
   (:class:`scipy.interpolate.RBFInterpolator`, kernel ``thin_plate_spline``; beyond
   :data:`GLOBAL_SPLINE_MAX` block means, each centre from its :data:`SPLINE_NEIGHBOURS`
   nearest). It reproduces a sloping plane exactly, also where a cell's centre lies beyond
   the last transect. Its error inside the survey is the bottom's departure from the spline
   between transects (far below a linear interpolation's h²/8 · |d²z/dx²|) plus the block
   mean's noise (σ/√n) plus the position error times the slope.

A cell gets a value when it is covered or its centre lies inside the block means' hull (the
spline is not extrapolated into the unsurveyed); below three block means not on one line
there is no spline and a covered cell keeps its block mean.

A cell *is covered* when at least one reading fell in it. The *surveyed area* is a polygon
(north/east metres); its cells are the ones whose centre lies in it. The holes of a survey
are its uncovered cells; :func:`hole_legs` joins each row's run of adjacent holes into one
leg through their centres, rows south to north, alternate rows driven the other way, so a
mission through those legs passes the centre of every hole.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.interpolate import RBFInterpolator
from scipy.spatial import Delaunay, QhullError
from scipy.stats import binned_statistic_2d
from shapely import contains_xy
from shapely.geometry import Polygon

Array = npt.NDArray[np.float64]
GLOBAL_SPLINE_MAX = 2000  # block means for one global spline (O(n³)); beyond: local ones
SPLINE_NEIGHBOURS = 64
MIN_CELL_M = 0.1
MAX_CELLS = 4_000_000


class GridError(ValueError):
    """The readings cannot be gridded; ``str()`` says why."""


@dataclass(frozen=True)
class GridFrame:
    """Cells ``cell_m`` square; cell (row i, column j) spans north ``north0_m + i·cell_m`` ..
    ``+cell_m`` and east ``east0_m + j·cell_m`` .. ``+cell_m`` (row 0 is the southmost)."""

    north0_m: float
    east0_m: float
    cell_m: float
    rows: int
    cols: int

    def centres(self) -> tuple[Array, Array]:
        """(north, east) of every cell centre, each shaped (rows, cols)."""
        n = self.north0_m + (np.arange(self.rows) + 0.5) * self.cell_m
        e = self.east0_m + (np.arange(self.cols) + 0.5) * self.cell_m
        north, east = np.meshgrid(n, e, indexing="ij")
        return north, east

    def edges(self) -> tuple[Array, Array]:
        n: Array = self.north0_m + np.arange(self.rows + 1, dtype=np.float64) * self.cell_m
        e: Array = self.east0_m + np.arange(self.cols + 1, dtype=np.float64) * self.cell_m
        return n, e


@dataclass(frozen=True)
class DepthGrid:
    frame: GridFrame
    depth_m: Array  # interpolated at the cell centres; NaN: outside the readings' hull
    count: npt.NDArray[np.int64]  # readings per cell
    mean_m: Array  # block mean per cell (NaN: no reading)
    spread_m: Array  # standard deviation of the cell's readings (NaN: none; 0 for one)
    in_area: npt.NDArray[np.bool_]  # the cell's centre lies in the surveyed area
    samples: int

    @property
    def covered(self) -> npt.NDArray[np.bool_]:
        out: npt.NDArray[np.bool_] = self.count > 0
        return out

    @property
    def holes(self) -> npt.NDArray[np.bool_]:
        """Cells of the surveyed area without a reading."""
        out: npt.NDArray[np.bool_] = self.in_area & ~self.covered
        return out

    @property
    def coverage(self) -> float:
        """Share of the surveyed area's cells with at least one reading (0 without cells)."""
        cells = int(self.in_area.sum())
        return float((self.in_area & self.covered).sum()) / cells if cells else 0.0


def frame_for(
    north_m: Array, east_m: Array, cell_m: float, area: Polygon | None = None
) -> GridFrame:
    """The cells around the readings and the area, aligned on whole multiples of ``cell_m``."""
    if not (math.isfinite(cell_m) and cell_m >= MIN_CELL_M):
        raise GridError(f"cell size {cell_m} m: at least {MIN_CELL_M} m")
    ns, es = [north_m], [east_m]
    if area is not None:
        minx, miny, maxx, maxy = area.bounds  # x east, y north
        ns.append(np.array([miny, maxy]))
        es.append(np.array([minx, maxx]))
    n_all, e_all = np.concatenate(ns), np.concatenate(es)
    if n_all.size == 0:
        raise GridError("no readings and no area")
    n0 = math.floor(float(n_all.min()) / cell_m) * cell_m
    e0 = math.floor(float(e_all.min()) / cell_m) * cell_m
    rows = max(1, math.ceil((float(n_all.max()) - n0) / cell_m - 1e-9))
    cols = max(1, math.ceil((float(e_all.max()) - e0) / cell_m - 1e-9))
    if rows * cols > MAX_CELLS:
        raise GridError(
            f"{rows} x {cols} cells of {cell_m:g} m: more than {MAX_CELLS}; use a larger cell"
        )
    return GridFrame(n0, e0, cell_m, rows, cols)


def grid_depths(
    north_m: Sequence[float] | Array,
    east_m: Sequence[float] | Array,
    depth_m: Sequence[float] | Array,
    cell_m: float,
    area: Polygon | None = None,
) -> DepthGrid:
    """Grid the readings (north, east, depth: metres; non-finite ones are left out) in
    ``cell_m`` cells. ``area``: the surveyed polygon (x east, y north); None: the readings'
    convex hull."""
    n = np.asarray(north_m, dtype=float)
    e = np.asarray(east_m, dtype=float)
    z = np.asarray(depth_m, dtype=float)
    if not n.shape == e.shape == z.shape or n.ndim != 1:
        raise GridError("north, east and depth must be three lists of one length")
    ok = np.isfinite(n) & np.isfinite(e) & np.isfinite(z)
    n, e, z = n[ok], e[ok], z[ok]
    if area is None:
        if n.size < 3:
            raise GridError(f"{n.size} readings: at least 3 without an area")
        hull = Polygon(np.column_stack([e, n])).convex_hull
        area = hull if isinstance(hull, Polygon) and hull.area > 0 else None
    frame = frame_for(n, e, cell_m, area)
    n_edges, e_edges = frame.edges()
    cn, ce = frame.centres()
    in_area = contains_xy(area, ce, cn) if area is not None else np.ones(cn.shape, dtype=bool)
    if n.size == 0:
        empty = np.full(cn.shape, np.nan)
        zeros = np.zeros(cn.shape, dtype=np.int64)
        return DepthGrid(frame, empty, zeros, empty, empty.copy(), in_area, 0)
    bins = [n_edges, e_edges]
    count = binned_statistic_2d(n, e, z, "count", bins=bins).statistic
    mean = binned_statistic_2d(n, e, z, "mean", bins=bins).statistic
    spread = binned_statistic_2d(n, e, z, "std", bins=bins).statistic
    mean_n = binned_statistic_2d(n, e, n, "mean", bins=bins).statistic
    mean_e = binned_statistic_2d(n, e, e, "mean", bins=bins).statistic
    has = count > 0
    spread = np.where(has, spread, np.nan)
    depth = _spline(mean_n[has], mean_e[has], mean[has], cn, ce, has)
    depth = np.where(np.isnan(depth) & has, mean, depth)
    return DepthGrid(frame, depth, count.astype(np.int64), mean, spread, in_area, int(n.size))


def _spline(
    n: Array, e: Array, z: Array, cn: Array, ce: Array, covered: npt.NDArray[np.bool_]
) -> Array:
    """The thin-plate spline through the block means at the centres of the covered cells and
    of the cells inside the block means' hull; NaN elsewhere, and everywhere when three
    block means on no line are not there."""
    out = np.full(cn.shape, np.nan)
    pts = np.column_stack([e, n])
    try:
        hull = Delaunay(pts)
    except (QhullError, ValueError):  # fewer than three, or all on a line
        return out
    centres = np.column_stack([ce.ravel(), cn.ravel()])
    want = (hull.find_simplex(centres) >= 0).reshape(cn.shape) | covered
    neighbours = None if len(z) <= GLOBAL_SPLINE_MAX else SPLINE_NEIGHBOURS
    spline = RBFInterpolator(pts, z, kernel="thin_plate_spline", neighbors=neighbours)
    out[want] = spline(np.column_stack([ce[want], cn[want]]))
    return out


@dataclass(frozen=True, slots=True)
class HoleLeg:
    """A run of adjacent uncovered cells in one row: from its first centre to its last."""

    row: int
    start: tuple[float, float]  # (north_m, east_m)
    end: tuple[float, float]
    cells: int


def hole_legs(grid: DepthGrid) -> list[HoleLeg]:
    """The legs through every hole's centre: each row's runs of adjacent holes, rows south to
    north, every other row driven west, so consecutive legs are near each other."""
    holes = grid.holes
    cn, ce = grid.frame.centres()
    legs: list[HoleLeg] = []
    eastward = True
    for i in range(grid.frame.rows):
        runs: list[HoleLeg] = []
        j = 0
        row = holes[i]
        while j < grid.frame.cols:
            if not row[j]:
                j += 1
                continue
            k = j
            while k + 1 < grid.frame.cols and row[k + 1]:
                k += 1
            runs.append(
                HoleLeg(
                    i,
                    (float(cn[i, j]), float(ce[i, j])),
                    (float(cn[i, k]), float(ce[i, k])),
                    k - j + 1,
                )
            )
            j = k + 1
        if not runs:
            continue
        if not eastward:
            runs = [HoleLeg(r.row, r.end, r.start, r.cells) for r in reversed(runs)]
        legs.extend(runs)
        eastward = not eastward
    return legs


def hole_waypoints(legs: Sequence[HoleLeg]) -> list[tuple[float, float]]:
    """The legs as one path (north, east): a leg of one cell is one waypoint."""
    out: list[tuple[float, float]] = []
    for leg in legs:
        out.append(leg.start)
        if leg.end != leg.start:
            out.append(leg.end)
    return out


def cells_passed(
    grid: DepthGrid, path_ne: Sequence[tuple[float, float]], tolerance_m: float
) -> npt.NDArray[np.bool_]:
    """Which cells' centres lie within ``tolerance_m`` of the path (its waypoints and the
    straight legs between them): how the bench checks that a holes mission covers every
    hole."""
    cn, ce = grid.frame.centres()
    passed = np.zeros(cn.shape, dtype=bool)
    pts = list(path_ne)
    if not pts:
        return passed
    segments = [(pts[0], pts[0]), *itertools.pairwise(pts)]
    for (n1, e1), (n2, e2) in segments:
        dn, de = n2 - n1, e2 - e1
        length2 = dn * dn + de * de
        t = np.zeros(cn.shape) if length2 == 0 else ((cn - n1) * dn + (ce - e1) * de) / length2
        t = np.clip(t, 0.0, 1.0)
        dist = np.hypot(cn - (n1 + t * dn), ce - (e1 + t * de))
        passed |= dist <= tolerance_m
    return passed


def grid_errors(grid: DepthGrid, truth_m: Array) -> tuple[float, float, int]:
    """(RMS, max |error|, cells) of the grid against the true depth at the cell centres, over
    the covered cells of the area where both are known."""
    use = grid.covered & grid.in_area & np.isfinite(grid.depth_m) & np.isfinite(truth_m)
    cells = int(use.sum())
    if not cells:
        return math.nan, math.nan, 0
    err = grid.depth_m[use] - truth_m[use]
    return float(np.sqrt(np.mean(err**2))), float(np.max(np.abs(err))), cells
