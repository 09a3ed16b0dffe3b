"""The broad phase of a collision check: which (robot shape, scene piece) and (robot shape, robot shape)
pairs can be within the clearance cap, each with a lower bound of its distance."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from placement.collision.robot import ArmShapes
from placement.collision.tables import Instances, Pairs, ScenePieces
from placement.kernels.broadphase import scene_pair_bounds, self_pair_bounds


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
    axis of the model (a forearm, a gripper above a table top): those pairs are not given to coal.
    The bounds come from :mod:`placement.kernels.broadphase` (numpy's arithmetic, term for term)."""
    objects = scene["objects"]
    skipped = np.array([o in gone for o in objects], dtype=bool)
    held = np.array([grasped is not None and o == grasped for o in objects], dtype=bool)
    centre = np.ascontiguousarray(inst["centre"], dtype=float)
    ext = np.ascontiguousarray(inst["extent"], dtype=float)
    radius = np.ascontiguousarray(inst["radius"], dtype=float)
    aabb = np.ascontiguousarray(scene["aabb"], dtype=float).reshape(-1, 2, 3)
    gripper = np.ascontiguousarray(inst["gripper"], dtype=bool)
    a, b, lb = scene_pair_bounds(centre, ext, radius, aabb, skipped, gripper, held, float(cap))
    sa, sb = self_instances(shapes, inst["poses"], ngeoms)
    keep, self_lb = self_pair_bounds(centre, ext, radius, sa.astype(np.int64), sb.astype(np.int64), float(cap))
    return {
        "a": np.concatenate([a, sa[keep]]),
        "b": np.concatenate([b, sb[keep]]),
        "self": np.concatenate([np.zeros(len(a), bool), np.ones(len(keep), bool)]),
        "lb": np.concatenate([lb, self_lb]),
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
