"""Map building: sample joint configurations, bin their TCP poses, keep the best value per cell.

Race-free in two phases per block: threads compute (cell, value) per sample
into their own slots while the grid is only read; then one pass applies the
per-cell maximum. The maximum is order-independent and every sample's value is
a pure function of (seed, sample index), so the map is bitwise identical for
any thread count or block split. A sample whose value is proven not to exceed
its cell's current value is dropped early (value -1): that cannot change the
result either.

Witnesses: every cell also keeps the number of the sample that set its value
(see placement/maps/witness.py for the numbering). Among samples of equal value the
smallest number wins; blocks are applied in increasing sample order and a
dropped sample never beats the earlier one that set the threshold, so the
witnesses are as deterministic as the values.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit, prange

from placement.kernels.grid import cell_index
from placement.kernels.ik import dls_attempt
from placement.kernels.isotropy import W_ROWS, isotropy_batched
from placement.kernels.kinematics import fk_jacobian
from placement.kernels.manipulability import ISOTROPY, extended_manipulability, joint_penalties
from placement.kernels.rng import uniform
from placement.kernels.subspace import generic_rank, subspace_manipulability
from placement.kernels.subspace_batched import subspace_isotropy_batched

CHUNK = 256  # samples per parallel task; its buffers (q, J) stay in the L2 cache


@njit(cache=True, parallel=True)
def sample_block(
    seed: np.uint64,
    start: int,
    count: int,
    given: npt.NDArray[np.float64],
    lower: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    continuous: npt.NDArray[np.bool_],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
    index: int,
    rot_scale: float,
    origin: npt.NDArray[np.float64],
    res: float,
    shape: npt.NDArray[np.int64],
    grid: npt.NDArray[np.float32],
    rowfac: npt.NDArray[np.float64],
    out_cell: npt.NDArray[np.int64],
    out_val: npt.NDArray[np.float64],
    rank: int = 0,
) -> None:
    """Evaluate samples start .. start+count-1 into out_cell (count,) and out_val (count,).

    ``given`` (count, n) holds the configurations [rad or m] to evaluate (the
    completion pass), or is (0, n): then they are the counter-based samples of ``seed``.

    out_cell is -1 for a pose outside the grid; out_val is -1 for a sample proven
    not to raise its cell. ``grid`` is the flat float32 map, read only here
    (length 0: no pruning, every value exact).
    ``rowfac`` is (count, 6, 2): each sample's row penalties (self-distance), a
    negative [i, 0, 0] rejecting the sample; or (0, 6, 2) for none.
    ``rank``: the arm's generic rank (the measure is taken on the subspace it spans, see
    :mod:`placement.kernels.subspace`; the isotropy index by the batched proofs of
    :mod:`placement.kernels.subspace_batched`, the same values); 0 (the default): computed here by
    :func:`generic_rank`.
    """
    n = lower.shape[0]
    if rank <= 0:
        rank = generic_rank(lower, upper, link_T, axis, kind, tip_T, rot_scale)
    n_chunks = (count + CHUNK - 1) // CHUNK
    for chunk in prange(n_chunks):
        q = np.empty((CHUNK, n))
        T = np.empty((4, 4))
        J = np.empty((CHUNK, 6, n))
        thr = np.empty(CHUNK)
        work = np.empty((n + 3, 4, 4))
        plo = np.empty(n)
        phi = np.empty(n)
        P = np.empty((6, n, 2))
        G = np.empty((6, 6, 2, 2))
        A = np.empty((6, 6))
        B = np.empty((6, 6))
        Ag = np.empty((21, 64))
        Rg = np.empty((21, 64))
        S = np.empty((2, 6, 6))
        C = np.empty((21, 21))
        ones = np.ones((6, 2))
        W = np.empty((W_ROWS, 64))
        de = np.empty((2, 6))
        lo = chunk * CHUNK
        hi = min(count, lo + CHUNK)
        # three passes per chunk: poses, then all the cells' current values (independent
        # loads from a map far larger than the caches overlap), then the measure
        for i in range(lo, hi):
            sid = start + i
            qi = q[i - lo]
            for j in range(n):
                qi[j] = (
                    given[i, j] if given.shape[0] > 0 else lower[j] + (upper[j] - lower[j]) * uniform(seed, sid * n + j)
                )
            fk_jacobian(qi, link_T, axis, kind, tip_T, T, J[i - lo], work)
            out_cell[i] = cell_index(T, origin, res, shape)
        for i in range(lo, hi):
            c = out_cell[i]
            thr[i - lo] = np.float64(grid[c]) if c >= 0 and grid.shape[0] > 0 else -1.0
        for i in range(lo, hi):
            rf = rowfac[i] if rowfac.shape[0] > 0 else ones
            if out_cell[i] < 0 or rf[0, 0] < 0.0:
                out_val[i] = -1.0
                continue
            Ji = J[i - lo]
            qi = q[i - lo]
            for j in range(n):
                Ji[3, j] *= rot_scale
                Ji[4, j] *= rot_scale
                Ji[5, j] *= rot_scale
            joint_penalties(qi, lower, upper, continuous, plo, phi)
            if rank < 6 and index == ISOTROPY:
                out_val[i] = subspace_isotropy_batched(
                    Ji, plo, phi, rf, rank, thr[i - lo], P, G, Ag, Rg, W, A, B, S, C, de
                )
            elif rank < 6:
                out_val[i] = subspace_manipulability(Ji, plo, phi, rf, index, rank, thr[i - lo], P, G, A, de)
            elif index == ISOTROPY:
                out_val[i] = isotropy_batched(Ji, plo, phi, rf, thr[i - lo], P, G, Ag, W, A, B, de)
            else:
                out_val[i] = extended_manipulability(Ji, plo, phi, rf, index, thr[i - lo], P, G, A, de)


@njit(cache=True)
def reduce_max(
    grid: npt.NDArray[np.float32],
    witness: npt.NDArray[np.uint32 | np.int64],
    cells: npt.NDArray[np.int64],
    vals: npt.NDArray[np.float64],
    ids: npt.NDArray[np.int64],
) -> int:
    """grid[cells[i]] = max(grid[cells[i]], vals[i]) for valid samples, witness[cell] = ids[i] of the
    winner (the smallest id among equal values); returns how many cells changed."""
    raised = 0
    for i in range(cells.shape[0]):
        c = cells[i]
        if c >= 0 and vals[i] > 0.0:
            v = np.float32(vals[i])
            if v > grid[c] or (v == grid[c] and ids[i] < witness[c]):
                grid[c] = v
                witness[c] = ids[i]
                raised += 1
    return raised


@njit(cache=True)
def configs_at(
    seed: np.uint64, ids: npt.NDArray[np.int64], lower: npt.NDArray[np.float64], upper: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """The joint configurations (len(ids), n) [rad/m] of the samples numbered ``ids``."""
    n = lower.shape[0]
    out = np.empty((ids.shape[0], n))
    for i in range(ids.shape[0]):
        for j in range(n):
            out[i, j] = lower[j] + (upper[j] - lower[j]) * uniform(seed, ids[i] * n + j)
    return out


@njit(cache=True)
def sample_configs(
    seed: np.uint64, start: int, count: int, lower: npt.NDArray[np.float64], upper: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """The joint configurations (count, n) [rad/m] of samples start .. start+count-1."""
    return configs_at(seed, np.arange(start, start + count), lower, upper)


# the 12 face neighbours of a 6D cell, as (axis, step): the completion directions
NEIGHBOURS = np.array([[a, d] for a in range(6) for d in (-1, 1)], dtype=np.int64)
# a few damped least-squares steps from the source witness towards the target cell's centre
COMPLETION_ITERATIONS = 4
COMPLETION_DAMPING = 1e-3
COMPLETION_MAX_STEP = 0.2


@njit(cache=True)
def neighbour_cell(cell: int, k: int, shape: npt.NDArray[np.int64]) -> int:
    """Flat index of the k-th face neighbour (NEIGHBOURS[k]) of flat ``cell``; yaw and roll wrap; -1 outside."""
    a = NEIGHBOURS[k, 0]
    stride = 1  # of axis a in the C-order flat index (no index array: this runs ~1e9 times per build)
    for d in range(5, a, -1):
        stride *= shape[d]
    i = (cell // stride) % shape[a]
    v = i + NEIGHBOURS[k, 1]
    if a == 3 or a == 5:
        v %= shape[a]
    elif v < 0 or v >= shape[a]:
        return -1
    # (numpy's stubs type an element of ``shape`` as Any, and typing.cast does not compile in a kernel)
    return cell + (v - i) * stride  # type: ignore[no-any-return]


@njit(cache=True)
def cell_centre(
    cell: int, origin: npt.NDArray[np.float64], res: float, shape: npt.NDArray[np.int64], T: npt.NDArray[np.float64]
) -> None:
    """The pose T (4, 4) at the centre of flat ``cell`` (the grid's bin convention, see kernels/grid.py)."""
    idx = np.empty(6, dtype=np.int64)
    rest = cell
    for d in range(5, -1, -1):
        idx[d] = rest % shape[d]
        rest //= shape[d]
    yaw = idx[3] * 2.0 * np.pi / shape[3]
    pitch = -0.5 * np.pi + (idx[4] + 0.5) * np.pi / shape[4]
    roll = idx[5] * 2.0 * np.pi / shape[5]
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    T[0, 0], T[0, 1], T[0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    T[1, 0], T[1, 1], T[1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    T[2, 0], T[2, 1], T[2, 2] = -sp, cp * sr, cp * cr
    for d in range(3):
        T[d, 3] = origin[d] + (idx[d] + 0.5) * res
    T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True)
def refined_config(
    seed: np.uint64,
    source: int,
    direction: int,
    lower: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    continuous: npt.NDArray[np.bool_],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
    origin: npt.NDArray[np.float64],
    res: float,
    shape: npt.NDArray[np.int64],
    out: npt.NDArray[np.float64],
) -> bool:
    """Completion sample into ``out`` (n,) [rad or m]: from sample ``source`` of ``seed``, a few DLS steps
    towards the centre of the ``direction``-th face neighbour of the cell that sample lies in.

    A pure function of (seed, source, direction): the map's witnesses only store those.
    Returns False (``out`` = the source sample) if the source or the neighbour is outside the grid.
    """
    n = lower.shape[0]
    for j in range(n):
        out[j] = lower[j] + (upper[j] - lower[j]) * uniform(seed, source * n + j)
    T = np.empty((4, 4))
    J = np.empty((6, n))
    work = np.empty((n + 3, 4, 4))
    fk_jacobian(out, link_T, axis, kind, tip_T, T, J, work)
    c = cell_index(T, origin, res, shape)
    t = neighbour_cell(c, direction, shape) if c >= 0 else -1
    if t < 0:
        return False
    cell_centre(t, origin, res, shape, T)
    # tolerances 0: always the fixed number of steps (the result must not depend on a float test)
    _, q, _, _, _ = dls_attempt(
        out.copy(),
        T,
        lower,
        upper,
        continuous,
        link_T,
        axis,
        kind,
        tip_T,
        0.0,
        0.0,
        COMPLETION_ITERATIONS,
        COMPLETION_DAMPING,
        COMPLETION_MAX_STEP,
        COMPLETION_ITERATIONS + 1,
    )
    out[:] = q
    return True


@njit(cache=True, parallel=True)
def refined_configs(
    seed: np.uint64,
    sources: npt.NDArray[np.int64],
    dirs: npt.NDArray[np.int64],
    lower: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    continuous: npt.NDArray[np.bool_],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
    origin: npt.NDArray[np.float64],
    res: float,
    shape: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """:func:`refined_config` of many (source, direction) pairs -> (configs (m, n), ok (m,) bool)."""
    m = sources.shape[0]
    out = np.empty((m, lower.shape[0]))
    ok = np.zeros(m, dtype=np.bool_)
    for i in prange(m):
        ok[i] = refined_config(
            seed, sources[i], dirs[i], lower, upper, continuous, link_T, axis, kind, tip_T, origin, res, shape, out[i]
        )
    return out, ok


@njit(cache=True)
def first_source(
    t: int,
    grid: npt.NDArray[np.float32],
    witness: npt.NDArray[np.uint32 | np.int64],
    plain: int,
    shape: npt.NDArray[np.int64],
) -> int:
    """The first face neighbour of cell ``t`` (NEIGHBOURS order) that is reached with a plain witness, or -1."""
    for d in range(NEIGHBOURS.shape[0]):
        c = neighbour_cell(t, d, shape)
        if c >= 0 and grid[c] > 0.0 and witness[c] < plain:
            return c
    return -1


#: Cell ranges of the parallel completion scan (fixed: the output order must not depend on the threads).
SCAN_PARTS = 256


@njit(cache=True)
def _scan_part(
    lo: int,
    hi: int,
    grid: npt.NDArray[np.float32],
    witness: npt.NDArray[np.uint32 | np.int64],
    plain: int,
    shape: npt.NDArray[np.int64],
    sources: npt.NDArray[np.int64],
    dirs: npt.NDArray[np.int64],
    m: int,
) -> int:
    """Completion candidates whose source cell is in [lo, hi): counted (``sources`` empty) or written
    from position ``m`` on; returns the position after them."""
    k = NEIGHBOURS.shape[0]
    write = sources.shape[0] > 0
    for c in range(lo, hi):
        if grid[c] > 0.0 and witness[c] < plain:
            for d in range(k):
                t = neighbour_cell(c, d, shape)
                if t >= 0 and grid[t] == 0.0 and first_source(t, grid, witness, plain, shape) == c:
                    if write:
                        sources[m] = witness[c]
                        dirs[m] = d
                    m += 1
    return m


@njit(cache=True, parallel=True)
def _count_parts(
    edges: npt.NDArray[np.int64],
    grid: npt.NDArray[np.float32],
    witness: npt.NDArray[np.uint32 | np.int64],
    plain: int,
    shape: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64]:
    counts = np.zeros(edges.shape[0] - 1, dtype=np.int64)
    for p in prange(counts.shape[0]):
        counts[p] = _scan_part(
            edges[p],
            edges[p + 1],
            grid,
            witness,
            plain,
            shape,
            np.empty(0, dtype=np.int64),
            np.empty(0, dtype=np.int64),
            0,
        )
    return counts


@njit(cache=True, parallel=True)
def _fill_parts(
    edges: npt.NDArray[np.int64],
    offsets: npt.NDArray[np.int64],
    grid: npt.NDArray[np.float32],
    witness: npt.NDArray[np.uint32 | np.int64],
    plain: int,
    shape: npt.NDArray[np.int64],
    sources: npt.NDArray[np.int64],
    dirs: npt.NDArray[np.int64],
) -> None:
    for p in prange(edges.shape[0] - 1):
        _scan_part(edges[p], edges[p + 1], grid, witness, plain, shape, sources, dirs, offsets[p])


def completion_sources(
    grid: npt.NDArray[np.float32], witness: npt.NDArray[np.uint32 | np.int64], plain: int, shape: npt.NDArray[np.int64]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """(sources, dirs): one completion candidate per empty cell next to a reached one, from its first
    (in NEIGHBOURS order) face neighbour that is reached with a plain-sample witness (< ``plain``);
    in increasing source cell, then direction order. One per empty cell, not one per pair: the
    candidates cost an exact measure each, and the pairs are several times as many.

    Two parallel passes over :data:`SCAN_PARTS` fixed cell ranges (count, then fill at each range's
    offset): the same arrays, in the same order, for any thread count (tests/test_witness.py
    compares them with a plain-Python reference). Both passes in one parallel function gave wrong
    counts under numba's parallel transform; as two functions they are right."""
    n = grid.shape[0]
    edges = (np.arange(SCAN_PARTS + 1, dtype=np.int64) * n) // SCAN_PARTS
    counts = _count_parts(edges, grid, witness, plain, shape)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    sources = np.empty(offsets[-1], dtype=np.int64)
    dirs = np.empty(offsets[-1], dtype=np.int64)
    _fill_parts(edges, offsets, grid, witness, plain, shape, sources, dirs)  # (always: compiled in warm-up)
    return sources, dirs
