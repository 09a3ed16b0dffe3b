"""Optional self-collision rejection and self-distance penalty while building a map (docs/maps.md).

Geometry: the URDF's ``<collision>`` shapes (meshes and primitives) loaded by
pinocchio (:func:`placement.collision.robot.load_geometry`, strict: a missing mesh is an error), tested by coal (hpp-fcl) exactly as ``pinocchio.computeCollisions``
does. Pairs tested: every pair with at least one shape moved by the arm's
joints, minus pairs on the same or adjacent links (parent/child joints, which
touch by design), minus the pairs the preset's SRDF disables or its ``ignore_collisions`` names, and minus shapes
carried only by the other arms (they move during a task too, so a map of one
arm does not depend on where another happens to be). The rest of the robot
stands at its reference configuration: fixed joints as in the preset.

Self-distance penalty: d = the smallest distance over those pairs [m] and n
the unit direction from the nearest point on the arm to the nearest point on
the other shape, in the TCP frame. With ``P(d) = exp(-alpha d) d^-beta``
(alpha = 40 /m, beta = 1, as Simox), the translational row r of the Jacobian
is scaled by ``1 / sqrt(1 + P(d) max(0, +n_r))`` in octants that move it in
+r and by ``1 / sqrt(1 + P(d) max(0, -n_r))`` in those that move it in -r:
motion towards the body is penalised like motion towards a joint limit, in
proportion to how directly it approaches. d <= 0 is a collision (rejected).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.collision.robot import adjacent, load_geometry, moved_joints
from placement.errors import PlacementError
from placement.robots import Robot
from placement.robots.model_cache import frame_id

ALPHA = 40.0  # [1/m] self-distance penalty decay
BETA = 1.0  # self-distance penalty exponent


def distance_penalty(d: np.ndarray | float) -> np.ndarray | float:
    """Simox's self-distance penalty ``P(d) = exp(-alpha d) d^-beta`` for distances d > 0 [m]."""
    return np.exp(-ALPHA * np.asarray(d, dtype=float)) * np.asarray(d, dtype=float) ** -BETA


