"""The object in the gripper, carried along a place trajectory, as a collision body.

The held object is its bounding box, rigidly attached to the TCP (``tcp_to_object``, see
:class:`Held`). At every pose of the trajectory it is checked against

* every scene piece (obstacles, tables, objects still where the scene has them, occupancy cells)
  with the checker's ``padding``, except its support (the obstacle it is set on) and every piece
  that continues its surface (its top level with the support's, within :data:`LEVEL_TOLERANCE`,
  its outline touching the support's: tables pushed together are one surface, and an object on
  their seam rests on both; see :func:`extends`): against those the box is checked
  with its lowest face raised by :data:`SUPPORT_TOLERANCE` and no padding (it may touch the
  surface, not pass through it);
* every robot shape except the gripper of the arm that holds it (the fingers close on the object).

Only pieces whose bounds come within reach are given to coal; a free trajectory measures the
object's distance to the scene pieces other than its support (the clearance of the place).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import coal
import numpy as np
import numpy.typing as npt

from placement.collision.scene import SceneShape, box_aabb
from placement.collision.tables import Instances, Operand

#: [m] how far the held object may sink into the surface it is set on (its lowest face is raised
#: by this much against the support): the place puts it exactly on the surface.
SUPPORT_TOLERANCE = 0.01
#: [m] a piece whose top is this close to the support's top is part of the same surface
LEVEL_TOLERANCE = 1e-6


@dataclass(frozen=True, eq=False)
class Held:
    """The object in the gripper during a place: ``name``, box ``size`` (3,) [m], ``tcp_to_object``
    (4, 4) its pose in the TCP frame, and the obstacle it is set on (``support``, None for none)."""

    name: str
    size: npt.NDArray[np.float64]
    tcp_to_object: npt.NDArray[np.float64]
    support: str | None = None


def support_box(
    size: npt.ArrayLike, T_obj: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(size (3,), offset (4, 4) in the object frame) of the box ``size`` [m] at pose ``T_obj`` with
    its lowest face (the axis nearest world z) raised by :data:`SUPPORT_TOLERANCE`."""
    trimmed = np.asarray(size, dtype=float).copy()
    m = int(np.argmax(np.abs(T_obj[2, :3])))
    cut = min(SUPPORT_TOLERANCE, 0.5 * float(trimmed[m]))
    trimmed[m] -= cut
    offset = np.eye(4)
    offset[m, 3] = 0.5 * cut * (1.0 if T_obj[2, m] >= 0 else -1.0)
    return trimmed, offset


def extends(support: npt.NDArray[np.float64], aabb: npt.NDArray[np.float64]) -> bool:
    """Whether a piece with bounds ``aabb`` (2, 3) [m] continues the surface of a support with bounds
    ``support``: its top level with the support's and its outline touching the support's."""
    level = abs(float(aabb[1][2]) - float(support[1][2])) <= LEVEL_TOLERANCE
    touch = bool(np.all(aabb[0][:2] <= support[1][:2] + LEVEL_TOLERANCE))
    return level and touch and bool(np.all(aabb[1][:2] >= support[0][:2] - LEVEL_TOLERANCE))


def _tf(T: npt.NDArray[np.float64]) -> coal.Transform3s:
    return coal.Transform3s(T[:3, :3], T[:3, 3])


