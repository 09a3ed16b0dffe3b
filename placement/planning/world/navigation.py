"""Navigation cost maps (paper section IV-A): distance to obstacles, velocity model, shortest paths.

All maps are (ny, nx) arrays over a :class:`~placement.scene.navgrid.NavGrid`; row index = y, column = x.
Distances and costs are in metres; ``cost / v_max`` is travel time in seconds.
"""

from __future__ import annotations

import os
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.kernels.navigation import component_of, distance_transform, padded_costs, padded_grid
from placement.planning.arrays import BoolArray, FloatArray, IntArray
from placement.scene.navgrid import NavGrid


def reachable_from(feasible: BoolArray, nav: NavGrid, x: float, y: float) -> BoolArray:
    """(ny, nx) bool: the ``feasible`` cells the base can drive to from (x, y) [m] on ``nav``: its
    8-connected component (every feasible cell when (x, y) is not on one: nothing narrower can be said)."""
    try:
        cell = nav.cell(x, y)
    except PlacementError:
        return feasible.copy()
    if not feasible[cell]:
        return feasible.copy()
    out: BoolArray = component_of(np.ascontiguousarray(feasible, dtype=np.bool_), int(cell[0]), int(cell[1]))
    return out


def distance_map(occupied: BoolArray, resolution: float) -> FloatArray:
    """Exact Euclidean distance [m] from each cell centre to the nearest occupied cell centre.

    occupied: (ny, nx) bool. Returns (ny, nx) float64 (inf if nothing is occupied).
    """
    occ = np.ascontiguousarray(occupied, dtype=np.bool_)
    if occ.ndim != 2:
        raise PlacementError(f"occupancy must be a 2D grid, got shape {occ.shape}")
    out: FloatArray = distance_transform(occ, float(resolution))
    return out


def speed_factor(d_o: FloatArray, lam: float, k: float, d_max: float) -> FloatArray:
    """The slowdown ``1 + lam * d_s`` of Eq. 4: ``v = v_max / factor``.

    ``d_s = (1 - d_o / d_max) ** k`` where ``d_o < d_max`` [m], else 0 (defaults in
    :class:`~placement.planning.settings.PlannerConfig`).
    """
    d_o = np.asarray(d_o, dtype=np.float64)
    d_s = np.where(d_o < d_max, np.clip(1.0 - d_o / d_max, 0.0, 1.0) ** k, 0.0)
    out: FloatArray = 1.0 + lam * d_s
    return out


def navigation_cost(
    factor: FloatArray,
    feasible: BoolArray,
    starts: npt.ArrayLike,
    resolution: float,
    start_costs: npt.ArrayLike | None = None,
    targets: BoolArray | None = None,
    reverse: bool = False,
) -> tuple[FloatArray, IntArray]:
    """Minimal travel cost [m] from the start cells to every cell (Eq. 5, exact, Dijkstra); with
    ``reverse``, from every cell to the start cells (``pred``: the next cell towards them).

    Args:
        factor: (ny, nx) slowdown per cell (>= 1), from :func:`speed_factor`.
        feasible: (ny, nx) bool, cells the base may occupy.
        starts: (k, 2) or (2,) integer (iy, ix) start cells.
        resolution: cell size [m].
        start_costs: optional (k,) initial costs [m] (0 by default).
        targets: optional (ny, nx) bool: only these cells are needed; the search stops when
            they are all settled and every other cell is returned as inf (same costs on the
            targets, less work).
    Returns:
        cost (ny, nx) [m] (inf where unreachable), pred (ny, nx) flat predecessor index.
    """
    fac, feas, cells, costs = _checked(factor, feasible, starts, start_costs)
    ny, nx = feas.shape
    tgt = np.zeros(feas.shape, dtype=np.bool_) if targets is None else np.ascontiguousarray(targets, dtype=np.bool_)
    if tgt.shape != feas.shape:
        raise PlacementError(f"targets {tgt.shape} and feasible {feas.shape} grids differ")
    grid, work = _prepared(fac, feas)
    cost, pred, _, _ = padded_costs(
        grid, work, ny, nx, cells, costs, float(resolution), np.flatnonzero(tgt), bool(reverse)
    )
    return np.asarray(cost, dtype=np.float64), np.asarray(pred, dtype=np.int64)


def costs_at(
    factor: FloatArray,
    feasible: BoolArray,
    starts: npt.ArrayLike,
    resolution: float,
    at: IntArray,
    start_costs: npt.ArrayLike | None = None,
    reverse: bool = False,
) -> tuple[FloatArray, IntArray]:
    """:func:`navigation_cost` with ``targets`` the flat cells ``at`` (n,), on them only: (n,) their
    costs [m] (inf where unreachable) and (n,) the flat start cell each one's shortest path starts from
    (the cell itself where unreachable; ``extract_path(pred, cell)[0]``). Without the (ny, nx) maps,
    which a search near its targets spends most of its time making."""
    fac, feas, cells, costs = _checked(factor, feasible, starts, start_costs)
    ny, nx = feas.shape
    flat = np.ascontiguousarray(at, dtype=np.int64).reshape(-1)
    if flat.size == 0:
        return np.zeros(0), np.zeros(0, np.int64)
    if flat.min() < 0 or flat.max() >= ny * nx:
        raise PlacementError(f"target cells outside the {ny} x {nx} grid")
    grid, work = _prepared(fac, feas)
    _, _, cost, source = padded_costs(grid, work, ny, nx, cells, costs, float(resolution), flat, bool(reverse), True)
    return np.asarray(cost, dtype=np.float64), np.asarray(source, dtype=np.int64)