class SelfCollision:
    """Tests configurations (N, n) of one arm for collisions with the robot itself.

    Raises :class:`placement.PlacementError` (naming the robot and the cause)
    when the collision geometry does not load.
    """

    def __init__(self, robot: Robot, arm: str):
        a = robot.arm(arm)
        self.robot, self.arm = robot, arm
        model = robot.model
        geom, _ = load_geometry(robot, strict=True)
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
        link = [model.frames[o.parentFrame].name for o in geom.geometryObjects]
        for cp in geom.collisionPairs:
            j1 = geom.geometryObjects[cp.first].parentJoint
            j2 = geom.geometryObjects[cp.second].parentJoint
            if frozenset((link[cp.first], link[cp.second])) in robot.ignore_collisions:
                continue  # a modelling artefact the preset names (see placement.collision.robot)
            if not adjacent(model, j1, j2) and (j1 in moved or j2 in moved) and j1 not in others and j2 not in others:
                keep.append(cp)
        if not keep:
            raise PlacementError(
                f"robot '{robot.name}': no collision shape pair involves arm '{arm}' "
                "(after same/adjacent links, SRDF, ignore_collisions and other arms); build without self-collision"
            )
        geom.removeAllCollisionPairs()
        for cp in keep:
            geom.addCollisionPair(cp)
        self.geom = geom
        self.pairs = len(keep)
        self._moved = moved
        self._tip_id = frame_id(robot.model, a.tip_frame)
        self._tcp = pin.SE3(a.tcp_offset)
        # bounding spheres (local frame) of the shapes, for lower bounds of pair distances
        for go in geom.geometryObjects:
            go.geometry.computeLocalAABB()
        self._pair_ids = np.array([(cp.first, cp.second) for cp in geom.collisionPairs], dtype=int).reshape(-1, 2)
        self._shapes = [int(g) for g in np.unique(self._pair_ids)]
        self._centre = np.array([np.asarray(go.geometry.aabb_center) for go in geom.geometryObjects])
        self._radius = np.array([go.geometry.aabb_radius for go in geom.geometryObjects])
        self._data = model.createData()
        self._gdata = pin.GeometryData(geom)
        self._q = robot.reference_q()

    @staticmethod
    def _moved_joints(model: pin.Model, joint_ids: list[int]) -> set[int]:
        """The arm's joints and every joint below them in the kinematic tree."""
        return moved_joints(model, joint_ids)

    def collides(self, Q: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """(N,) bool: True where configuration Q[i] (n,) [rad/m] of the arm collides with the robot."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        out = np.zeros(len(Q), dtype=bool)
        for i, q in enumerate(Q):
            qf = self.robot.full_q(self.arm, q, self._q)
            out[i] = pin.computeCollisions(self.robot.model, self._data, self.geom, self._gdata, qf, True)
        return out

    def row_factors(self, Q: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """(N, 6, 2) self-distance row penalties of configurations Q (N, n) (see the module doc).

        Row factors are 1 for rotation rows; [i, 0, 0] is -1 where Q[i] collides.
        """
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        out = np.ones((len(Q), 6, 2))
        model, data, geom = self.robot.model, self._data, self.geom
        pairs = geom.collisionPairs
        first, second = self._pair_ids[:, 0], self._pair_ids[:, 1]
        centre = np.empty_like(self._centre)
        for i, q in enumerate(Q):
            qf = self.robot.full_q(self.arm, q, self._q)
            k, res = self._nearest_pair(qf, centre, first, second)
            d = res.min_distance
            if d <= 0.0:
                out[i, 0, 0] = -1.0
                continue
            cp = pairs[k]
            j1 = geom.geometryObjects[cp.first].parentJoint
            j2 = geom.geometryObjects[cp.second].parentJoint
            # the arm's point: the shape moved by the arm (the deeper one if both are)
            first_is_arm = (j1 in self._moved) and (j2 not in self._moved or j1 > j2)
            p_arm, p_other = (
                (res.getNearestPoint1(), res.getNearestPoint2())
                if first_is_arm
                else (res.getNearestPoint2(), res.getNearestPoint1())
            )
            v = np.asarray(p_other) - np.asarray(p_arm)
            norm = np.linalg.norm(v)
            if norm == 0.0:
                continue
            pin.updateFramePlacements(model, data)
            R = (data.oMf[self._tip_id] * self._tcp).rotation
            n = R.T @ (v / norm)
            pen = float(distance_penalty(d))
            for r in range(3):
                out[i, r, 0] = 1.0 / np.sqrt(1.0 + pen * max(0.0, n[r]))
                out[i, r, 1] = 1.0 / np.sqrt(1.0 + pen * max(0.0, -n[r]))
        return out

    def _nearest_pair(
        self, qf: np.ndarray, centre: npt.NDArray[np.float64], first: npt.NDArray[np.intp], second: npt.NDArray[np.intp]
    ) -> tuple[int, Any]:  # Any: a coal DistanceResult (coal has no types)
        """(pair index, coal DistanceResult) of the pair at the smallest distance, exactly.

        Pairs are measured in order of a lower bound (distance of their bounding
        spheres) until the bound exceeds the best distance found: the others
        cannot be nearer. Same pair and result as measuring all pairs (ties go
        to the lower index, as ``argmin`` would).
        """
        model, data, geom, gdata = self.robot.model, self._data, self.geom, self._gdata
        pin.updateGeometryPlacements(model, data, geom, gdata, qf)
        for g in self._shapes:
            M = gdata.oMg[g]
            centre[g] = M.rotation @ self._centre[g] + M.translation
        lower = np.linalg.norm(centre[first] - centre[second], axis=1) - self._radius[first] - self._radius[second]
        best, best_k, best_res = np.inf, -1, None
        for k in np.argsort(lower, kind="stable"):
            if lower[k] > best:
                break
            res = pin.computeDistance(geom, gdata, int(k))
            if res.min_distance < best or (res.min_distance == best and k < best_k):
                best, best_k, best_res = res.min_distance, int(k), res
        return best_k, best_res

    def describe(self) -> str:
        """One line for the map metadata: what geometry and pairs are used."""
        return (
            f"URDF collision shapes (pinocchio/coal), {self.pairs} pairs with a shape moved by the arm; "
            "same/adjacent links, SRDF-disabled pairs and other arms excluded"
        )
