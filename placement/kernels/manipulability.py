"""The extended manipulability of Vahrenkamp et al. (Humanoids 2012), as Simox computes it.

For a (6, n) TCP Jacobian J (LOCAL frame, rotation rows already scaled) and
per-joint penalty factors, each of the 64 sign vectors s of the Cartesian
hyper-octants gives a penalised Jacobian ``J_s``; the measure is the worst case
over the octants: ``min_s sigma_min(J_s)/sigma_max(J_s)`` (isotropy) or
``min_s prod sigma(J_s)`` (volume).

Arms that span fewer than six dimensions (a 5-joint arm; a lift, a telescoping
chain and a wrist, whose 6 x 8 Jacobian has rank 5 everywhere) would score 0
everywhere: sigma_min of a rank-deficient Jacobian is 0. For them the measure is
taken on the subspace the arm spans (:mod:`placement.kernels.subspace`): with
r the arm's generic rank (the largest numerical rank of J over random
configurations; 6 for ordinary arms, whose values are unchanged), each octant's
isotropy is ``sigma_r/sigma_1`` and its volume ``prod`` of the r largest
singular values, the worst case over octants as before. The base's planar
motion supplies the degrees of freedom the arm lacks to reach a pose (the
planner moves it anyway), so what the map should rank is how well-conditioned
the arm is in the motions it can make, which this value still does: it drops
near singularities and joint limits of those motions, and is comparable between
cells of one arm (not with rank-6 arms' values: the map records r).

All octant Gram matrices ``A_s = J_s J_s^T`` share one table: row r of ``J_s``
depends only on the sign s_r, so ``A_s[r, c] = P[r, :, s_r] . P[c, :, s_c]``
with ``P[r, j, a] = J[r, j] * factor(r, j, a)``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

ISOTROPY = 0
VOLUME = 1
N_OCTANTS = 64


@njit(cache=True)
def joint_penalties(
    q: npt.NDArray[np.float64],
    lower: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    continuous: npt.NDArray[np.bool_],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
) -> None:
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
def penalised_rows(
    J: npt.NDArray[np.float64],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
    rowfac: npt.NDArray[np.float64],
    P: npt.NDArray[np.float64],
) -> None:
    """P (6, n, 2) <- each Jacobian entry times its penalties for either sign of its row (0 = +, 1 = -).

    pen_lo, pen_hi (n,): joint-limit factors; rowfac (6, 2): a factor per row
    and sign (the self-distance penalty; all ones without it).
    """
    n = J.shape[1]
    for r in range(6):
        f0 = rowfac[r, 0]
        f1 = rowfac[r, 1]
        for j in range(n):
            v = J[r, j]
            # sign +: moving the row's coordinate up needs q_j up when J >= 0 -> towards hi
            P[r, j, 0] = v * (pen_lo[j] if v < 0.0 else pen_hi[j]) * f0
            P[r, j, 1] = v * (pen_hi[j] if v < 0.0 else pen_lo[j]) * f1


@njit(cache=True)
def gram_from(P: npt.NDArray[np.float64], G: npt.NDArray[np.float64]) -> None:
    """G (6, 6, 2, 2) <- all row products of P: the entries of every octant's Gram matrix."""
    n = P.shape[1]
    for r in range(6):
        for c in range(r, 6):
            for a in range(2):
                for b in range(2):
                    acc = 0.0
                    for j in range(n):
                        acc += P[r, j, a] * P[c, j, b]
                    G[r, c, a, b] = acc
                    G[c, r, b, a] = acc


@njit(cache=True)
def most_penalised_octant(P: npt.NDArray[np.float64]) -> int:
    """The octant whose rows take the more penalised sign each (smaller row norm in P (6, n, 2)).

    Usually the worst octant or close to it: trying it first settles most samples that cannot raise
    their cell at once.
    """
    n = P.shape[1]
    s = 0
    for r in range(6):
        d0 = 0.0
        d1 = 0.0
        for j in range(n):
            d0 += P[r, j, 0] * P[r, j, 0]
            d1 += P[r, j, 1] * P[r, j, 1]
        if d1 < d0:
            s |= 1 << r
    return s


@njit(cache=True)
def gram_table(
    J: npt.NDArray[np.float64],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
    rowfac: npt.NDArray[np.float64],
    P: npt.NDArray[np.float64],
    G: npt.NDArray[np.float64],
) -> None:
    """Fill P (6, n, 2) and G (6, 6, 2, 2) for the octant Gram matrices (sign index 0 = +, 1 = -)."""
    penalised_rows(J, pen_lo, pen_hi, rowfac, P)
    gram_from(P, G)


