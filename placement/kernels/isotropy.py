"""The exact 64-octant isotropy index, decided by batched proofs instead of 64 eigenproblems.

Same value, bitwise, as ``extended_manipulability(..., ISOTROPY, -1, ...)``:
the octants that decide the minimum are computed by the very same routine
(``octant_value``); every other octant is *proven* not to be below the
running minimum. The proofs are Cholesky factorisations of all 64 octants at
once (``octants.py``):

1. ``rho_s`` <= lambda_max(A_s) from power steps (any Rayleigh quotient is a
   lower bound). With a threshold t (the cell's current value): if some
   ``A_s - t^2 rho_s I`` is not positive definite, lambda_min(A_s) < t^2
   lambda_max(A_s), so the sample cannot raise its cell: return -1.
2. ``mu_s`` >= lambda_min(A_s) from inverse iteration; ``mu_s / rho_s``
   bounds octant s's isotropy squared from above and ranks the octants.
3. The best-ranked octant is computed exactly: m. ``U_s`` >= lambda_max(A_s)
   is certified by ``U_s I - A_s`` > 0 (else the trace is used); then
   ``A_s - m^2 U_s I`` > 0 proves octant s is not below m. Octants that no
   proof settles are computed exactly, lowest bound first.

Relative margins (``proof_margin``) far above rounding keep every proof valid in
exact arithmetic.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from placement.kernels.linalg6 import cho_solve6, cholesky6
from placement.kernels.manipulability import (
    gram_from,
    most_penalised_octant,
    octant_gram,
    octant_gram_direct,
    octant_value,
    penalised_rows,
)
from placement.kernels.octants import fill_grams, lambda_max_lower, pd_flags, traces
from placement.kernels.octants_refine import lambda_max_tight, lambda_min_upper

__all__ = ["W_ROWS", "isotropy_batched"]

W_ROWS = 6

_MARGIN = 1e-6  # smallest relative margin of a proof
_U_SLACKS = (1.001, 1.03)  # U_s = rho_s * slack, certified by Cholesky


@njit(cache=True, inline="always")
def proof_margin(v: float) -> float:
    """Relative margin of a proof at isotropy v.

    A Cholesky that succeeds proves positive definiteness of A + E with
    ||E|| < 5e-15 lambda_max; a proof at isotropy v must beat that by far,
    so the margin (relative to v^2) grows as v shrinks: m^2 * margin >= 1e-12.
    """
    return max(_MARGIN, 1e-12 / (v * v))


@njit(cache=True, inline="always")
def _largest_column(A: npt.NDArray[np.float64], x: npt.NDArray[np.float64]) -> int:
    """x[:6] <- the column of A (6, 6) with the largest diagonal entry; returns its index."""
    k = 0
    for r in range(1, 6):
        if A[r, r] > A[k, k]:
            k = r
    for r in range(6):
        x[r] = A[r, k]
    return k


@njit(cache=True)
def _below(
    P: npt.NDArray[np.float64],
    s: int,
    t2: float,
    A: npt.NDArray[np.float64],
    L: npt.NDArray[np.float64],
    z: npt.NDArray[np.float64],
) -> bool:
    """Proof that octant s's isotropy is below t: A_s - t2 rho I is not positive definite, t2 = t^2 (1 - margin).

    rho <= lambda_max(A_s) is the Rayleigh quotient after two power steps from
    A_s's largest column. A (6, 6), L (6, 6), z (12,) scratch.
    """
    octant_gram_direct(P, s, A)
    k = _largest_column(A, z)
    num = 0.0
    den = 0.0
    for _it in range(2):
        num = 0.0
        den = 0.0
        for r in range(6):
            acc = 0.0
            for c in range(6):
                acc += A[r, c] * z[c]
            z[6 + r] = acc
            num += z[r] * acc
            den += z[r] * z[r]
        for r in range(6):
            z[r] = z[6 + r]
    rho = max(num / den if den > 0.0 else 0.0, A[k, k])
    return not cholesky6(A, 1.0, -t2 * rho, L)


@njit(cache=True)
def top_start(
    G: npt.NDArray[np.float64], A: npt.NDArray[np.float64], top: npt.NDArray[np.float64], z: npt.NDArray[np.float64]
) -> None:
    """An approximate top eigenvector (6,) of octant 0 (A (6, 6), z (6,) scratch): the common power-step start."""
    octant_gram(G, 0, A)
    _largest_column(A, top)
    for _it in range(4):
        m = 0.0
        for r in range(6):
            acc = 0.0
            for c in range(6):
                acc += A[r, c] * top[c]
            z[r] = acc
            m = max(m, abs(acc))
        if m == 0.0:
            return
        for r in range(6):
            top[r] = z[r] / m


@njit(cache=True)
def _bottom_start(
    G: npt.NDArray[np.float64],
    s: int,
    A: npt.NDArray[np.float64],
    L: npt.NDArray[np.float64],
    bottom: npt.NDArray[np.float64],
    z: npt.NDArray[np.float64],
) -> None:
    """An approximate bottom eigenvector (6,) of octant s: three inverse steps (A, L (6, 6), z (6,) scratch)."""
    octant_gram(G, s, A)
    for r in range(6):
        bottom[r] = 1.0
    if not cholesky6(A, 1.0, 0.0, L):
        return
    for _it in range(3):
        cho_solve6(L, bottom, z, bottom)
        m = 0.0
        for r in range(6):
            m = max(m, abs(bottom[r]))
        for r in range(6):
            bottom[r] /= m


@njit(cache=True)
def isotropy_batched(
    J: npt.NDArray[np.float64],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
    rowfac: npt.NDArray[np.float64],
    threshold: float,
    P: npt.NDArray[np.float64],
    G: npt.NDArray[np.float64],
    Ag: npt.NDArray[np.float64],
    W: npt.NDArray[np.float64],
    A: npt.NDArray[np.float64],
    B: npt.NDArray[np.float64],
    de: npt.NDArray[np.float64],
) -> float:
    """Isotropy index (min over octants of sigma_min/sigma_max), or -1.0 if proven <= threshold.

    Args:
        J: (6, n) TCP Jacobian, rotation rows scaled.
        pen_lo, pen_hi: (n,) joint-limit penalty factors.
        rowfac: (6, 2) penalty factor per row and sign (self-distance; ones without).
        threshold: the cell's current value; < 0 computes the exact value always.
        P (6, n, 2), G (6, 6, 2, 2), Ag (21, 64), W (W_ROWS, 64), A, B (6, 6), de (2, 6): scratch.
    """
    penalised_rows(J, pen_lo, pen_hi, rowfac, P)
    t = threshold
    t2 = t * t * (1.0 - proof_margin(t)) if t > 0.0 else 0.0
    if t > 0.0:
        # cheap first try: the most penalised octant and its complement, one at a time;
        # a sample far below its cell's value is usually settled here (~0.1 us each)
        s_pen = most_penalised_octant(P)
        if _below(P, s_pen, t2, A, B, W[4]) or _below(P, s_pen ^ 63, t2, A, B, W[4]):
            return -1.0
    gram_from(P, G)
    fill_grams(G, Ag)
    rho, mu, flag, upper, beta, done = W[0], W[1], W[2], W[3], W[4], W[5]
    top_start(G, A, de[0], beta)
    lambda_max_lower(Ag, de[0], rho)
    if t > 0.0:
        for s in range(64):
            beta[s] = -t2 * rho[s]
        pd_flags(Ag, 1.0, beta, flag)
        for s in range(64):
            if flag[s] == 0.0:
                return -1.0
    # ranking: mu / rho >= (sigma_min / sigma_max)^2 of each octant
    lambda_max_tight(Ag, de[0], rho)
    _bottom_start(G, 0, A, B, de[1], beta)
    lambda_min_upper(Ag, de[1], mu)
    ub = mu
    for s in range(64):
        ub[s] = mu[s] / rho[s] if rho[s] > 0.0 else 0.0
    s0 = 0
    for s in range(1, 64):
        if ub[s] < ub[s0]:
            s0 = s
    best = octant_value(G, s0, 0, A, P, de)
    if best <= t:
        return -1.0
    if best > 0.0:
        # certified U_s >= lambda_max(A_s): the tightest of rho * slack that Cholesky accepts, else the trace
        traces(Ag, upper)
        for slack in _U_SLACKS:
            for s in range(64):
                beta[s] = slack * rho[s]
            pd_flags(Ag, -1.0, beta, flag)
            for s in range(64):
                if flag[s] > 0.0 and beta[s] < upper[s]:
                    upper[s] = beta[s]
        c = -best * best * (1.0 + proof_margin(best))
        for s in range(64):
            beta[s] = c * upper[s]
        pd_flags(Ag, 1.0, beta, done)
    else:
        for s in range(64):
            done[s] = 0.0
    done[s0] = 1.0
    while True:
        s = -1
        for k in range(64):
            if done[k] == 0.0 and (s < 0 or ub[k] < ub[s]):
                s = k
        if s < 0:
            return best
        done[s] = 1.0
        v = octant_value(G, s, 0, A, P, de)
        if v < best:
            best = v
            if best <= t:
                return -1.0
