"""The 6x6 Cholesky and solve kernels against numpy."""

from __future__ import annotations

import numpy as np

from placement.kernels.linalg6 import cho_solve6, cholesky6


def test_cholesky6_and_solve_match_numpy():
    rng = np.random.default_rng(2)
    definite = 0
    for _ in range(300):
        X = rng.normal(size=(6, 7))
        A = X @ X.T
        w = np.linalg.eigvalsh(A)
        beta = -w[0] * rng.uniform(0.0, 2.0)  # definite about half of the time
        L = np.zeros((6, 6))
        ok = cholesky6(A, 1.0, beta, L)
        expect = w[0] + beta > 0
        if abs(w[0] + beta) > 1e-9 * w[-1]:
            assert ok == expect
        if ok:
            definite += 1
            M = A + beta * np.eye(6)
            np.testing.assert_allclose(np.tril(L), np.linalg.cholesky(M), rtol=0, atol=1e-10 * w[-1])
            b = rng.normal(size=6)
            x, z = np.empty(6), np.empty(6)
            cho_solve6(L, b, z, x)
            np.testing.assert_allclose(M @ x, b, rtol=0, atol=1e-8 * np.abs(b).max() * np.linalg.cond(M))
            y = b.copy()
            cho_solve6(L, y, y, y)  # in place, as the IK uses it
            np.testing.assert_array_equal(y, x)
    assert 50 < definite < 250
    # alpha = -1: beta I - A positive definite exactly when beta > lambda_max
    L = np.zeros((6, 6))
    assert cholesky6(A, -1.0, w[-1] * 1.01, L) and not cholesky6(A, -1.0, w[-1] * 0.99, L)
