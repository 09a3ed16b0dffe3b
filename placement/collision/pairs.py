"""The broad phase of a collision check: which (robot shape, scene piece) and (robot shape, robot shape)
pairs can be within the clearance cap, each with a lower bound of its distance."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from placement.collision.bounds import box_distance, boxes_distance
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
    """Pairs whose lower bound [m] is within ``cap`` [m]: robot-scene first, then self pairs
    (``shapes.self_pairs`` at every pose). Pieces of the objects in ``gone`` pair with nothing, the
    ``grasped`` object not with the gripper.

    A pair's bound is the larger of two, each no more than its distance: bounding sphere against the
    piece's box (or two spheres), and the axis-aligned box around the robot shape's own box against
    the piece's box (or two such boxes). The box is the tighter one for long links lying along an
    axis of the model (a forearm, a gripper above a table top): those pairs are not given to coal."""
    centre, ext, radius = inst["centre"], inst["extent"], inst["radius"]
    lb = np.maximum(
        box_distance(centre, scene["aabb"]) - radius[:, None], boxes_distance(centre, ext, scene["aabb"])
    )  # (N, S)
    if gone:
        lb[:, [i for i, o in enumerate(scene["objects"]) if o in gone]] = np.inf
    if grasped is not None:
        held = np.array([o == grasped for o in scene["objects"]], dtype=bool)
        lb[np.ix_(inst["gripper"], held)] = np.inf
    a, b = np.nonzero(lb <= cap)
    sa, sb = self_instances(shapes, inst["poses"], ngeoms)
    c, r = centre, radius
    gap = np.maximum(np.abs(c[sa] - c[sb]) - ext[sa] - ext[sb], 0.0)
    self_lb = np.maximum(np.linalg.norm(c[sa] - c[sb], axis=1) - r[sa] - r[sb], np.linalg.norm(gap, axis=1))
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
