"""Gridding a survey's readings (helixd/planning/depth_grid.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon, box

from helixd.planning import depth_grid
from helixd.planning.depth_grid import (
    DepthGrid,
    GridError,
    GridFrame,
    cells_passed,
    grid_depths,
    grid_errors,
    hole_legs,
    hole_waypoints,
)


def transects(
    spacing_m: float, length_m: float, step_m: float = 0.2
) -> tuple[np.ndarray, np.ndarray]:
    """North-south lines ``spacing_m`` apart over a ``length_m`` square, a reading every
    ``step_m``."""
    easts = np.arange(spacing_m / 2, length_m, spacing_m)
    norths = np.arange(0.0, length_m, step_m)
    e, n = np.meshgrid(easts, norths)
    return n.ravel(), e.ravel()


def test_a_sloping_plane_is_gridded_exactly_where_covered() -> None:
    n, e = transects(2.0, 20.0)
    z = 1.0 + 0.05 * n + 0.1 * e
    grid = grid_depths(n, e, z, 2.0, box(0.0, 0.0, 20.0, 20.0))
    assert grid.frame.rows == grid.frame.cols == 10
    assert grid.coverage == 1.0 and not grid.holes.any()
    cn, ce = grid.frame.centres()
    truth = 1.0 + 0.05 * cn + 0.1 * ce
    _rms, max_abs, cells = grid_errors(grid, truth)
    # the thin-plate spline reproduces a plane exactly, the edge cells beyond the last
    # transect included
    assert cells == 100 and max_abs < 1e-6
    assert (grid.count[grid.covered] >= 10).all()
    assert np.nanmax(grid.spread_m) < 0.1  # within a cell the plane varies by ±0.1 m


def test_noise_averages_down_in_the_block_means() -> None:
    rng = np.random.default_rng(0)
    n, e = transects(2.0, 20.0, step_m=0.05)
    z = np.full(n.shape, 2.0) + rng.normal(0.0, 0.025, n.shape)
    grid = grid_depths(n, e, z, 2.0, box(0.0, 0.0, 20.0, 20.0))
    rms, _, _ = grid_errors(grid, np.full(grid.depth_m.shape, 2.0))
    assert rms < 0.01  # 0.025 m noise, ~40 readings a cell
    assert np.nanmedian(grid.spread_m) == pytest.approx(0.025, rel=0.2)


def test_cells_without_readings_are_holes_and_the_legs_pass_each() -> None:
    n, e = transects(2.0, 20.0)
    keep = ~((n > 7.9) & (n < 11.9) & (e > 10.0))  # a gap: rows 4 and 5, east half
    grid = grid_depths(n[keep], e[keep], np.ones(keep.sum()), 2.0, box(0.0, 0.0, 20.0, 20.0))
    assert grid.holes.sum() == 10 and grid.coverage == pytest.approx(0.9)
    legs = hole_legs(grid)
    assert [(leg.row, leg.cells) for leg in legs] == [(4, 5), (5, 5)]
    assert legs[0].start[1] < legs[0].end[1] and legs[1].start[1] > legs[1].end[1]  # boustrophedon
    path = hole_waypoints(legs)
    assert len(path) == 4
    passed = cells_passed(grid, path, 1.0)
    assert (passed | ~grid.holes).all()


def test_cells_outside_the_area_are_not_holes() -> None:
    n, e = transects(2.0, 10.0)
    triangle = Polygon([(0.0, 0.0), (10.0, 0.0), (0.0, 10.0)])
    grid = grid_depths(n, e, np.ones(n.size), 2.0, triangle)
    cn, ce = grid.frame.centres()
    assert (grid.in_area == (ce + cn < 10.0)).all()
    assert grid.coverage == 1.0


def test_without_an_area_the_readings_hull_is_the_area_and_bad_input_is_refused() -> None:
    n, e = transects(2.0, 10.0)
    grid = grid_depths(n, e, np.ones(n.size), 2.0)
    assert grid.coverage > 0.9
    with pytest.raises(GridError):
        grid_depths([0.0, 1.0], [0.0, 1.0], [1.0, 1.0], 2.0)  # too few for a hull
    with pytest.raises(GridError):
        grid_depths(n, e, np.ones(n.size), 0.0)
    with pytest.raises(GridError):
        grid_depths(n, e, np.ones(n.size), 0.001)  # far too many cells
    # NaN readings are left out, never gridded
    z = np.ones(n.size)
    z[::2] = math.nan
    assert grid_depths(n, e, z, 2.0).samples == n.size - (n.size + 1) // 2


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.booleans(), min_size=6, max_size=6), min_size=5, max_size=5))
def test_the_holes_path_passes_every_hole_for_any_pattern(mask: list[list[bool]]) -> None:
    holes = np.array(mask, dtype=bool)
    frame = GridFrame(0.0, 0.0, 1.0, 5, 6)
    count = np.where(holes, 0, 3).astype(np.int64)
    nan = np.full(holes.shape, np.nan)
    grid = DepthGrid(frame, nan, count, nan, nan, np.ones(holes.shape, dtype=bool), 0)
    path = hole_waypoints(hole_legs(grid))
    passed = cells_passed(grid, path, 0.5)
    assert (passed | ~holes).all()
    assert len(path) <= 2 * int(holes.sum())


def test_a_curved_bottom_is_closer_than_linear_between_transects_and_local_splines_agree(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A bowl (curvature 0.02 /m², as the example pond's) sampled 2 m apart: within a few mm
    at every covered centre; the local splines (beyond GLOBAL_SPLINE_MAX block means) give
    the same grid within a millimetre."""
    n, e = transects(2.0, 20.0)
    z = 2.0 - 0.01 * ((n - 10.0) ** 2 + (e - 10.0) ** 2)
    area = box(0.0, 0.0, 20.0, 20.0)
    grid = grid_depths(n, e, z, 2.0, area)
    cn, ce = grid.frame.centres()
    truth = 2.0 - 0.01 * ((cn - 10.0) ** 2 + (ce - 10.0) ** 2)
    rms, max_abs, _ = grid_errors(grid, truth)
    assert rms < 0.005 and max_abs < 0.01  # linear: h²/8 · 0.02 = 0.01 between transects
    monkeypatch.setattr(depth_grid, "GLOBAL_SPLINE_MAX", 10)
    local = grid_depths(n, e, z, 2.0, area)
    assert np.nanmax(np.abs(local.depth_m - grid.depth_m)) < 1e-3


def test_block_means_on_one_line_give_no_spline_and_keep_their_means() -> None:
    n = np.arange(0.0, 10.0, 0.25)
    e = np.full(n.shape, 1.0)  # one transect: every block mean on the line east = 1
    grid = grid_depths(n, e, 1.0 + 0.1 * n, 2.0, box(0.0, 0.0, 2.0, 10.0))
    assert np.allclose(grid.depth_m[grid.covered], grid.mean_m[grid.covered])
    assert np.isfinite(grid.depth_m[grid.covered]).all()
