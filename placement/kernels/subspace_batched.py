"""The isotropy index on an arm's r-dimensional subspace (r < 6), decided by batched proofs.

Same value, bitwise, as :func:`placement.kernels.subspace.subspace_manipulability` with ``ISOTROPY``:
the octants that decide the minimum are computed by the same routine (``octant_value_rank``), every
other octant is *proven* not to be below the running minimum, as :mod:`placement.kernels.isotropy`
does for rank 6 (the most penalised octant first, exactly, as the octant-by-octant kernel: most samples
that cannot raise their cell stop there). Octant s's value is ``sqrt(lambda_r(A_s) / lambda_1(A_s))`` (eigenvalues of its
Gram matrix ``A_s``, largest first); the bounds on ``lambda_r`` come from Courant-Fischer in a basis
``E`` (6, 6, orthonormal columns): the eigenvectors of the most penalised octant, largest first.
With ``B_s = E^T A_s E``:

- ``lambda_r(A_s) <= lambda_max`` of ``B_s``'s trailing (7 - r) x (7 - r) block (a (7 - r)-dimensional
  subspace: the min-max form), closed form for r = 5, the block's trace below;
- ``lambda_r(A_s) >= c`` when ``B_s``'s leading r x r block minus c I is positive definite (Cholesky;
  the max-min form);
- ``lambda_1(A_s) >= rho_s`` (Rayleigh quotients after power steps) and ``<= U_s`` (certified by
  Cholesky, else the trace), the kernels of :mod:`placement.kernels.octants`.

``E`` orthonormal to rounding makes ``B_s`` congruent to ``A_s`` (Ostrowski: eigenvalues equal within a
relative ~1e-15); the proofs keep the relative margins of the rank-6 path (``proof_margin``), far above that.
"""

from __future__ import annotations

import math

from numba import njit

from placement.kernels.isotropy import proof_margin
from placement.kernels.manipulability import gram_table, most_penalised_octant, octant_gram
from placement.kernels.octants import fill_grams, lambda_max_lower, pd_flags, traces
from placement.kernels.octants_refine import lambda_max_tight
from placement.kernels.subspace import octant_value_rank

__all__ = ["eigenvectors6", "rotated_grams", "subspace_isotropy_batched"]

#: Jacobi sweeps at most for the basis E (any orthonormal E gives valid bounds; near-eigenvectors tight ones).
SWEEPS = 8
#: Slacks tried for the certified upper bound U_s = slack * rho_s >= lambda_1 (as the rank-6 path).
U_SLACKS = (1.001, 1.03)


@njit(cache=True)
def eigenvectors6(A, E, lam):
    """Cyclic Jacobi on the symmetric (6, 6) ``A`` (overwritten): E (6, 6) <- orthonormal eigenvectors as
    columns, lam (6,) <- eigenvalues, both sorted largest first. Returns whether it converged (the
    off-diagonal part below 1e-15 of the diagonal's norm: lam are then eigenvalues within that, by Weyl);
    E is orthonormal to rounding either way."""
    converged = False
    for r in range(6):
        for c in range(6):
            E[r, c] = 1.0 if r == c else 0.0
    for _sweep in range(SWEEPS):
        off = 0.0
        diag = 0.0
        for p in range(6):
            diag += A[p, p] * A[p, p]
            for q in range(p + 1, 6):
                off += A[p, q] * A[p, q]
        if off <= 1e-30 * diag:
            converged = True
            break
        for p in range(5):
            for q in range(p + 1, 6):
                apq = A[p, q]
                if apq == 0.0:
                    continue
                theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(6):
                    akp = A[k, p]
                    akq = A[k, q]
                    A[k, p] = c * akp - s * akq
                    A[k, q] = s * akp + c * akq
                for k in range(6):
                    apk = A[p, k]
                    aqk = A[q, k]
                    A[p, k] = c * apk - s * aqk
                    A[q, k] = s * apk + c * aqk
                for k in range(6):
                    ekp = E[k, p]
                    ekq = E[k, q]
                    E[k, p] = c * ekp - s * ekq
                    E[k, q] = s * ekp + c * ekq
    for k in range(6):
        lam[k] = A[k, k]
    # selection sort of the columns, largest eigenvalue first
    for i in range(5):
        m = i
        for k in range(i + 1, 6):
            if lam[k] > lam[m]:
                m = k
        if m != i:
            lam[i], lam[m] = lam[m], lam[i]
            for k in range(6):
                E[k, i], E[k, m] = E[k, m], E[k, i]
    return converged


@njit(cache=True)
def rotated_grams(Ag, E, B, C):
    """B (21, 64) <- ``E^T A_s E`` of every octant s from Ag (21, 64), the packed ``A_s`` of
    :func:`placement.kernels.octants.fill_grams` (entry (r, c), r >= c, in row r (r + 1) / 2 + c).

    Each packed entry of B is a fixed combination of A_s's packed entries, ``B = C Ag`` with C (21, 21)
    (scratch) from E: one product whose inner loop runs across the octants (SIMD)."""
    for r in range(6):
        for c in range(r + 1):
            i = r * (r + 1) // 2 + c
            for k in range(6):
                for m in range(k + 1):
                    j = k * (k + 1) // 2 + m
                    C[i, j] = E[k, r] * E[k, c] if k == m else E[k, r] * E[m, c] + E[m, r] * E[k, c]
    for i in range(21):
        for s in range(64):
            B[i, s] = 0.0
        for j in range(21):
            f = C[i, j]
            for s in range(64):
                B[i, s] += f * Ag[j, s]