class HeldCheck:
    """One check of a held object along a trajectory (see the module docstring).

    Args:
        held: the :class:`Held` object.
        world: (P, 4, 4) the object's world pose at every trajectory pose.
        padding: robot/object-scene distance below which they collide [m]; cap: distances measured up to [m].
    """

    def __init__(self, held: Held, world: npt.NDArray[np.float64], padding: float, cap: float):
        self.held, self.world, self.padding, self.cap = held, world, padding, cap
        self.box = coal.Box(*(float(v) for v in held.size))
        size, self.offset = support_box(held.size, world[-1])
        self.trimmed = coal.Box(*(float(v) for v in size))
        self.req = coal.CollisionRequest()
        self.req.security_margin = padding
        self.touch = coal.CollisionRequest()
        self.radius = 0.5 * float(np.linalg.norm(held.size))
        #: the support and the pieces level with it (set by :meth:`scene`)
        self.surface: set[str] = {held.support} if held.support is not None else set()

    def scene(self, pieces: list[SceneShape], skip: set[str]) -> tuple[tuple[float, str, int] | None, float]:
        """First collision with the scene ``pieces`` (:class:`~.scene.SceneShape`, named ``skip``
        ignored) as (signed distance [m], piece name, pose index), and the clearance [m] (capped).

        Collisions first, over every pose; distances only when all are free, nearest bounds first,
        skipping pieces whose bounds are already farther than the best distance."""
        near: list[tuple[float, int, SceneShape]] = []  # (bounds gap [m], pose index, piece)
        kept = [piece for piece in pieces if piece.name not in skip]
        support = [piece.aabb for piece in pieces if piece.name == self.held.support]
        self.surface = {piece.name for piece in kept if piece.name == self.held.support}
        self.surface |= {piece.name for piece in kept if support and extends(support[0], piece.aabb)}
        bounds = np.array([piece.aabb for piece in kept]).reshape(len(kept), 2, 3)
        for p, T in enumerate(self.world):
            lo, hi = box_aabb(T, self.held.size)
            gaps = np.sqrt((np.maximum(bounds[:, 0] - hi, 0.0) + np.maximum(lo - bounds[:, 1], 0.0)) ** 2 @ np.ones(3))
            near += [(float(gaps[s]), p, kept[s]) for s in np.flatnonzero(gaps <= max(self.cap, self.padding))]
        for gap, p, piece in near:
            g, Tg, req = self._operand(p, piece)
            if gap <= self.padding and coal.collide(
                g, _tf(Tg), piece.geometry, _tf(piece.pose), req, coal.CollisionResult()
            ):
                return (self._distance(g, Tg, piece.geometry, piece.pose), piece.name, p), 0.0
        best = self.cap
        for gap, p, piece in sorted((n for n in near if n[2].name not in self.surface), key=lambda n: n[0]):
            if gap >= best:
                break
            g, Tg, _ = self._operand(p, piece)
            best = min(best, self._distance(g, Tg, piece.geometry, piece.pose))
        return None, best

    def _operand(
        self, p: int, piece: SceneShape
    ) -> tuple[coal.CollisionGeometry, npt.NDArray[np.float64], coal.CollisionRequest]:
        """(geometry, world pose, request) of the held object at pose ``p`` against ``piece``: the
        box with its lowest face raised against its support, the whole box with padding otherwise."""
        T = self.world[p]
        if piece.name in self.surface:
            return self.trimmed, T @ self.offset, self.touch
        return self.box, T, self.req

    def robot(
        self, A: npt.NDArray[np.float64], inst: Instances, operand: Callable[[int], Operand]
    ) -> tuple[float, int, int] | None:
        """First collision with a robot shape instance of the checker's ``inst`` (model frame, ``A``
        world -> model), gripper instances excepted: (distance [m], instance, pose index).
        ``operand(k)`` gives (geometry, hull, hull is exact, coal transform) of instance k."""
        for p, T in enumerate(self.world):
            Tm = A @ T
            near = np.linalg.norm(inst["centre"] - Tm[:3, 3], axis=1) <= inst["radius"] + self.radius
            near &= ~inst["gripper"] & ((inst["pose"] == p) | (inst["pose"] < 0))
            for k in np.flatnonzero(near):
                g, hull, exact, Tk = operand(int(k))
                res = coal.CollisionResult()
                if not coal.collide(self.box, _tf(Tm), hull, Tk, self.touch, res):
                    continue
                res = coal.CollisionResult()
                if exact or coal.collide(self.box, _tf(Tm), g, Tk, self.touch, res):
                    return self._distance(self.box, Tm, g, Tk), int(k), p
        return None

    @staticmethod
    def _distance(
        g1: coal.CollisionGeometry,
        T1: coal.Transform3s | npt.NDArray[np.float64],
        g2: coal.CollisionGeometry,
        T2: coal.Transform3s | npt.NDArray[np.float64],
    ) -> float:
        res = coal.DistanceResult()
        T1 = T1 if isinstance(T1, coal.Transform3s) else _tf(T1)
        T2 = T2 if isinstance(T2, coal.Transform3s) else _tf(T2)
        return float(coal.distance(g1, T1, g2, T2, coal.DistanceRequest(), res))
