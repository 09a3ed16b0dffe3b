"""The isotropy index on an arm's r-dimensional subspace (r < 6), decided by batched proofs.

Same value, bitwise, as :func:`placement.kernels.subspace.subspace_manipulability` with ``ISOTROPY``:
the octants that decide the minimum are computed by the same routine (``octant_value_rank``), every
other octant is *proven* not to be below the running minimum, as :mod:`placement.kernels.isotropy`
does for rank 6 (the most penalised octant first, exactly, as the octant-by-octant kernel: most samples
that cannot raise their cell stop there). Octant s's value is ``sqrt(lambda_r(A_s) / lambda_1(A_s))``
(eigenvalues of its Gram matrix ``A_s``, largest first). The proofs count eigenvalues: by Sylvester's
law of inertia, the negative pivots of ``A_s - c I = L D L^T`` are the eigenvalues below c
(:mod:`placement.kernels.subspace_inertia`, all 64 octants at once, with an a-posteriori bound on the
factorisation's error that every proof must beat):

- ``lambda_r(A_s) < c`` when at least 7 - r pivots are negative: with ``c = t^2 rho_s`` (``rho_s <=
  lambda_1(A_s)``, a Rayleigh quotient), octant s is below the cell's value t: the sample is dropped;
- ``lambda_r(A_s) > c`` when at most 6 - r are: with ``c = best^2 U_s`` (``U_s >= lambda_1(A_s)``,
  certified by Cholesky, else the trace), octant s is not below the running minimum;
- in between, a few bisection steps of the same count on each octant's ``lambda_r / rho`` rank the
  octants no proof settles: they are computed exactly, lowest first, re-proving the rest after each
  new minimum.

The proofs keep the relative margins of the rank-6 path (``proof_margin``), far above rounding.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from placement.kernels.isotropy import proof_margin, top_start
from placement.kernels.manipulability import gram_table, most_penalised_octant
from placement.kernels.octants import fill_grams, lambda_max_lower, pd_flags, traces
from placement.kernels.octants_refine import lambda_max_tight
from placement.kernels.subspace import octant_value_rank
from placement.kernels.subspace_inertia import ERROR_FACTOR, inertia

__all__ = ["subspace_isotropy_batched"]

#: Slacks tried for the certified upper bound U_s = slack * rho_s >= lambda_1 (as the rank-6 path).
U_SLACKS = (1.001, 1.03)
#: Bisection steps ranking the octants that the first proof leaves open.
RANK_STEPS = 3


@njit(cache=True)
def _some_below(
    Ag: npt.NDArray[np.float64],
    rho: npt.NDArray[np.float64],
    t2: float,
    rank: int,
    beta: npt.NDArray[np.float64],
    neg: npt.NDArray[np.float64],
    err: npt.NDArray[np.float64],
) -> bool:
    """True when some octant's lambda_rank(A_s) < t2 rho_s (rho_s <= lambda_1(A_s)): by its inertia at
    ``t2 rho_s (1 - m)``, where the factorisation's error bound stays below the margin m."""
    m = proof_margin(math.sqrt(t2))
    for s in range(64):
        beta[s] = -t2 * rho[s] * (1.0 - m)
    inertia(Ag, beta, neg, err)
    for s in range(64):
        if neg[s] >= 7 - rank and ERROR_FACTOR * err[s] <= t2 * rho[s] * m:
            return True
    return False


@njit(cache=True)
def _prove_not_below(
    Ag: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    best: float,
    rank: int,
    beta: npt.NDArray[np.float64],
    neg: npt.NDArray[np.float64],
    err: npt.NDArray[np.float64],
    done: npt.NDArray[np.float64],
) -> int:
    """done[s] <- 1.0 where lambda_rank(A_s) > best^2 (1 + m) upper_s (upper_s >= lambda_1(A_s)): octant s is
    not below ``best``; by its inertia at best^2 (1 + 2 m) upper_s, the error bound below the margin.
    Returns how many octants are left open."""
    m = proof_margin(best)
    c = best * best * (1.0 + 2.0 * m)
    for s in range(64):
        beta[s] = -c * upper[s] if done[s] == 0.0 else 0.0
    inertia(Ag, beta, neg, err)
    left = 0
    for s in range(64):
        if done[s] == 0.0:
            if neg[s] <= 6 - rank and ERROR_FACTOR * err[s] <= best * best * m * upper[s]:
                done[s] = 1.0
            else:
                left += 1
    return left


