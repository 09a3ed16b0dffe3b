"""The ranking kernel against a plain numpy reference (the ranking as first written)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from placement.kernels.ranking import rank_window

K = 25


def reference(value, nav, heur, thr, lam_n, lam_m, lam_nh, k):
    """Eq. 6 on the cells keeping the threshold, tiers by the 3 x 3 minimum filter, stable argsort."""
    reach = (value >= thr) & np.isfinite(nav) & np.isfinite(heur)
    c = np.full(value.shape, np.inf)
    c[reach] = lam_n * nav[reach] + lam_m / value[reach] + lam_nh * heur[reach]
    inner = ndimage.minimum_filter(value, size=3, mode="constant", cval=0.0) >= thr
    out = []
    for mask in (reach & inner, reach & ~inner):
        flat = np.flatnonzero(mask)
        top = flat[np.argsort(c.flat[flat], kind="stable")[:k]]
        out += [top, c.flat[top]]
    return out


@pytest.mark.parametrize("seed", range(30))
def test_kernel_equals_reference(seed):
    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 40, size=2)
    thr = float(rng.choice([0.0235, 0.01, 0.1]))
    value = rng.uniform(0, 0.2, (h, w)).astype(np.float32)
    value[rng.random((h, w)) < 0.3] = 0
    value[rng.random((h, w)) < 0.1] = np.float32(thr)  # exactly at the (float32) threshold
    if seed % 3 == 0:
        value = np.round(value, 2).astype(np.float32)  # ties in cost
    nav = rng.uniform(0, 10, (h, w)).round(seed % 2 + 1)
    heur = rng.uniform(0, 10, (h, w)) if seed % 4 else np.zeros((h, w))
    nav[rng.random((h, w)) < 0.1] = np.inf
    heur[rng.random((h, w)) < 0.05] = np.inf
    lam = (1 / 20, 0.002353, 1 / 20 if seed % 4 else 0.0)
    got = rank_window(value, nav, heur, np.float32(thr), lam[0], np.float32(lam[1]), lam[2], K)
    want = reference(value, nav, heur, thr, *lam, K)
    for g, r in zip(got, want):
        assert np.array_equal(g, r), (g, r)
    assert sum(len(g) for g in got[::2]) > 0 or not (value >= thr).any()
