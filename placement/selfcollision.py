"""Optional self-collision rejection while building a map (SPEC section 3, item 5: a hard reject).

Geometry: the URDF's ``<collision>`` shapes (meshes and primitives) loaded by
pinocchio, tested by coal (hpp-fcl) exactly as ``pinocchio.computeCollisions``
does. Pairs tested: every pair with at least one shape moved by the arm's
joints, minus pairs on the same or adjacent links (parent/child joints, which
touch by design), minus the pairs the preset's SRDF disables, and minus shapes
carried only by the other arms (they move during a task too, so a map of one
arm does not depend on where another happens to be). The rest of the robot
stands at its reference configuration: fixed joints as in the preset.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from .errors import PlacementError
from .robots import Robot


def _package_dirs(urdf: Path) -> list[str]:
    """Folders that may hold the URDF's ``package://name/...`` packages: its ancestors."""
    return [str(p) for p in urdf.resolve().parents]


class SelfCollision:
    """Tests configurations (N, n) of one arm for collisions with the robot itself.

    Raises :class:`placement.PlacementError` (naming the robot and the cause)
    when the collision geometry does not load.
    """

    def __init__(self, robot: Robot, arm: str):
        a = robot.arm(arm)
        self.robot, self.arm = robot, arm
        model = robot.model
        try:
            geom = pin.buildGeomFromUrdf(model, str(robot.urdf_path), pin.GeometryType.COLLISION,
                                         package_dirs=_package_dirs(robot.urdf_path))
        except Exception as exc:  # pinocchio raises ValueError/RuntimeError with a multi-line message
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise PlacementError(f"robot '{robot.name}': collision geometry of {robot.urdf_path} "
                                 f"does not load ({first}); build without self-collision") from None
        if geom.ngeoms == 0:
            raise PlacementError(f"robot '{robot.name}': the URDF has no <collision> shapes; "
                                 "build without self-collision")
        geom.addAllCollisionPairs()
        if robot.srdf_path is not None:
            pin.removeCollisionPairs(model, geom, str(robot.srdf_path))
        moved = self._moved_joints(model, a.joint_ids)
        # shapes carried only by the other arms: they move during a task too, so they are no obstacle
        others = set()
        for other in robot.arms:
            if other != arm:
                others |= self._moved_joints(model, robot.arm(other).joint_ids)
        others -= moved
        keep = []
        for cp in geom.collisionPairs:
            j1 = geom.geometryObjects[cp.first].parentJoint
            j2 = geom.geometryObjects[cp.second].parentJoint
            adjacent = j1 == j2 or model.parents[j1] == j2 or model.parents[j2] == j1
            if not adjacent and (j1 in moved or j2 in moved) and j1 not in others and j2 not in others:
                keep.append(cp)
        geom.removeAllCollisionPairs()
        for cp in keep:
            geom.addCollisionPair(cp)
        self.geom = geom
        self.pairs = len(keep)
        self._data = model.createData()
        self._gdata = pin.GeometryData(geom)
        self._q = robot.reference_q()

    def _with(self, qfull: np.ndarray, arm: str, q) -> np.ndarray:
        out = qfull.copy()
        for jid, v in zip(self.robot.arm(arm).joint_ids, np.asarray(q, dtype=float)):
            self.robot._set(out, jid, float(v))
        return out

    @staticmethod
    def _moved_joints(model, joint_ids) -> set[int]:
        """The arm's joints and every joint below them in the kinematic tree."""
        moved = set(int(j) for j in joint_ids)
        for j in range(1, model.njoints):
            k = j
            while k > 0:
                if k in moved:
                    moved.add(j)
                    break
                k = model.parents[k]
        return moved

    def collides(self, Q) -> np.ndarray:
        """(N,) bool: True where configuration Q[i] (n,) [rad/m] of the arm collides with the robot."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        out = np.zeros(len(Q), dtype=bool)
        for i, q in enumerate(Q):
            qf = self._with(self._q, self.arm, q)
            out[i] = pin.computeCollisions(self.robot.model, self._data, self.geom, self._gdata, qf, True)
        return out

    def describe(self) -> str:
        """One line for the map metadata: what geometry and pairs are used."""
        return (f"URDF collision shapes (pinocchio/coal), {self.pairs} pairs with a shape moved by the arm; "
                "same/adjacent links, SRDF-disabled pairs and other arms excluded")
