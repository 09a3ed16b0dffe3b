"""The extended manipulability of an arm configuration (public wrapper of the kernels)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.kernels.kinematics import fk_jacobian
from placement.kernels.manipulability import joint_penalties
from placement.kernels.subspace import generic_rank, subspace_manipulability
from placement.robots import Robot
from placement.validation import finite_array

INDEX_NAMES = ("isotropy", "volume")
ROTATION_SCALE = 0.15  # Simox: rotational Jacobian rows are weighted against metres


_RANKS: dict[bytes, int] = {}


def arm_rank(robot: Robot, arm: str) -> int:
    """The generic rank r (1 .. 6) of ``arm``'s TCP Jacobian: 6 for an arm that spans every pose
    direction, 5 for a 5-joint arm or a lift with a telescoping chain and a 3-joint wrist.

    The maps' measure is taken on the r-dimensional subspace the arm spans (see
    :mod:`placement.kernels.subspace`). Computed once per chain (about a millisecond), then cached.
    """
    a = robot.arm(arm)
    ch = a.chain
    key = b"".join(np.ascontiguousarray(x).tobytes() for x in (a.lower, a.upper, *ch.arrays))
    if key not in _RANKS:
        _RANKS[key] = int(generic_rank(a.lower, a.upper, *ch.arrays, ROTATION_SCALE))
    return _RANKS[key]


def extended_manipulability(
    robot: Robot,
    arm: str,
    q: npt.ArrayLike,
    index: str = "isotropy",
    row_factors: npt.ArrayLike | None = None,
    rank: int | None = None,
) -> np.ndarray | float:
    """Simox's extended manipulability of ``arm`` at joint angles ``q``.

    Args:
        robot: the robot.
        arm: arm name.
        q: (n,) or (N, n) joint values [rad, m], in the arm's joint order.
        index: "isotropy" (min over octants of sigma_min/sigma_max, default) or
            "volume" (min over octants of the product of singular values).
        row_factors: optional (6, 2) or (N, 6, 2) penalty factor per Jacobian row
            and octant sign (0 = +, 1 = -), e.g. the self-distance penalty of
            :mod:`placement.maps.selfcollision`; all ones by default.
        rank: the dimension r (1 .. 6) of the subspace the measure is taken on: the r largest
            singular values of each octant's Jacobian count (see :mod:`placement.kernels.subspace`);
            default the arm's generic rank (:func:`arm_rank`), 6 for an ordinary arm.

    Returns:
        A float for (n,) input, else (N,) values; dimensionless (isotropy) or
        [m^r-ish] (volume), 0 at singularities.
    """
    if index not in INDEX_NAMES:
        raise PlacementError(f"unknown manipulability index '{index}'; choose from {', '.join(INDEX_NAMES)}")
    a = robot.arm(arm)
    Q = finite_array(q, "joint values q", PlacementError)
    single = Q.ndim == 1
    Q = np.atleast_2d(Q)
    if Q.ndim != 2 or Q.shape[1] != a.dof:
        raise PlacementError(f"arm '{arm}' has {a.dof} joints, got configurations of shape {Q.shape[1:]}")
    if rank is None:
        rank = arm_rank(robot, arm)
    elif isinstance(rank, bool) or not isinstance(rank, (int, np.integer)) or not 1 <= rank <= 6:
        raise PlacementError(f"rank must be a whole number from 1 to 6, got {rank!r}")
    n, ch = a.dof, a.chain
    T, J, work = np.empty((4, 4)), np.empty((6, n)), np.empty((n + 3, 4, 4))
    plo, phi, P, G, A = np.empty(n), np.empty(n), np.empty((6, n, 2)), np.empty((6, 6, 2, 2)), np.empty((6, 6))
    cont = a.continuous.astype(np.bool_)
    de = np.empty((2, 6))
    if row_factors is None:
        rf = np.ones((len(Q), 6, 2))
    else:
        rf = finite_array(row_factors, "row_factors", PlacementError)
        try:
            rf = np.broadcast_to(rf, (len(Q), 6, 2))
        except ValueError:
            raise PlacementError(f"row_factors must have shape (6, 2) or ({len(Q)}, 6, 2), got {rf.shape}") from None
    out = np.empty(len(Q))
    for i, qi in enumerate(Q):
        fk_jacobian(qi, *ch.arrays, T, J, work)
        J[3:] *= ROTATION_SCALE
        joint_penalties(qi, a.lower, a.upper, cont, plo, phi)
        rfi = np.ascontiguousarray(rf[i])
        out[i] = subspace_manipulability(J, plo, phi, rfi, INDEX_NAMES.index(index), int(rank), -1.0, P, G, A, de)
    return float(out[0]) if single else out
