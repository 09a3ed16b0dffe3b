"""An independent collision check of a plan (tests and tools/heldout.py), written without
placement.collision: the robot's GeometryModel straight from its URDF, the scene as coal objects built
here, and plain coal.collide / coal.distance on every pair (no broad phase, no convex hulls).

For each planned step the robot stands at the step's base pose with the reported joints of every
pose (the plan JSON's ``poses[i].joints``), the preset's fixed joints set and every other arm at its
``idle`` configuration. Checked:

* robot-scene: every robot shape against every obstacle (tables included) and object, except the
  gripper (shapes below the arm's last joint or the tip frame's joint) against the object it grasps
  in a pick, and objects picked in earlier steps (carried away; the one in the hand in a place step too);
* the carried object in a place step: its box, fixed to the TCP (from the plan's ``placed_pose`` and
  last TCP pose, moved by pinocchio FK at every pose), against every obstacle and object still in
  the scene, and every robot shape but the gripper; against its ``support`` only its part above the
  lowest centimetre counts (it is set on that surface), and at the last pose it must rest on the
  support's top within a centimetre;
* self: every pair with a shape the arm moves, except shapes on the same or adjacent joints, the
  SRDF's disabled pairs, the preset's ``ignore_collisions`` link pairs and pairs already in contact
  with every arm idle;
* the base footprint polygon against the obstacles' floor outlines, exactly in 2D, at the step's yaw.

A pair collides when coal.collide says so (no padding). Distances are capped at ``cap`` [m] like
the planner's clearance.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin


def pose_matrix(pose) -> np.ndarray:
    """(4, 4) of a 7-vector [x, y, z, qx, qy, qz, qw]."""
    T = np.eye(4)
    T[:3, :3] = quat_matrix(pose[3:])
    T[:3, 3] = pose[:3]
    return T


def quat_matrix(q) -> np.ndarray:
    """(3, 3) rotation of a unit quaternion [x, y, z, w]."""
    x, y, z, w = (float(v) for v in q)
    return pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()


def yaw_matrix(yaw: float) -> np.ndarray:
    return pin.utils.rotate("z", float(yaw))


def subtree(model: pin.Model, roots) -> set[int]:
    """Joint ids of ``roots`` and every joint below them."""
    out = set()
    for j in range(1, model.njoints):
        k = j
        while k > 0 and k not in roots:
            k = model.parents[k]
        if k > 0:
            out.add(j)
    return out


def segment_distance(p, q, r, s) -> float:
    """Distance [m] between 2D segments pq and rs."""

    def cross(a, b):
        return a[0] * b[1] - a[1] * b[0]

    d1, d2 = q - p, s - r
    den = cross(d1, d2)
    if den != 0:
        t, u = cross(r - p, d2) / den, cross(r - p, d1) / den
        if 0 <= t <= 1 and 0 <= u <= 1:
            return 0.0

    def point_seg(a, b, c):
        d = c - b
        t = 0.0 if not d.any() else min(1.0, max(0.0, float(np.dot(a - b, d) / np.dot(d, d))))
        return float(np.linalg.norm(b + t * d - a))

    return min(point_seg(p, r, s), point_seg(q, r, s), point_seg(r, p, q), point_seg(s, p, q))


def inside(point, poly) -> bool:
    """Even-odd rule: is ``point`` (2,) inside the polygon (k, 2)?"""
    x, y = point
    c = False
    for (x1, y1), (x2, y2) in zip(poly, np.roll(poly, -1, axis=0)):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            c = not c
    return c


def polygon_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Signed-ish 2D distance [m] between polygons (k, 2): 0 when they touch, -1 when one holds the other."""
    if inside(a[0], b) or inside(b[0], a):
        return -1.0
    ea = list(zip(a, np.roll(a, -1, axis=0)))
    eb = list(zip(b, np.roll(b, -1, axis=0)))
    return min(segment_distance(p, q, r, s) for p, q in ea for r, s in eb)


