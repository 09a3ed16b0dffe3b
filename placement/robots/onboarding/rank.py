"""How many of the 6 pose directions an arm spans: the rank of its 6 x n Jacobian at random configurations.

An arm of fewer than 6 joints, or with joints that move the TCP alike (a telescoping chain of prismatic
joints along one axis), cannot reach every position and orientation from one base pose; the planner's
base motion supplies a missing direction, and grasps whose orientation the arm cannot take are left
out. ``robots init`` and ``robots check`` say so in plain words (:func:`rank_warning`).
"""

from __future__ import annotations

import numpy as np

from placement.robots.chain import PRISMATIC, Chain
from placement.robots.onboarding.reach import rotations

#: Random configurations the rank is taken over (the largest rank found: the arm's generic rank).
RANK_SAMPLES = 16
#: Singular values below this (in the Jacobian's units, [m] and [1]) count as zero.
RANK_TOLERANCE = 1e-6


def jacobian(chain: Chain, q: np.ndarray) -> np.ndarray:
    """(6, n) Jacobian of the canonical TCP in the base frame at ``q`` (n,) [rad or m]: rows linear
    [m per rad or m], then angular; a revolute column is [w x (p - o); w], a prismatic one [w; 0]."""
    n = len(chain.kind)
    T = np.eye(4)
    origins, axes = np.zeros((n, 3)), np.zeros((n, 3))
    for i in range(n):
        T = T @ chain.link_T[i]
        origins[i], axes[i] = T[:3, 3], T[:3, :3] @ chain.axis[i]
        M = np.eye(4)
        if chain.kind[i] == PRISMATIC:
            M[:3, 3] = q[i] * chain.axis[i]
        else:
            M[:3, :3] = rotations(chain.axis[i], np.array([q[i]]))[0]
        T = T @ M
    p = (T @ chain.tip_T)[:3, 3]
    J = np.zeros((6, n))
    for i in range(n):
        if chain.kind[i] == PRISMATIC:
            J[:3, i] = axes[i]
        else:
            J[:3, i] = np.cross(axes[i], p - origins[i])
            J[3:, i] = axes[i]
    return J


def pose_rank(chain: Chain, lower: np.ndarray, upper: np.ndarray, samples: int = RANK_SAMPLES, seed: int = 0) -> int:
    """The largest rank of the arm's Jacobian over ``samples`` uniform configurations within [lower, upper]
    (n,) [rad or m]: 6 for an arm that reaches full poses."""
    ok = np.isfinite(lower) & np.isfinite(upper)  # unusable limits are refused when the preset loads
    lo, hi = np.where(ok, np.minimum(lower, upper), -np.pi), np.where(ok, np.maximum(lower, upper), np.pi)
    Q = np.random.default_rng(seed).uniform(lo, hi, size=(samples, len(lower)))
    return max(int(np.linalg.matrix_rank(jacobian(chain, q), tol=RANK_TOLERANCE)) for q in Q)


def rank_warning(arm: str, rank: int) -> str | None:
    """Plain words for an arm spanning ``rank`` < 6 pose directions (None for a full 6)."""
    if rank >= 6:
        return None
    missing = 6 - rank
    if missing == 1:
        supply = "the base's motion on the floor supplies the missing one"
    else:
        supply = f"the base's motion on the floor (x, y, yaw) supplies at most 3 of the {missing} missing ones"
    return (
        f"arm '{arm}' spans {rank} of the 6 pose directions: {supply}; grasps whose orientation it "
        "cannot reach are left out"
    )