@njit(cache=True)
def octant_gram_direct(P: npt.NDArray[np.float64], s: int, A: npt.NDArray[np.float64]) -> None:
    """A (6, 6) <- the Gram matrix of octant s straight from P (bitwise equal to :func:`octant_gram`)."""
    n = P.shape[1]
    for r in range(6):
        a = (s >> r) & 1
        for c in range(r, 6):
            b = (s >> c) & 1
            acc = 0.0
            for j in range(n):
                acc += P[r, j, a] * P[c, j, b]
            A[r, c] = acc
            A[c, r] = acc


@njit(cache=True, inline="always")
def octant_gram(G: npt.NDArray[np.float64], s: int, A: npt.NDArray[np.float64]) -> None:
    """A (6, 6) <- the Gram matrix of octant s (bit r of s set = negative sign of row r)."""
    for r in range(6):
        a = (s >> r) & 1
        for c in range(r, 6):
            b = (s >> c) & 1
            A[r, c] = G[r, c, a, b]
            A[c, r] = A[r, c]


@njit(cache=True)
def sym_eig_extremes(A: npt.NDArray[np.float64], de: npt.NDArray[np.float64]) -> tuple[float, float]:
    """Smallest and largest eigenvalue of a symmetric (6, 6) matrix (A and de (2, 6) are overwritten).

    Householder tridiagonalisation, then implicit QL with Wilkinson shifts
    (eigenvalues only): backward stable, absolute error ~eps * |A|, about three
    times cheaper than cyclic Jacobi.
    """
    n = 6
    d = de[0]
    e = de[1]
    for i in range(n - 1, 0, -1):
        l = i - 1
        h = 0.0
        if l > 0:
            scale = 0.0
            for k in range(l + 1):
                scale += abs(A[i, k])
            if scale == 0.0:
                e[i] = A[i, l]
            else:
                for k in range(l + 1):
                    A[i, k] /= scale
                    h += A[i, k] * A[i, k]
                f = A[i, l]
                g = -math.sqrt(h) if f >= 0.0 else math.sqrt(h)
                e[i] = scale * g
                h -= f * g
                A[i, l] = f - g
                f = 0.0
                for j in range(l + 1):
                    g = 0.0
                    for k in range(j + 1):
                        g += A[j, k] * A[i, k]
                    for k in range(j + 1, l + 1):
                        g += A[k, j] * A[i, k]
                    e[j] = g / h
                    f += e[j] * A[i, j]
                hh = f / (h + h)
                for j in range(l + 1):
                    f = A[i, j]
                    g = e[j] - hh * f
                    e[j] = g
                    for k in range(j + 1):
                        A[j, k] -= f * e[k] + g * A[i, k]
        else:
            e[i] = A[i, l]
    for i in range(n):
        d[i] = A[i, i]
    for i in range(1, n):
        e[i - 1] = e[i]
    e[n - 1] = 0.0
    for l in range(n):
        for _it in range(60):
            m = l
            while m < n - 1:
                dd = abs(d[m]) + abs(d[m + 1])
                if abs(e[m]) + dd == dd:
                    break
                m += 1
            if m == l:
                break
            g = (d[l + 1] - d[l]) / (2.0 * e[l])
            r = math.sqrt(g * g + 1.0)
            g = d[m] - d[l] + e[l] / (g + (r if g >= 0.0 else -r))
            s = 1.0
            c = 1.0
            p = 0.0
            i = m - 1
            underflow = False
            while i >= l:
                f = s * e[i]
                b = c * e[i]
                r = math.sqrt(f * f + g * g)
                e[i + 1] = r
                if r == 0.0:
                    d[i + 1] -= p
                    e[m] = 0.0
                    underflow = True
                    break
                s = f / r
                c = g / r
                g = d[i + 1] - p
                r = (d[i] - g) * s + 2.0 * c * b
                p = s * r
                d[i + 1] = g + p
                g = c * r - b
                i -= 1
            if underflow:
                continue
            d[l] -= p
            e[l] = g
            e[m] = 0.0
    lmin = d[0]
    lmax = d[0]
    for p in range(1, n):
        lmin = min(lmin, d[p])
        lmax = max(lmax, d[p])
    return lmin, lmax


# Below this isotropy the Gram-matrix route (which squares the condition number)
# may lose ~1e-12 absolute; such octants are recomputed from J_s itself.
ACCURATE_BELOW = 1e-4