def circle_polygon(n: int = 64):
    """Unit circle as a polygon circumscribing it (its edges touch the circle)."""
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.c_[np.cos(t), np.sin(t)] / math.cos(math.pi / n)


@dataclass
class StepCheck:
    """Outcome for one step: colliding pairs (names), the smallest robot-scene and self distances
    [m] (capped), the footprint's 2D distance to the nearest obstacle [m] (None for a round base)."""

    step: int
    scene_hits: list[str] = field(default_factory=list)
    self_hits: list[str] = field(default_factory=list)
    scene_m: float = math.inf
    self_m: float = math.inf
    footprint_m: float | None = None
    held_m: float = math.inf  # non-gripper shapes vs the object in the hand at its old spot (planner rule)
    object_m: float = math.inf  # the carried object vs the scene but its support (a place)
    object_hits: list[str] = field(default_factory=list)

    @property
    def free(self) -> bool:
        return (
            not self.scene_hits
            and not self.self_hits
            and not self.object_hits
            and (self.footprint_m is None or self.footprint_m > 0)
        )

    def clearance(self, cap: float, planner_rule: bool = True) -> float:
        """Smallest distance as the planner reports it [m] (robot-scene, self, carried object, capped)."""
        return min(cap, self.scene_m, self.self_m, self.object_m, self.held_m if planner_rule else math.inf)


