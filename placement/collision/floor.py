"""The floor in the arm's collision model: the plane z = 0 of the world, solid below.

The base stands on it, so only the shapes the checked arm moves are tested, and the object the
gripper holds. Touching the floor is allowed (an object stands on it, fingers close around an object
lying on it); a shape that dips more than :data:`FLOOR_SLACK` below it collides, named
``LINK vs floor`` (or ``OBJECT (held) vs floor``) with its signed distance, the depth.

A shape is tested only when its bounding sphere reaches below z = 0; its depth is coal's distance
from its convex hull (whose lowest point is the shape's) to the half-space.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import coal
import numpy as np
import numpy.typing as npt

from placement.collision.tables import CollisionResult, Instances, Operand

if TYPE_CHECKING:
    from placement.collision.held import Held

#: [m] how far a moving arm shape or a held object may dip below the floor before it collides.
FLOOR_SLACK = 1e-4
_IDENTITY = coal.Transform3s()
_REQUEST = coal.DistanceRequest()


def floor_collision(
    inst: Instances,
    A: npt.NDArray[np.float64],
    robot: Callable[[int], Operand],
    names: Sequence[str],
    held: Held | None = None,
    carried_at: npt.NDArray[np.float64] | None = None,
) -> CollisionResult | None:
    """The first arm shape (or the held object) more than :data:`FLOOR_SLACK` below the floor, as a
    collision, or None.

    Args:
        inst: the robot instances of the check (model frame; ``pose`` >= 0: moved by the arm).
        A: (4, 4) world -> model transform.
        robot: instance index -> its operand (shape, hull, exact, coal transform).
        names: the robot's shape names, by geometry id.
        held: the carried object, or None; carried_at: its (P, 4, 4) world poses.
    """
    moving = np.flatnonzero(inst["pose"] >= 0)
    Ainv = np.linalg.inv(A)
    z = inst["centre"][moving] @ Ainv[2, :3] + Ainv[2, 3]
    low = moving[z - inst["radius"][moving] < 0.0]
    if len(low):
        normal = A[:3, :3] @ np.array([0.0, 0.0, 1.0])  # the world's z <= 0, in the model frame
        plane = coal.Halfspace(normal, float(normal @ A[:3, 3]))
        result = coal.DistanceResult()
        for k in low:
            _, hull, _, T = robot(int(k))
            result.clear()
            depth = float(coal.distance(hull, T, plane, _IDENTITY, _REQUEST, result))
            if depth < -FLOOR_SLACK:
                return CollisionResult(False, depth, f"{names[int(inst['id'][k])]} vs floor", int(inst["pose"][k]))
    if held is not None and carried_at is not None:
        half = np.asarray(held.size, dtype=float) / 2
        bottom = carried_at[:, 2, 3] - np.abs(carried_at[:, 2, :3]) @ half
        below = np.flatnonzero(bottom < -FLOOR_SLACK)
        if len(below):
            p = int(below[0])
            return CollisionResult(False, float(bottom[p]), f"{held.name} (held) vs floor", p)
    return None