def _checked(
    factor: FloatArray, feasible: BoolArray, starts: npt.ArrayLike, start_costs: npt.ArrayLike | None
) -> tuple[FloatArray, BoolArray, IntArray, FloatArray]:
    """The search's inputs as the kernel reads them (contiguous, typed), checked: (factor, feasible,
    (k, 2) start cells, (k,) their costs [m])."""
    cells = np.ascontiguousarray(np.atleast_2d(np.asarray(starts, dtype=np.int64)))
    feas = np.ascontiguousarray(feasible, dtype=np.bool_)
    fac = np.ascontiguousarray(factor, dtype=np.float64)
    if fac.shape != feas.shape:
        raise PlacementError(f"factor {fac.shape} and feasible {feas.shape} grids differ")
    ny, nx = feas.shape
    if 9 * (ny + 2) * (nx + 2) + len(cells) >= 2**31:
        raise PlacementError(f"the {ny} x {nx} grid is too large for the shortest-path kernel (int32 queue)")
    outside = (cells[:, 0] < 0) | (cells[:, 0] >= ny) | (cells[:, 1] < 0) | (cells[:, 1] >= nx)
    if outside.any():
        iy, ix = cells[int(np.argmax(outside))]
        raise PlacementError(f"start cell ({iy}, {ix}) is outside the {ny} x {nx} grid")
    if not feas[cells[:, 0], cells[:, 1]].any():
        iy, ix = cells[0]
        raise PlacementError(f"start cell ({iy}, {ix}) is inside an obstacle or too close to one for the base")
    costs = np.zeros(len(cells)) if start_costs is None else np.asarray(start_costs, dtype=float)
    return fac, feas, cells, np.ascontiguousarray(costs, dtype=np.float64)


#: The padded grid (:func:`~placement.kernels.navigation.padded_grid`) and the work arrays of a search
#: (see :func:`~placement.kernels.navigation.padded_costs`).
Grid = tuple[FloatArray, BoolArray, float, float]
Work = tuple[FloatArray, IntArray, BoolArray, BoolArray, IntArray]
#: Grids kept per thread (a planner searches one world at a time; an update brings another): each
#: holds about 27 bytes per cell (20 MB for the office floor's 911 x 798 window)
GRIDS_KEPT = 2
_kept = threading.local()


def _frozen(a: Any) -> bool:
    """Whether ``a``'s data cannot change: read-only, and so is every array it is a view of."""
    while isinstance(a, np.ndarray):
        if a.flags.writeable:
            return False
        a = a.base
    return a is None or isinstance(a, bytes)


def _fresh(fac: FloatArray, feas: BoolArray) -> tuple[Grid, Work]:
    grid: Grid = padded_grid(fac, feas)
    n = grid[1].size
    return grid, (
        np.full(n, np.inf),
        np.full(n, -1, dtype=np.int64),
        grid[1].copy(),
        np.zeros(n, dtype=bool),
        np.full(n, -1, dtype=np.int64),
    )


def _prepared(fac: FloatArray, feas: BoolArray) -> tuple[Grid, Work]:
    """The padded grid of (``fac``, ``feas``) and a search's work arrays. For arrays that cannot change (a
    world's layers are read-only) both are made once and kept, per thread, for the next search on
    them: a search near its targets touches few cells, and making its (ny + 2) (nx + 2) arrays (with
    the page faults of fresh memory) took most of its time on building-sized grids."""
    if not (_frozen(fac) and _frozen(feas)):
        return _fresh(fac, feas)
    kept: OrderedDict[tuple[int, int], tuple[Any, Any, Grid, Work]] = getattr(_kept, "grids", None) or OrderedDict()
    _kept.grids = kept
    key = (id(fac), id(feas))
    hit = kept.get(key)
    if hit is not None and hit[0]() is fac and hit[1]() is feas:
        kept.move_to_end(key)
        return hit[2], hit[3]
    grid, work = _fresh(fac, feas)
    kept[key] = (weakref.ref(fac), weakref.ref(feas), grid, work)
    while len(kept) > GRIDS_KEPT:
        kept.popitem(last=False)
    return grid, work


_A = TypeVar("_A")
_R = TypeVar("_R")
_POOL: list[ThreadPoolExecutor] = []


def side_by_side(fn: Callable[[_A], _R], items: Iterable[_A]) -> list[_R]:
    """``[fn(x) for x in items]``, the calls run in threads, one per core (made once: each thread keeps
    its work arrays per grid, see :func:`_prepared`). For searches (:func:`costs_at`, whose kernel
    releases the GIL): the same results as one after the other."""
    if not _POOL:
        _POOL.append(ThreadPoolExecutor(max_workers=max(1, os.cpu_count() or 1), thread_name_prefix="placement-search"))
    return list(_POOL[0].map(fn, items))


# a forked child has none of the parent's threads: its pool is made anew (the parent's would wait forever)
if hasattr(os, "register_at_fork"):  # POSIX only; elsewhere nothing forks
    os.register_at_fork(after_in_child=_POOL.clear)


def extract_path(pred: IntArray, goal: tuple[int, int] | IntArray) -> IntArray:
    """Cells (m, 2) (iy, ix) from the source to ``goal`` (iy, ix) along the predecessor map."""
    ny, nx = pred.shape
    u = int(goal[0]) * nx + int(goal[1])
    path = [u]
    while pred.flat[u] >= 0:
        u = int(pred.flat[u])
        path.append(u)
        if len(path) > pred.size:
            raise PlacementError("predecessor map has a cycle")
    path.reverse()
    return np.array([(p // nx, p % nx) for p in path], dtype=np.int64)
