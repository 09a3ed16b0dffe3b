"""The broad phase of a collision check: lower bounds of the distances between robot shapes (bounding
spheres and boxes) and scene pieces (axis-aligned boxes), and between robot shapes themselves.

Each bound is the larger of two, each no more than the distance: the sphere against the piece's box
(or two spheres), and the robot shape's axis-aligned box against the piece's box (or two such boxes).
The arithmetic is numpy's in :mod:`placement.collision.bounds`, term for term (no fused or reordered
operations), so the bounds are the same floats; a check makes a few hundred of them per pose.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit


@njit(cache=True)
def scene_pair_bounds(
    centre: npt.NDArray[np.float64],
    extent: npt.NDArray[np.float64],
    radius: npt.NDArray[np.float64],
    aabb: npt.NDArray[np.float64],
    skipped: npt.NDArray[np.bool_],
    gripper: npt.NDArray[np.bool_],
    held: npt.NDArray[np.bool_],
    cap: float,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """(a (K,), b (K,), lb (K,)): the (robot instance, scene piece) pairs whose bound [m] is within
    ``cap`` [m], row by row (instance, then piece), and their bounds.

    Args:
        centre, extent: (N, 3) each instance's bounding-box centre and half extents [m], model frame.
        radius: (N,) its bounding sphere's radius [m] about ``centre``.
        aabb: (S, 2, 3) each piece's box (lower and upper corner) [m], model frame.
        skipped: (S,) pieces that pair with nothing (objects carried away).
        gripper: (N,) instances of the gripper; held: (S,) pieces of the grasped object, which the
            gripper's instances do not pair with.
    """
    n, s = centre.shape[0], aabb.shape[0]
    a = np.empty(n * s, dtype=np.int64)
    b = np.empty(n * s, dtype=np.int64)
    lb = np.empty(n * s)
    k = 0
    for i in range(n):
        for j in range(s):
            if skipped[j] or (gripper[i] and held[j]):
                continue
            sq = 0.0  # squared distance from the centre to the box
            gq = 0.0  # squared distance between the boxes
            for ax in range(3):
                lo, hi, p, e = aabb[j, 0, ax], aabb[j, 1, ax], centre[i, ax], extent[i, ax]
                d = max(lo - p, 0.0) + max(p - hi, 0.0)
                g = max(lo - (p + e), 0.0) + max((p - e) - hi, 0.0)
                sq = d * d if ax == 0 else sq + d * d
                gq = g * g if ax == 0 else gq + g * g
            bound = max(math.sqrt(sq) - radius[i], math.sqrt(gq))
            if bound <= cap:
                a[k], b[k], lb[k] = i, j, bound
                k += 1
    return a[:k], b[:k], lb[:k]


@njit(cache=True)
def self_pair_bounds(
    centre: npt.NDArray[np.float64],
    extent: npt.NDArray[np.float64],
    radius: npt.NDArray[np.float64],
    first: npt.NDArray[np.int64],
    second: npt.NDArray[np.int64],
    cap: float,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """(kept (K,), lb (K,)): the indices into the instance pairs ``first``, ``second`` (M,) whose bound
    [m] is within ``cap`` [m], in order, and their bounds (centre, extent, radius as in
    :func:`scene_pair_bounds`)."""
    m = first.shape[0]
    kept = np.empty(m, dtype=np.int64)
    lb = np.empty(m)
    k = 0
    for q in range(m):
        u, v = first[q], second[q]
        sq = 0.0
        gq = 0.0
        for ax in range(3):
            d = centre[u, ax] - centre[v, ax]
            g = max(abs(d) - extent[u, ax] - extent[v, ax], 0.0)
            sq = d * d if ax == 0 else sq + d * d
            gq = g * g if ax == 0 else gq + g * g
        bound = max(math.sqrt(sq) - radius[u] - radius[v], math.sqrt(gq))
        if bound <= cap:
            kept[k], lb[k] = q, bound
            k += 1
    return kept[:k], lb[:k]
