"""The broad phase of a collision check: which (robot shape, scene piece) and (robot shape, robot shape)
pairs can be within the clearance cap, each with a lower bound of its distance."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from placement.collision.bounds import box_distance
from placement.collision.robot import ArmShapes
from placement.collision.tables import Instances, Pairs, ScenePieces


def candidate_pairs(
    inst: Instances,
    scene: ScenePieces,
    shapes: ArmShapes,
    ngeoms: int,
    cap: float,
    grasped: str | None,
    gone: frozenset[str],
) -> Pairs:
    """Pairs whose lower bound [m] (bounding sphere against piece bounds, or two spheres) is within
    ``cap`` [m]: robot-scene first, then self pairs (``shapes.self_pairs`` at every pose). Pieces of
    the objects in ``gone`` pair with nothing, the ``grasped`` object not with the gripper."""
    lb = box_distance(inst["centre"], scene["aabb"]) - inst["radius"][:, None]  # (N, S)
    if gone:
        lb[:, [i for i, o in enumerate(scene["objects"]) if o in gone]] = np.inf
    if grasped is not None:
        held = np.array([o == grasped for o in scene["objects"]], dtype=bool)
        lb[np.ix_(inst["gripper"], held)] = np.inf
    a, b = np.nonzero(lb <= cap)
    sa, sb = self_instances(shapes, inst["poses"], ngeoms)
    c, r = inst["centre"], inst["radius"]
    self_lb = np.linalg.norm(c[sa] - c[sb], axis=1) - r[sa] - r[sb]
    keep = self_lb <= cap
    return {
        "a": np.concatenate([a, sa[keep]]),
        "b": np.concatenate([b, sb[keep]]),
        "self": np.concatenate([np.zeros(len(a), bool), np.ones(int(keep.sum()), bool)]),
        "lb": np.concatenate([lb[a, b], self_lb[keep]]),
    }


def self_instances(shapes: ArmShapes, poses: int, ngeoms: int) -> tuple[npt.NDArray[np.int_], npt.NDArray[np.int_]]:
    """Instance indices (the static shapes once, then the moving ones per pose) of both shapes of every
    self pair at every pose; ``ngeoms``: the geometry model's shape count."""
    slot = np.full(ngeoms, -1)
    slot[shapes.static] = np.arange(len(shapes.static))
    mslot = np.full(ngeoms, -1)
    mslot[shapes.moving] = np.arange(len(shapes.moving))
    out = []
    for col in (shapes.self_pairs[:, 0], shapes.self_pairs[:, 1]):
        moves = mslot[col] >= 0
        first = np.where(moves, len(shapes.static) + mslot[col], slot[col])
        step = np.where(moves, len(shapes.moving), 0)
        out.append((first[None, :] + np.arange(poses)[:, None] * step[None, :]).ravel())
    return out[0], out[1]


__all__ = ["candidate_pairs", "self_instances"]