@njit(cache=True)
def octant_r(P: npt.NDArray[np.float64], s: int, R: npt.NDArray[np.float64]) -> None:
    """R (6, 6) upper triangular with J_s^T = Q R (Householder QR of the (n, 6) J_s^T)."""
    n = P.shape[1]
    M = np.empty((n, 6))
    for j in range(n):
        for r in range(6):
            M[j, r] = P[r, j, (s >> r) & 1]
    v = np.empty(n)
    for k in range(6):
        norm = 0.0
        for i in range(k, n):
            norm += M[i, k] * M[i, k]
        norm = math.sqrt(norm)
        if norm == 0.0:
            continue
        alpha = -norm if M[k, k] >= 0.0 else norm
        vnorm = 0.0
        for i in range(k, n):
            v[i] = M[i, k]
        v[k] -= alpha
        for i in range(k, n):
            vnorm += v[i] * v[i]
        if vnorm == 0.0:
            continue
        for c in range(k, 6):
            dot = 0.0
            for i in range(k, n):
                dot += v[i] * M[i, c]
            f = 2.0 * dot / vnorm
            for i in range(k, n):
                M[i, c] -= f * v[i]
    for r in range(6):
        for c in range(6):
            # an arm of n < 6 joints: rows n.. of R are 0
            R[r, c] = M[r, c] if c >= r and r < n else 0.0


@njit(cache=True)
def jacobi_columns(R: npt.NDArray[np.float64]) -> None:
    """One-sided Jacobi on a (6, 6) matrix, in place: afterwards the column norms of R are its singular values."""
    for _sweep in range(60):
        rotated = False
        for p in range(5):
            for q in range(p + 1, 6):
                a = 0.0
                b = 0.0
                c = 0.0
                for i in range(6):
                    a += R[i, p] * R[i, p]
                    b += R[i, q] * R[i, q]
                    c += R[i, p] * R[i, q]
                if c == 0.0 or abs(c) <= 1e-15 * math.sqrt(a * b):
                    continue
                rotated = True
                zeta = (b - a) / (2.0 * c)
                t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                cs = 1.0 / math.sqrt(1.0 + t * t)
                sn = cs * t
                for i in range(6):
                    x = R[i, p]
                    y = R[i, q]
                    R[i, p] = cs * x - sn * y
                    R[i, q] = sn * x + cs * y
        if not rotated:
            break


@njit(cache=True)
def _singular_extremes(R: npt.NDArray[np.float64]) -> tuple[float, float]:
    """Smallest and largest singular value of a (6, 6) matrix by one-sided Jacobi (R is overwritten)."""
    jacobi_columns(R)
    smin = np.inf
    smax = 0.0
    for c in range(6):
        acc = 0.0
        for i in range(6):
            acc += R[i, c] * R[i, c]
        sv = math.sqrt(acc)
        smin = min(smin, sv)
        smax = max(smax, sv)
    return smin, smax


@njit(cache=True)
def _isotropy_from(lmin: float, lmax: float, P: npt.NDArray[np.float64], s: int, R: npt.NDArray[np.float64]) -> float:
    """sigma_min/sigma_max of octant s from its Gram eigenvalues, refined from J_s when small."""
    v = math.sqrt(lmin / lmax) if lmin > 0.0 and lmax > 0.0 else 0.0
    if v < ACCURATE_BELOW:
        octant_r(P, s, R)
        smin, smax = _singular_extremes(R)
        v = smin / smax if smax > 0.0 else 0.0
    return v


@njit(cache=True)
def octant_value(
    G: npt.NDArray[np.float64],
    s: int,
    index: int,
    A: npt.NDArray[np.float64],
    P: npt.NDArray[np.float64],
    de: npt.NDArray[np.float64],
) -> float:
    """The index value of one octant: sigma_min/sigma_max (isotropy) or prod sigma (volume)."""
    if index == VOLUME:
        octant_r(P, s, A)
        vol = 1.0
        for r in range(6):
            vol *= abs(A[r, r])
        return vol
    octant_gram(G, s, A)
    lmin, lmax = sym_eig_extremes(A, de)
    return _isotropy_from(lmin, lmax, P, s, A)


@njit(cache=True)
def extended_manipulability(
    J: npt.NDArray[np.float64],
    pen_lo: npt.NDArray[np.float64],
    pen_hi: npt.NDArray[np.float64],
    rowfac: npt.NDArray[np.float64],
    index: int,
    threshold: float,
    P: npt.NDArray[np.float64],
    G: npt.NDArray[np.float64],
    A: npt.NDArray[np.float64],
    de: npt.NDArray[np.float64],
) -> float:
    """Worst case over the 64 octants, or -1.0 as soon as it is proven <= threshold.

    ``threshold`` < 0 computes the exact value always. Returning early is exact:
    the minimum over octants can only fall below any octant's value.
    """
    gram_table(J, pen_lo, pen_hi, rowfac, P, G)
    best = np.inf
    for s in range(N_OCTANTS):
        v = octant_value(G, s, index, A, P, de)
        if v < best:
            best = v
            if best <= threshold:
                return -1.0
    return best
