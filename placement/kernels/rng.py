"""Counter-based random numbers: sample i of seed s is a pure function of (s, i).

That makes a map independent of how the samples are split over threads,
processes or Dask workers.
"""

from __future__ import annotations

import numpy as np
from numba import njit, uint64

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, inline="always")
def splitmix64(x: np.uint64) -> np.uint64:
    """The splitmix64 finaliser of x + golden ratio (a 64-bit bijective hash)."""
    z = x + _GOLDEN
    z = (z ^ (z >> uint64(30))) * _M1
    z = (z ^ (z >> uint64(27))) * _M2
    return z ^ (z >> uint64(31))


@njit(cache=True, inline="always")
def uniform(seed: np.uint64, counter: int) -> float:
    """A float64 in [0, 1) from 53 hashed bits of (seed, counter)."""
    h = splitmix64(splitmix64(uint64(seed)) ^ uint64(counter))
    return float(h >> uint64(11)) * (1.0 / 9007199254740992.0)
