"""The extended manipulability on the subspace an arm spans, for arms of generic rank r < 6.

Why this measure, and what it means: see :mod:`placement.kernels.manipulability`. In short, with r
the arm's generic rank, each octant's penalised Jacobian ``J_s`` (6, n) gives ``sigma_r/sigma_1``
(isotropy) or ``sigma_1 ... sigma_r`` (volume) of its r largest singular values, and the value is the
worst case over the 64 octants. For r = 6 every function here is the ordinary measure, bit for bit
(it calls the same kernels).

The generic rank is a property of the arm, computed once from :data:`RANK_SAMPLES` counter-based
configurations (fixed seed, so every build and every check of one arm gets the same r): the largest
number of singular values of J above :data:`RANK_TOLERANCE` times the largest. A structural
deficiency (parallel prismatic axes, fewer than 6 joints) leaves the r+1-th at rounding level,
~1e-16 relative, everywhere; a real sixth direction is far above 1e-8 at almost every configuration.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from placement.kernels.kinematics import fk_jacobian
from placement.kernels.manipulability import (
    ACCURATE_BELOW,
    ISOTROPY,
    N_OCTANTS,
    extended_manipulability,
    gram_table,
    jacobi_columns,
    most_penalised_octant,
    octant_gram,
    octant_r,
    octant_value,
    sym_eig_extremes,
)
from placement.kernels.rng import uniform

__all__ = ["RANK_SAMPLES", "RANK_TOLERANCE", "generic_rank", "octant_value_rank", "subspace_manipulability"]

#: Configurations the generic rank is taken over.
RANK_SAMPLES = 200
#: A singular value counts towards the rank above this fraction of the largest.
RANK_TOLERANCE = 1e-8
#: The volume index comes from the Gram eigenvalues while sigma_r/sigma_1 is above this (their relative
#: error, ~eps (sigma_1/sigma_r)^2, stays below 1e-11), else from J_s by QR and one-sided Jacobi.
VOLUME_FROM_GRAM_ABOVE = 1e-2
#: Seed of the rank's configurations (fixed: the rank is a property of the arm, not of a build).
RANK_SEED = np.uint64(0x7A4B)


@njit(cache=True, inline="always")
def _sort_descending(d: npt.NDArray[np.float64]) -> None:
    """Insertion sort of the 6 values in d, largest first, in place."""
    for i in range(1, 6):
        v = d[i]
        k = i - 1
        while k >= 0 and d[k] < v:
            d[k + 1] = d[k]
            k -= 1
        d[k + 1] = v


@njit(cache=True)
def _column_norms(R: npt.NDArray[np.float64], out: npt.NDArray[np.float64]) -> None:
    """out (6,) <- the column norms of R (6, 6), largest first (after :func:`jacobi_columns`: its singular values)."""
    for c in range(6):
        acc = 0.0
        for i in range(6):
            acc += R[i, c] * R[i, c]
        out[c] = math.sqrt(acc)
    _sort_descending(out)


@njit(cache=True)
def octant_value_rank(
    G: npt.NDArray[np.float64],
    s: int,
    index: int,
    rank: int,
    A: npt.NDArray[np.float64],
    P: npt.NDArray[np.float64],
    de: npt.NDArray[np.float64],
) -> float:
    """One octant's index on the arm's ``rank``-dimensional subspace (rank 6: :func:`octant_value`).

    Isotropy ``sigma_rank/sigma_1``, volume the product of the ``rank`` largest singular values
    of J_s: from the Gram eigenvalues (all six are left in de[0] by :func:`sym_eig_extremes`), or,
    where the Gram matrix's squared condition number would cost accuracy (isotropy below
    ``ACCURATE_BELOW``, volume below :data:`VOLUME_FROM_GRAM_ABOVE`), from J_s by QR and
    one-sided Jacobi (G (6, 6, 2, 2), P (6, n, 2): the tables
    of :func:`gram_table`; A (6, 6), de (2, 6): scratch).
    """
    if rank >= 6:
        return octant_value(G, s, index, A, P, de)
    d = de[0]
    octant_gram(G, s, A)
    sym_eig_extremes(A, de)
    _sort_descending(d)
    v = math.sqrt(d[rank - 1] / d[0]) if d[rank - 1] > 0.0 and d[0] > 0.0 else 0.0
    if index == ISOTROPY and v >= ACCURATE_BELOW:
        return v
    if index != ISOTROPY and v >= VOLUME_FROM_GRAM_ABOVE:
        vol = 1.0
        for k in range(rank):
            vol *= d[k]
        return math.sqrt(vol)
    octant_r(P, s, A)
    jacobi_columns(A)
    _column_norms(A, d)
    if index == ISOTROPY:
        return d[rank - 1] / d[0] if d[0] > 0.0 else 0.0
    vol = 1.0
    for k in range(rank):
        vol *= d[k]
    return vol


@njit(cache=True)
def subspace_manipulability(
    J: npt.NDArray[np.float64],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
    rowfac: npt.NDArray[np.float64],
    index: int,
    rank: int,
    threshold: float,
    P: npt.NDArray[np.float64],
    G: npt.NDArray[np.float64],
    A: npt.NDArray[np.float64],
    de: npt.NDArray[np.float64],
) -> float:
    """Worst case over the 64 octants of :func:`octant_value_rank`, or -1.0 as soon as it is proven <= threshold.

    Arguments as :func:`~placement.kernels.manipulability.extended_manipulability`, plus ``rank``
    (1 .. 6), the arm's generic rank; rank 6 is that function. The octants are visited from the
    most penalised one on (its complement last): the result does not depend on the order, but a
    sample that cannot raise its cell is usually settled by the first.
    """
    if rank >= 6:
        return extended_manipulability(J, pen_lo, pen_hi, rowfac, index, threshold, P, G, A, de)
    gram_table(J, pen_lo, pen_hi, rowfac, P, G)
    first = most_penalised_octant(P)
    best = np.inf
    for k in range(N_OCTANTS):
        v = octant_value_rank(G, first ^ k, index, rank, A, P, de)
        if v < best:
            best = v
            if best <= threshold:
                return -1.0
    return best


@njit(cache=True)
def generic_rank(
    lower: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
    rot_scale: float,
) -> int:
    """The arm's generic rank: the largest numerical rank of its TCP Jacobian (rotation rows scaled by
    ``rot_scale``) over :data:`RANK_SAMPLES` configurations uniform within ``lower`` .. ``upper`` (n,)."""
    n = lower.shape[0]
    q = np.empty(n)
    T = np.empty((4, 4))
    J = np.empty((6, n))
    work = np.empty((n + 3, 4, 4))
    P = np.zeros((6, n, 2))
    R = np.empty((6, 6))
    sv = np.empty(6)
    best = 0
    for i in range(RANK_SAMPLES):
        for j in range(n):
            q[j] = lower[j] + (upper[j] - lower[j]) * uniform(RANK_SEED, i * n + j)
        fk_jacobian(q, link_T, axis, kind, tip_T, T, J, work)
        for r in range(6):
            f = rot_scale if r >= 3 else 1.0
            for j in range(n):
                P[r, j, 0] = J[r, j] * f
        octant_r(P, 0, R)
        jacobi_columns(R)
        _column_norms(R, sv)
        count = 0
        for k in range(6):
            if sv[k] > RANK_TOLERANCE * sv[0]:
                count += 1
        best = max(best, count)
        if best == 6:
            break
    return best