class IndependentCheck:
    """Check the steps of plans of one robot in one scene (see the module doc)."""

    def __init__(self, robot, scene, cap: float = 0.2):
        self.robot, self.scene, self.cap = robot, scene, cap
        model = self.model = robot.model
        dirs = [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        dirs += [str(p) for p in Path(robot.urdf_path).resolve().parents]
        self.geom = pin.buildGeomFromUrdf(model, str(robot.urdf_path), pin.GeometryType.COLLISION, package_dirs=dirs)
        self.data, self.gdata = model.createData(), pin.GeometryData(self.geom)
        q = robot.reference_q()
        for name in robot.arms:
            q = robot.full_q(name, robot.arm(name).idle, q)
        self.idle_q = q
        self.joint = [o.parentJoint for o in self.geom.geometryObjects]
        self.names = [model.frames[o.parentFrame].name for o in self.geom.geometryObjects]
        idle = self.placements(q)
        disabled = set()
        if robot.srdf_path is not None:
            work = pin.GeometryModel(self.geom)
            work.addAllCollisionPairs()
            before = {(p.first, p.second) for p in work.collisionPairs}
            pin.removeCollisionPairs(model, work, str(robot.srdf_path))
            disabled = before - {(p.first, p.second) for p in work.collisionPairs}
        n = self.geom.ngeoms
        self.self_pairs = []
        for i in range(n):
            for j in range(i + 1, n):
                ji, jj = self.joint[i], self.joint[j]
                if ji == jj or model.parents[ji] == jj or model.parents[jj] == ji or (i, j) in disabled:
                    continue
                if frozenset((self.names[i], self.names[j])) in robot.ignore_collisions:
                    continue
                if self.collide(i, idle[i], self.geom.geometryObjects[j].geometry, idle[j]):
                    continue
                self.self_pairs.append((i, j))
        self.objects = {o.name: o for o in scene.objects}
        self.shapes = [(ob.name, *self.obstacle(ob.shape)) for ob in scene.obstacles]
        self.outlines = [(ob.name, self.outline(ob.shape)) for ob in scene.obstacles]

    # -- geometry ----------------------------------------------------------------------------------
    @staticmethod
    def obstacle(shape):
        """(coal geometry, (4, 4) world pose) of a scene obstacle shape."""
        T = np.eye(4)
        if hasattr(shape, "points"):
            pts = np.asarray(shape.points, float)
            verts = coal.StdVec_Vec3s()
            verts.extend([np.array([x, y, z]) for z in (0.0, 3.0) for x, y in pts])
            return coal.Convex.convexHull(verts, False, None), T  # convex polygons only (see outline)
        T[:3, 3] = shape.center
        if hasattr(shape, "radius"):
            return coal.Cylinder(float(shape.radius), float(shape.height)), T
        T[:3, :3] = yaw_matrix(getattr(shape, "yaw", 0.0))
        return coal.Box(*map(float, shape.size)), T

    @staticmethod
    def outline(shape) -> np.ndarray:
        """(k, 2) floor outline of an obstacle [m]."""
        if hasattr(shape, "points"):
            return np.asarray(shape.points, float)
        c = np.asarray(shape.center, float)[:2]
        if hasattr(shape, "radius"):
            return c + float(shape.radius) * circle_polygon()
        hx, hy = np.asarray(shape.size, float)[:2] / 2
        corners = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        return c + corners @ yaw_matrix(getattr(shape, "yaw", 0.0))[:2, :2].T

    def object_shape(self, name: str):
        o = self.objects[name]
        T = np.eye(4)
        T[:3, 3] = o.position
        T[:3, :3] = quat_matrix(o.orientation) if o.orientation is not None else yaw_matrix(o.yaw)
        return coal.Box(*map(float, o.size)), T

    def placements(self, q, root=None) -> list[np.ndarray]:
        """(4, 4) world pose of every robot shape at pinocchio configuration ``q``."""
        pin.framesForwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geom, self.gdata)
        root = np.eye(4) if root is None else root
        return [root @ M.homogeneous for M in self.gdata.oMg]

    @staticmethod
    def tf(T):
        return coal.Transform3s(T[:3, :3].copy(), T[:3, 3].copy())

    def collide(self, i: int, Ti, other, To) -> bool:
        res = coal.CollisionResult()
        return (
            coal.collide(
                self.geom.geometryObjects[i].geometry, self.tf(Ti), other, self.tf(To), coal.CollisionRequest(), res
            )
            > 0
        )

    def distance(self, i: int, Ti, other, To) -> float:
        res = coal.DistanceResult()
        return float(
            coal.distance(
                self.geom.geometryObjects[i].geometry, self.tf(Ti), other, self.tf(To), coal.DistanceRequest(), res
            )
        )

    # -- the check ---------------------------------------------------------------------------------
    def check_step(self, step: dict, picked_before: list[str], held: str | None) -> StepCheck:
        """Check one planned step of the plan JSON; ``picked_before``: objects picked in earlier
        steps, ``held``: the object in the hand (picked now, or carried in a place step)."""
        robot, model = self.robot, self.model
        arm = robot.arm(step["arm"])
        x, y, yaw = step["base"]
        B = np.eye(4)
        B[:3, :3], B[:2, 3] = yaw_matrix(yaw), (x, y)
        moved = subtree(model, set(arm.joint_ids))
        tip_joint = model.frames[model.getFrameId(arm.tip_frame)].parentJoint
        hand = subtree(model, {arm.joint_ids[-1], tip_joint})
        out = StepCheck(step["step"])
        present = [n for n in self.objects if n not in picked_before]
        scene = list(self.shapes) + [(n, *self.object_shape(n)) for n in present]
        held_shape = []
        carried = None
        if "placed_pose" in step:  # a place: the object moves with the TCP
            T_last = pose_matrix(step["poses"][-1]["pose"])
            carried = np.linalg.inv(T_last) @ pose_matrix(step["placed_pose"])
        for k, p in enumerate(step["poses"]):
            q = robot.full_q(step["arm"], [p["joints"][j] for j in arm.joints], self.idle_q)
            pin.framesForwardKinematics(model, self.data, q)
            root = B @ self.data.oMf[robot.base_frame_id].inverse().homogeneous
            Ms = self.placements(q, root)
            for i in range(self.geom.ngeoms):
                for name, g, T in scene + held_shape:
                    gripper = self.joint[i] in hand
                    if name == held and gripper:
                        continue
                    d = self.distance(i, Ms[i], g, T)
                    hit = self.collide(i, Ms[i], g, T)
                    if name == held and held in picked_before:
                        out.held_m = min(out.held_m, d)
                        continue
                    out.scene_m = min(out.scene_m, d)
                    if hit:
                        out.scene_hits.append(f"{self.names[i]} vs {name} (pose {k}, {d:+.4f} m)")
            if carried is not None:
                tcp = B @ robot.tcp_pose(step["arm"], [p["joints"][j] for j in arm.joints])
                self.check_carried(out, step, tcp @ carried, scene, Ms, hand, k, last=k == len(step["poses"]) - 1)
            for i, j in self.self_pairs:
                if self.joint[i] not in moved and self.joint[j] not in moved:
                    continue
                g = self.geom.geometryObjects[j].geometry
                out.self_m = min(out.self_m, self.distance(i, Ms[i], g, Ms[j]))
                if self.collide(i, Ms[i], g, Ms[j]):
                    out.self_hits.append(f"{self.names[i]} vs {self.names[j]} (pose {k})")
        if robot.footprint is not None:
            poly = np.asarray(robot.footprint, float) @ B[:2, :2].T + (x, y)
            out.footprint_m = min((polygon_distance(poly, o) for _, o in self.outlines), default=math.inf)
        return out

    def check_carried(self, out: StepCheck, step: dict, T: np.ndarray, scene, Ms, hand, k: int, last: bool) -> None:
        """The object carried by a place step at world pose ``T`` (4, 4) against the scene and the robot."""
        name = step["object"]
        size = np.asarray(self.objects[name].size, float)
        box = coal.Box(*map(float, size))
        # its lowest centimetre cut off, for the surface it is set on
        m = int(np.argmax(np.abs(T[2, :3])))
        cut = size.copy()
        cut[m] -= min(0.01, size[m] / 2)
        lift = np.eye(4)
        lift[m, 3] = 0.5 * (size[m] - cut[m]) * np.sign(T[2, m] or 1.0)
        support = step.get("support")
        for other, g, To in scene:
            if other == name:
                continue
            geom, Tb = (coal.Box(*map(float, cut)), T @ lift) if other == support else (box, T)
            res = coal.CollisionResult()
            if coal.collide(geom, self.tf(Tb), g, self.tf(To), coal.CollisionRequest(), res) > 0:
                out.object_hits.append(f"{name} (held) vs {other} (pose {k})")
            if other != support:
                dres = coal.DistanceResult()
                out.object_m = min(
                    out.object_m, float(coal.distance(geom, self.tf(Tb), g, self.tf(To), coal.DistanceRequest(), dres))
                )
        for i in range(self.geom.ngeoms):
            if self.joint[i] in hand:
                continue
            res = coal.CollisionResult()
            if (
                coal.collide(
                    self.geom.geometryObjects[i].geometry, self.tf(Ms[i]), box, self.tf(T), coal.CollisionRequest(), res
                )
                > 0
            ):
                out.object_hits.append(f"{name} (held) vs {self.names[i]} (pose {k})")
        if last and support is not None:
            sh = next(ob.shape for ob in self.scene.obstacles if ob.name == support)
            top = float(sh.center[2]) + float(sh.size[2] if hasattr(sh, "size") else sh.height) / 2
            bottom = float(T[2, 3] - np.abs(T[2, :3]) @ size / 2)
            if abs(bottom - top) > 0.01:
                out.object_hits.append(f"{name} set down {bottom - top:+.3f} m off the top of {support}")

    def check_plan(self, doc: dict) -> list[StepCheck]:
        """Check every planned step of a plan JSON ``doc`` (infeasible steps are skipped)."""
        out, picked = [], []
        for step in doc["steps"]:
            if step["action"] == "pick":
                held = step["target"]
            elif step["action"] == "place":
                held = picked[-1] if picked else None
            else:
                held = None
            if step.get("status", "ok") == "ok":
                out.append(self.check_step(step, list(picked), held))
            if step["action"] == "pick":
                picked.append(step["target"])
        return out