@njit(cache=True)
def _rank_open(
    Ag: npt.NDArray[np.float64],
    rho: npt.NDArray[np.float64],
    rank: int,
    done: npt.NDArray[np.float64],
    lo: npt.NDArray[np.float64],
    hi: npt.NDArray[np.float64],
    beta: npt.NDArray[np.float64],
    neg: npt.NDArray[np.float64],
    err: npt.NDArray[np.float64],
) -> None:
    """Narrow [lo_s, hi_s], a bracket of lambda_rank(A_s) / rho_s, for the open octants (done 0.0) by
    :data:`RANK_STEPS` inertia counts (a ranking only: no error bound needed)."""
    for _step in range(RANK_STEPS):
        for s in range(64):
            mid = 0.25 * hi[s] if lo[s] <= 0.0 else math.sqrt(lo[s] * hi[s])
            beta[s] = -mid * rho[s] if done[s] == 0.0 else 0.0
        inertia(Ag, beta, neg, err)
        for s in range(64):
            if done[s] == 0.0:
                mid = -beta[s] / rho[s] if rho[s] > 0.0 else 0.0
                if neg[s] >= 7 - rank:
                    hi[s] = mid
                else:
                    lo[s] = mid


@njit(cache=True)
def subspace_isotropy_batched(
    J: npt.NDArray[np.float64],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
    rowfac: npt.NDArray[np.float64],
    rank: int,
    threshold: float,
    P: npt.NDArray[np.float64],
    G: npt.NDArray[np.float64],
    Ag: npt.NDArray[np.float64],
    Rg: npt.NDArray[np.float64],
    W: npt.NDArray[np.float64],
    A: npt.NDArray[np.float64],
    B: npt.NDArray[np.float64],
    S: npt.NDArray[np.float64],
    C: npt.NDArray[np.float64],
    de: npt.NDArray[np.float64],
) -> float:
    """The rank-``rank`` isotropy index (min over octants of sigma_rank/sigma_1), or -1.0 if proven <= threshold.

    Args:
        J: (6, n) TCP Jacobian, rotation rows scaled; pen_lo, pen_hi: (n,) joint-limit penalty factors;
        rowfac: (6, 2) row factors (self-distance; ones without); rank: the arm's generic rank, 1 .. 5;
        threshold: the cell's current value; < 0 computes the exact value always.
        P (6, n, 2), G (6, 6, 2, 2), Ag, Rg (21, 64), W (6, 64), A, B (6, 6), S (2, 6, 6), C (21, 21),
        de (2, 6): scratch (P to W as :func:`placement.kernels.isotropy.isotropy_batched`; B, S, C unused).
    """
    gram_table(J, pen_lo, pen_hi, rowfac, P, G)
    t = threshold
    t2 = t * t * (1.0 - proof_margin(t)) if t > 0.0 else 0.0
    # the most penalised octant first, exactly: a sample far below its cell's value is usually settled here
    s_pen = most_penalised_octant(P)
    best = octant_value_rank(G, s_pen, 0, rank, A, P, de)
    if best <= t:
        return -1.0
    if best <= 0.0:
        return best  # no octant is below 0
    rho, upper, beta, flag, hi, done = W[0], W[1], W[2], W[3], W[4], W[5]
    lo, neg, err = Rg[0], Rg[1], Rg[2]
    fill_grams(G, Ag)
    top = de[1]
    top_start(G, A, top, de[0])
    lambda_max_lower(Ag, top, rho)
    if t > 0.0 and _some_below(Ag, rho, t2, rank, beta, neg, err):
        return -1.0
    lambda_max_tight(Ag, top, rho)
    for s in range(64):
        done[s] = 0.0
    done[s_pen] = 1.0
    traces(Ag, upper)
    for slack in U_SLACKS:
        for s in range(64):
            beta[s] = slack * rho[s]
        pd_flags(Ag, -1.0, beta, flag)
        for s in range(64):
            if flag[s] > 0.0 and beta[s] < upper[s]:
                upper[s] = beta[s]
    left = _prove_not_below(Ag, upper, best, rank, beta, neg, err, done)
    if left > 1:
        for s in range(64):
            lo[s] = 0.0
            hi[s] = best * best * upper[s] / rho[s] if rho[s] > 0.0 else 0.0
        _rank_open(Ag, rho, rank, done, lo, hi, beta, neg, err)
    while left > 0:
        s = -1
        for k in range(64):
            if done[k] == 0.0 and (s < 0 or hi[k] < hi[s] or (hi[k] == hi[s] and lo[k] < lo[s])):
                s = k
        done[s] = 1.0
        left -= 1
        v = octant_value_rank(G, s, 0, rank, A, P, de)
        if v < best:
            best = v
            if best <= t:
                return -1.0
            if best <= 0.0:
                return best
            if left > 1:
                left = _prove_not_below(Ag, upper, best, rank, beta, neg, err, done)
    return best
