"""Map building: sample joint configurations, bin their TCP poses, keep the best value per cell.

Race-free in two phases per block: threads compute (cell, value) per sample
into their own slots while the grid is only read; then one pass applies the
per-cell maximum. The maximum is order-independent and every sample's value is
a pure function of (seed, sample index), so the map is bitwise identical for
any thread count or block split. A sample whose value is proven not to exceed
its cell's current value is dropped early (value -1): that cannot change the
result either.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .grid import cell_index
from .kinematics import fk_jacobian
from .isotropy import W_ROWS, isotropy_batched
from .manipulability import ISOTROPY, extended_manipulability, joint_penalties
from .rng import uniform


CHUNK = 256  # samples per parallel task; its buffers (q, J) stay in the L2 cache


@njit(cache=True, parallel=True)
def sample_block(seed, start, count, lower, upper, continuous, link_T, axis, kind, tip_T,
                 index, rot_scale, origin, res, shape, grid, rowfac, out_cell, out_val):
    """Evaluate samples start .. start+count-1 into out_cell (count,) and out_val (count,).

    out_cell is -1 for a pose outside the grid; out_val is -1 for a sample proven
    not to raise its cell. ``grid`` is the flat float32 map, read only here.
    ``rowfac`` is (count, 6, 2): each sample's row penalties (self-distance), a
    negative [i, 0, 0] rejecting the sample; or (0, 6, 2) for none.
    """
    n = lower.shape[0]
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
                qi[j] = lower[j] + (upper[j] - lower[j]) * uniform(seed, sid * n + j)
            fk_jacobian(qi, link_T, axis, kind, tip_T, T, J[i - lo], work)
            out_cell[i] = cell_index(T, origin, res, shape)
        for i in range(lo, hi):
            c = out_cell[i]
            thr[i - lo] = np.float64(grid[c]) if c >= 0 else 0.0
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
            if index == ISOTROPY:
                out_val[i] = isotropy_batched(Ji, plo, phi, rf, thr[i - lo], P, G, Ag, W, A, B, de)
            else:
                out_val[i] = extended_manipulability(Ji, plo, phi, rf, index, thr[i - lo], P, G, A, de)


@njit(cache=True)
def reduce_max(grid, cells, vals):
    """grid[cells[i]] = max(grid[cells[i]], vals[i]) for valid samples; returns how many raised."""
    raised = 0
    for i in range(cells.shape[0]):
        c = cells[i]
        if c >= 0 and vals[i] > 0.0:
            v = np.float32(vals[i])
            if v > grid[c]:
                grid[c] = v
                raised += 1
    return raised


@njit(cache=True)
def configs_at(seed, ids, lower, upper):
    """The joint configurations (len(ids), n) [rad/m] of the samples numbered ``ids``."""
    n = lower.shape[0]
    out = np.empty((ids.shape[0], n))
    for i in range(ids.shape[0]):
        for j in range(n):
            out[i, j] = lower[j] + (upper[j] - lower[j]) * uniform(seed, ids[i] * n + j)
    return out


@njit(cache=True)
def sample_configs(seed, start, count, lower, upper):
    """The joint configurations (count, n) [rad/m] of samples start .. start+count-1."""
    return configs_at(seed, np.arange(start, start + count), lower, upper)
