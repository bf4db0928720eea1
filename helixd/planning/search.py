"""Shortest 8-connected grid path (no corner cutting) and line-of-sight shortcutting.

Library choice — measured, not assumed (``/tmp``-free reproduction: ``tools/bench_planning.py``
runs the chosen one). 2000 × 2000 grid (200 m at 0.1 m), corner to corner, two maps: "clutter"
(300 random discs, 26 % blocked, A* explores ~10 %) and "walls" (9 berms with gaps at alternate
ends, A* explores ~85 %); x86-64, 2 cores shared with four other busy jobs (load 2.5–3.8):

======================================  ========  ========  ======================================
library (version)                       clutter   walls     correct?
======================================  ========  ========  ======================================
tcod 21.2 ``CustomGraph`` + A* heuristic   843 ms   2818 ms  yes: no corner cutting, octile length
tcod 21.2 ``SimpleGraph``                  603 ms   5243 ms  no: cuts corners (118 / 17 cuts)
pyastar2d 1.1.4                            199 ms   1146 ms  no: cuts corners, Chebyshev cost
                                                             (paths 4–9 % longer); sdist only, no
                                                             wheels for x86-64 or arm64
scikit-image 0.26 ``MCP_Geometric``       4470 ms   3736 ms  no: cuts corners (Dijkstra, no goal
                                                             heuristic)
scipy 1.17 ``csgraph.dijkstra`` (CSR)     5395 ms   9926 ms  yes (graph built in numpy), too slow
networkx 3.6 ``astar_path``             minutes             yes, pure Python: ~4 M node objects
extremitypathfinder 2.7                     —         —      polygons only (visibility graph); a
                                                             raster map would need polygonising
======================================  ========  ========  ======================================

Corner cutting matters: a diagonal step between two free cells whose shared neighbours are
blocked slips between two obstacles through a single point, and the TurtleBot report's 5 × 5
worked example (path length 6) is only a shortest path when that step is forbidden. tcod's
``CustomGraph`` lets each diagonal edge carry a per-node condition, which expresses exactly that
rule, and it runs compiled A* with an admissible octile heuristic. Costs are the integers 70
(straight) and 99 (diagonal): 99/70 = 1.41429 vs √2 = 1.41421, so path lengths are within
0.006 % of the true octile length, and int32 distances cannot overflow before 21 M steps. tcod
ships abi3 wheels for manylinux x86-64 and aarch64.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from helixd.planning.grid import PlanningGrid, segment_is_free
from helixd.planning.obstacles import PointNE

STRAIGHT_COST = 70
DIAGONAL_COST = 99
Cell = tuple[int, int]


def _shifted(free: npt.NDArray[Any], d_row: int, d_col: int) -> npt.NDArray[Any]:
    """out[r, c] = free[r + d_row, c + d_col] (False outside)."""
    rows, cols = free.shape
    out = np.zeros_like(free)
    dst_r = slice(max(-d_row, 0), rows - max(d_row, 0))
    src_r = slice(max(d_row, 0), rows + min(d_row, 0))
    dst_c = slice(max(-d_col, 0), cols - max(d_col, 0))
    src_c = slice(max(d_col, 0), cols + min(d_col, 0))
    out[dst_r, dst_c] = free[src_r, src_c]
    return out


def grid_path(
    free: npt.NDArray[Any], start: Cell, goal: Cell, weight: float = 1.0
) -> list[Cell] | None:
    """Shortest 8-connected path of free cells from ``start`` to ``goal``, both included.

    A diagonal step is allowed only when both cells it passes between are free (no corner
    cutting). None when no path exists or an end cell is blocked or outside. ``weight`` > 1
    inflates the heuristic (weighted A*): far fewer cells expanded, path at most ``weight``
    times the shortest (1.0 = exactly shortest).
    """
    rows, cols = free.shape
    for r, c in (start, goal):
        if not (0 <= r < rows and 0 <= c < cols) or not free[r, c]:
            return None
    if start == goal:
        return [start]
    # deferred: tcod takes 0.3-0.5 s to import, which every command paid at start
    # (`helixd --version` took 3.1 s); only planning on a map needs it
    import tcod.path

    cost = np.ascontiguousarray(free, dtype=np.int8)
    graph = tcod.path.CustomGraph(free.shape)
    graph.add_edges(
        edge_map=[[0, STRAIGHT_COST, 0], [STRAIGHT_COST, 0, STRAIGHT_COST], [0, STRAIGHT_COST, 0]],
        cost=cost,
    )
    for dr, dc in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        ok = _shifted(free, dr, 0) & _shifted(free, 0, dc)
        graph.add_edge((dr, dc), DIAGONAL_COST, cost=cost, condition=ok.view(np.int8))
    graph.set_heuristic(
        cardinal=round(STRAIGHT_COST * weight), diagonal=round(DIAGONAL_COST * weight)
    )
    finder = tcod.path.Pathfinder(graph)
    finder.add_root(start)
    path = finder.path_to(goal)
    # unreachable: tcod answers with the goal alone (no root at the front)
    if len(path) < 2 or tuple(int(v) for v in path[0]) != start:
        return None
    if tuple(int(v) for v in path[-1]) != goal:
        return None
    return [(int(r), int(c)) for r, c in path]


def turning_cells(path: list[Cell]) -> list[Cell]:
    """The path's ends and the cells where its direction changes (straight runs collapsed):
    the segment between two consecutive kept cells is exactly the run of cells it replaces."""
    if len(path) <= 2:
        return list(path)
    p = np.asarray(path, dtype=np.int64)
    d = np.diff(p, axis=0)
    turn = np.any(d[1:] != d[:-1], axis=1)
    keep = np.concatenate(([True], turn, [True]))
    return [(int(r), int(c)) for r, c in p[keep]]


def shortcut(grid: PlanningGrid, points: list[PointNE]) -> list[PointNE]:
    """Greedy line-of-sight shortcutting: from each kept point, jump to the last point that is
    still in sight (the segment crosses no inflated cell); keeps both ends."""
    if len(points) <= 2:
        return list(points)
    out = [points[0]]
    anchor = 0
    while anchor < len(points) - 1:
        nxt = anchor + 1
        j = anchor + 2
        while j < len(points) and segment_is_free(grid, points[anchor], points[j]):
            nxt = j
            j += 1
        out.append(points[nxt])
        anchor = nxt
    # second pass: drop any kept corner whose neighbours see each other
    changed = True
    while changed and len(out) > 2:
        changed = False
        i = 1
        while i < len(out) - 1:
            if segment_is_free(grid, out[i - 1], out[i + 1]):
                del out[i]
                changed = True
            else:
                i += 1
    return out
