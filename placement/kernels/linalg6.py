"""Small dense linear algebra on 6x6 matrices (one at a time; the batched kind is in octants.py)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit


@njit(cache=True)
def cholesky6(A: npt.NDArray[np.float64], alpha: float, beta: float, L: npt.NDArray[np.float64]) -> bool:
    """Whether alpha * A + beta * I (symmetric (6, 6)) is positive definite; its factor goes into L.

    Only the lower triangles of A and L are used. Stops at the first pivot <= 0.
    """
    for j in range(6):
        d = alpha * A[j, j] + beta
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        ljj = math.sqrt(d)
        L[j, j] = ljj
        for i in range(j + 1, 6):
            v = alpha * A[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / ljj
    return True


@njit(cache=True)
def cho_solve6(
    L: npt.NDArray[np.float64], b: npt.NDArray[np.float64], z: npt.NDArray[np.float64], x: npt.NDArray[np.float64]
) -> None:
    """x (6,) <- (L L^T)^-1 b through z (6,); x may be b or z."""
    for r in range(6):
        acc = b[r]
        for c in range(r):
            acc -= L[r, c] * z[c]
        z[r] = acc / L[r, r]
    for r in range(5, -1, -1):
        acc = z[r]
        for c in range(r + 1, 6):
            acc -= L[c, r] * x[c]
        x[r] = acc / L[r, r]