@njit(cache=True, inline="always")
def _lambda_r_upper(B, s, rank):
    """An upper bound of lambda_rank(A_s): lambda_max of B_s's trailing (7 - rank) block (closed form for a
    2 x 2 block, else its trace: the block is positive semi-definite)."""
    k = rank - 1
    if rank == 5:
        a = B[14, s]
        b = B[19, s]
        d = B[20, s]
        h = 0.5 * (a - d)
        return 0.5 * (a + d) + math.sqrt(h * h + b * b)
    acc = 0.0
    for i in range(k, 6):
        acc += B[i * (i + 1) // 2 + i, s]
    return acc


@njit(cache=True)
def _lambda_r_above(B, s, rank, c, L):
    """True when B_s's leading rank x rank block minus c I is positive definite (Cholesky; L (6, 6)
    scratch): then lambda_rank(A_s) > c."""
    for i in range(rank):
        for j in range(i + 1):
            acc = B[i * (i + 1) // 2 + j, s] - (c if i == j else 0.0)
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            if i == j:
                if not acc > 0.0:
                    return False
                L[i, i] = math.sqrt(acc)
            else:
                L[i, j] = acc / L[j, j]
    return True


@njit(cache=True)
def subspace_isotropy_batched(J, pen_lo, pen_hi, rowfac, rank, threshold, P, G, Ag, Rg, W, A, B, S, C, de):
    """The rank-``rank`` isotropy index (min over octants of sigma_rank/sigma_1), or -1.0 if proven <= threshold.

    Args:
        J: (6, n) TCP Jacobian, rotation rows scaled; pen_lo, pen_hi: (n,) joint-limit penalty factors;
        rowfac: (6, 2) row factors (self-distance; ones without); rank: the arm's generic rank, 1 .. 5;
        threshold: the cell's current value; < 0 computes the exact value always.
        P (6, n, 2), G (6, 6, 2, 2), Ag, Rg (21, 64), W (6, 64), A, B (6, 6), S (2, 6, 6), C (21, 21),
        de (2, 6): scratch (P to W as :func:`placement.kernels.isotropy.isotropy_batched`).
    """
    gram_table(J, pen_lo, pen_hi, rowfac, P, G)
    t = threshold
    t2 = t * t * (1.0 - proof_margin(t)) if t > 0.0 else 0.0
    # the most penalised octant first, exactly: a sample far below its cell's value is usually settled here
    s_pen = most_penalised_octant(P)
    best = octant_value_rank(G, s_pen, 0, rank, A, P, de)
    if best <= t:
        return -1.0
    octant_gram(G, s_pen, A)
    E = B
    eigenvectors6(A, E, de[0])
    rho, upper, beta, flag, ub, done = W[0], W[1], W[2], W[3], W[4], W[5]
    fill_grams(G, Ag)
    top = de[1]
    for r in range(6):
        top[r] = E[r, 0]
    lambda_max_lower(Ag, top, rho)
    L = S[0]
    rotated_grams(Ag, E, Rg, C)
    for s in range(64):
        ub[s] = _lambda_r_upper(Rg, s, rank)
    if t > 0.0:
        for s in range(64):
            if ub[s] < t2 * rho[s]:
                return -1.0
    lambda_max_tight(Ag, top, rho)
    for s in range(64):
        ub[s] = ub[s] / rho[s] if rho[s] > 0.0 else 0.0
    s0 = 0
    for s in range(1, 64):
        if ub[s] < ub[s0]:
            s0 = s
    if s0 != s_pen:
        best = min(best, octant_value_rank(G, s0, 0, rank, A, P, de))
        if best <= t:
            return -1.0
    for s in range(64):
        done[s] = 0.0
    done[s_pen] = 1.0
    if best > 0.0:
        traces(Ag, upper)
        for slack in U_SLACKS:
            for s in range(64):
                beta[s] = slack * rho[s]
            pd_flags(Ag, -1.0, beta, flag)
            for s in range(64):
                if flag[s] > 0.0 and beta[s] < upper[s]:
                    upper[s] = beta[s]
        c = best * best * (1.0 + proof_margin(best))
        for s in range(64):
            if _lambda_r_above(Rg, s, rank, c * upper[s], L):
                done[s] = 1.0
    done[s0] = 1.0
    while True:
        s = -1
        for k in range(64):
            if done[k] == 0.0 and (s < 0 or ub[k] < ub[s]):
                s = k
        if s < 0:
            return best
        done[s] = 1.0
        v = octant_value_rank(G, s, 0, rank, A, P, de)
        if v < best:
            best = v
            if best <= t:
                return -1.0
