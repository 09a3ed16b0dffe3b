"""The extended manipulability of Vahrenkamp et al. (Humanoids 2012), as Simox computes it.

For a (6, n) TCP Jacobian J (LOCAL frame, rotation rows already scaled) and
per-joint penalty factors, each of the 64 sign vectors s of the Cartesian
hyper-octants gives a penalised Jacobian ``J_s``; the measure is the worst case
over the octants: ``min_s sigma_min(J_s)/sigma_max(J_s)`` (isotropy) or
``min_s prod sigma(J_s)`` (volume).

All octant Gram matrices ``A_s = J_s J_s^T`` share one table: row r of ``J_s``
depends only on the sign s_r, so ``A_s[r, c] = P[r, :, s_r] . P[c, :, s_c]``
with ``P[r, j, a] = J[r, j] * factor(r, j, a)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

ISOTROPY = 0
VOLUME = 1
N_OCTANTS = 64


@njit(cache=True)
def joint_penalties(q, lower, upper, continuous, pen_lo, pen_hi):
    """Simox joint-limit penalty factors, written into pen_lo / pen_hi (n,).

    Motion towards the nearer limit is scaled by 1/sqrt(1+w), away from it by 1;
    continuous joints are never penalised.
    """
    for j in range(q.shape[0]):
        pen_lo[j] = 1.0
        pen_hi[j] = 1.0
        if continuous[j]:
            continue
        t, lo, hi = q[j], lower[j], upper[j]
        if t - lo < 1e-10 or hi - t < 1e-10:
            w = 1e10
        else:
            w = abs((hi - lo) ** 2 * (2.0 * t - hi - lo) / (4.0 * (hi - t) ** 2 * (t - lo) ** 2))
        f = 1.0 / math.sqrt(1.0 + w)
        if t - lo < hi - t:
            pen_lo[j] = f
        else:
            pen_hi[j] = f


@njit(cache=True)
def gram_table(J, pen_lo, pen_hi, P, G):
    """Fill P (6, n, 2) and G (6, 6, 2, 2) for the octant Gram matrices (sign index 0 = +, 1 = -)."""
    n = J.shape[1]
    for r in range(6):
        for j in range(n):
            v = J[r, j]
            # sign +: moving the row's coordinate up needs q_j up when J >= 0 -> towards hi
            P[r, j, 0] = v * (pen_lo[j] if v < 0.0 else pen_hi[j])
            P[r, j, 1] = v * (pen_hi[j] if v < 0.0 else pen_lo[j])
    for r in range(6):
        for c in range(r, 6):
            for a in range(2):
                for b in range(2):
                    acc = 0.0
                    for j in range(n):
                        acc += P[r, j, a] * P[c, j, b]
                    G[r, c, a, b] = acc
                    G[c, r, b, a] = acc


@njit(cache=True, inline="always")
def octant_gram(G, s, A):
    """A (6, 6) <- the Gram matrix of octant s (bit r of s set = negative sign of row r)."""
    for r in range(6):
        a = (s >> r) & 1
        for c in range(r, 6):
            b = (s >> c) & 1
            A[r, c] = G[r, c, a, b]
            A[c, r] = A[r, c]


@njit(cache=True)
def sym_eig_extremes(A):
    """Smallest and largest eigenvalue of a symmetric (6, 6) matrix by cyclic Jacobi.

    A is overwritten. Jacobi keeps small eigenvalues of positive semi-definite
    matrices to high accuracy, which the isotropy ratio needs.
    """
    n = A.shape[0]
    for sweep in range(60):
        off = 0.0
        diag = 0.0
        for p in range(n):
            diag += A[p, p] * A[p, p]
            for q in range(p + 1, n):
                off += A[p, q] * A[p, q]
        if off <= 1e-32 * diag or off == 0.0:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = A[p, q]
                if apq == 0.0:
                    continue
                theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                tau = s / (1.0 + c)
                A[p, p] -= t * apq
                A[q, q] += t * apq
                A[p, q] = 0.0
                A[q, p] = 0.0
                for r in range(n):
                    if r != p and r != q:
                        arp = A[r, p]
                        arq = A[r, q]
                        A[r, p] = arp - s * (arq + tau * arp)
                        A[p, r] = A[r, p]
                        A[r, q] = arq + s * (arp - tau * arq)
                        A[q, r] = A[r, q]
    lmin = A[0, 0]
    lmax = A[0, 0]
    for p in range(1, n):
        lmin = min(lmin, A[p, p])
        lmax = max(lmax, A[p, p])
    return lmin, lmax


@njit(cache=True)
def chol_det(A):
    """Determinant of a symmetric (6, 6) matrix by Cholesky; 0 if not positive definite."""
    n = A.shape[0]
    L = np.empty((n, n))
    det = 1.0
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if d <= 0.0:
            return 0.0
        det *= d
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            v = A[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
    return det


@njit(cache=True)
def octant_value(G, s, index, A):
    """The index value of one octant: sigma_min/sigma_max (isotropy) or prod sigma (volume)."""
    octant_gram(G, s, A)
    if index == VOLUME:
        return math.sqrt(chol_det(A))
    lmin, lmax = sym_eig_extremes(A)
    if lmax <= 0.0 or lmin <= 0.0:
        return 0.0
    return math.sqrt(lmin / lmax)


@njit(cache=True)
def extended_manipulability(J, pen_lo, pen_hi, index, threshold, P, G, A):
    """Worst case over the 64 octants, or -1.0 as soon as it is proven <= threshold.

    ``threshold`` < 0 computes the exact value always. Returning early is exact:
    the minimum over octants can only fall below any octant's value.
    """
    gram_table(J, pen_lo, pen_hi, P, G)
    best = np.inf
    for s in range(N_OCTANTS):
        v = octant_value(G, s, index, A)
        if v < best:
            best = v
            if best <= threshold:
                return -1.0
    return best
