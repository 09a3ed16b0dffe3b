"""The tables one collision check (:meth:`placement.collision.SceneCollision.check`) works on, and its result.

A check lays the robot's shapes out as *instances* (a static shape once, a moving shape once per trajectory
pose), the scene pieces near them, and the candidate pairs of the two.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypedDict

import coal
import numpy as np
import numpy.typing as npt

from placement.collision.scene import SceneShape

#: (shape, its convex hull, hull is the shape, coal transform) of a robot instance or scene piece; coal ships
#: no type stubs, so its parts are Any to mypy.
Operand = tuple[coal.CollisionGeometry, coal.CollisionGeometry, bool, coal.Transform3s]


class Instances(TypedDict):
    """N robot shape instances in the model frame: static shapes first, then the moving ones per pose.

    Keys: ``id`` (N,) shape index; ``pose`` (N,) trajectory pose (-1: static); ``poses`` number of poses;
    ``R`` (N, 3, 3), ``t`` (N, 3) [m] placement; ``centre`` (N, 3) [m], ``radius`` (N,) [m] bounding
    sphere; ``extent`` (N, 3) [m] half extents of the axis-aligned box around the shape's own box,
    centred on ``centre``; ``gripper`` (N,) the shape is the arm's gripper; ``tf`` operands made so far, by instance.
    """

    id: npt.NDArray[np.int_]
    pose: npt.NDArray[np.int_]
    poses: int
    R: npt.NDArray[np.float64]
    t: npt.NDArray[np.float64]
    centre: npt.NDArray[np.float64]
    radius: npt.NDArray[np.float64]
    extent: npt.NDArray[np.float64]
    gripper: npt.NDArray[np.bool_]
    tf: dict[int, Operand]


class ScenePieces(TypedDict):
    """S scene pieces near the robot: ``shapes`` each a :class:`SceneShape` or an occupancy cell's (row, col)
    (made into a shape when first needed); ``aabb`` (S, 2, 3) model-frame bounds [m]; ``A`` (4, 4) world to
    model; ``tf`` operands made so far, by piece; ``objects`` the object of each piece, or None."""

    shapes: list[SceneShape | tuple[int, int]]
    aabb: npt.NDArray[np.float64]
    A: npt.NDArray[np.float64]
    tf: dict[int, Operand]
    objects: list[str | None]


class Pairs(TypedDict):
    """K candidate pairs: instance ``a`` against piece (or, when ``self``, instance) ``b``, each (K,), with a
    lower bound ``lb`` (K,) of their distance [m]."""

    a: npt.NDArray[np.intp]
    b: npt.NDArray[np.intp]
    self: npt.NDArray[np.bool_]
    lb: npt.NDArray[np.float64]


@dataclass(frozen=True)
class CollisionResult:
    """Outcome of :meth:`placement.collision.SceneCollision.check`.

    Attributes:
        free: no pair collides.
        clearance_m: free: the smallest distance over the checked pairs, capped at the checker's
            ``clearance_cap`` [m]; colliding: the signed distance of ``culprit`` (negative: penetration
            depth; >= 0 only when it is within ``padding``).
        culprit: ``"r_gripper_palm_link vs table_1"``: the first colliding pair found, or when free the
            closest pair (None when nothing is within the cap). Robot shapes are named by their link,
            occupancy cells as ``occupancy[row,col]``.
        pose: index of the trajectory pose of ``culprit``, None for a part of the robot the arm does
            not move (or no culprit).
        box: the world-frame box (x0, y0, z0, x1, y1, z1) [m] outside which no scene piece can change
            this result (every checked shape's bounding sphere, and the held object's, grown by the
            larger of padding and cap); None when not computed. A scene change whose pieces all lie
            outside it leaves the result as it is (see :mod:`placement.planning.verification.verdicts`).
    """

    free: bool
    clearance_m: float
    culprit: str | None
    pose: int | None = None
    box: tuple[float, float, float, float, float, float] | None = field(default=None, compare=False)
