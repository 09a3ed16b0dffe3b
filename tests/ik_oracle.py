"""An independent oracle for "is this step feasible?": random base poses around the target and a
pinocchio-only damped least-squares IK with restarts (no map, no planner kernel, no placement.kinematics.ik).

A step is feasible when some base pose lets the arm reach every pose of one of the step's TCP
trajectories, each within 2 mm and 0.02 rad. Base poses are on the planner's grid (cell centres) and,
for a polygon footprint, at the planner's base yaws. Base feasibility: a round base stands on a
feasible cell of the planner's world; a polygon base is tested here, exactly in 2D at its yaw
(oracle_collision.polygon_distance), keeping the planner's footprint padding from each obstacle's
bounding rectangle grown out to the grid lines (the planner tests the grid cells an obstacle touches:
they all lie in that rectangle, which is the obstacle itself for the grid-aligned boxes of the tests). With ``collisions``
the configurations are also checked by oracle_collision.IndependentCheck (robot-scene pairs keep the
planner's collision padding, no self-collision).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from oracle_collision import IndependentCheck, polygon_distance

POS_TOL, ROT_TOL = 2e-3, 2e-2


class PinIK:
    """DLS IK of one arm on pinocchio alone: TCP frame added to a copy of the model."""

    def __init__(self, robot, arm: str):
        a = robot.arm(arm)
        self.robot, self.arm, self.a = robot, arm, a
        self.model = pin.Model(robot.model)
        tip_id = self.model.getFrameId(a.tip_frame)
        tip = self.model.frames[tip_id]
        self.tcp = self.model.addFrame(
            pin.Frame(
                "oracle_tcp",
                tip.parentJoint,
                tip_id,
                tip.placement * pin.SE3(np.asarray(a.tcp_offset, float)),
                pin.FrameType.OP_FRAME,
            )
        )
        self.data = self.model.createData()
        self.cols = [self.model.joints[j].idx_v for j in a.joint_ids]
        self.ref = robot.reference_q()
        pin.framesForwardKinematics(self.model, self.data, robot.full_q(arm, a.home, self.ref))
        self.oMbase = pin.SE3(self.data.oMf[robot.base_frame_id])
        first = a.joint_ids[0]
        #: the first arm joint's origin in the base frame [m]: no arm joint moves it
        self.shoulder = (self.oMbase.actInv(self.data.oMi[first])).translation.copy()
        self.reach_m = self._reach()

    def _reach(self) -> float:
        """An upper bound [m] of the distance from the first arm joint's origin to the TCP at any
        configuration: a revolute joint keeps the distance to the next joint's origin, a prismatic one
        adds its longest travel (inf for any other chain: the bound is then not used)."""
        m, ids = self.model, list(self.a.joint_ids)
        if len(ids) != self.a.dof:
            return math.inf
        total = 0.0
        for k, j in enumerate(ids):
            kind = m.joints[j].shortname()
            if kind in ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"):
                total += max(abs(float(self.a.lower[k])), abs(float(self.a.upper[k])))
            elif not kind.startswith(("JointModelR", "JointModelRevolute")):
                return math.inf
            nxt = ids[k + 1] if k + 1 < len(ids) else None
            if nxt is not None:
                if m.parents[nxt] != j:
                    return math.inf
                total += float(np.linalg.norm(m.jointPlacements[nxt].translation))
        frame = m.frames[self.tcp]
        if frame.parentJoint != ids[-1]:
            return math.inf
        return total + float(np.linalg.norm(frame.placement.translation))

    def out_of_reach(self, T_base: np.ndarray) -> bool:
        """Whether no configuration puts the TCP within the position tolerance of the pose ``T_base``
        (4, 4, base frame): it lies farther from the first joint than the arm reaches."""
        return float(np.linalg.norm(T_base[:3, 3] - self.shoulder)) > self.reach_m + POS_TOL

    def solve(self, T_base: np.ndarray, q0: np.ndarray, iters: int = 80):
        """(success, q (n,)) for the TCP pose ``T_base`` (4, 4) in the base frame, from q0."""
        target = self.oMbase * pin.SE3(T_base[:3, :3].copy(), T_base[:3, 3].copy())
        q = q0.copy()
        a = self.a
        for _ in range(iters):
            full = self.robot.full_q(self.arm, q, self.ref)
            pin.computeJointJacobians(self.model, self.data, full)
            pin.updateFramePlacements(self.model, self.data)
            cur = self.data.oMf[self.tcp]
            err = pin.log6(cur.actInv(target)).vector
            if np.linalg.norm(err[:3]) < POS_TOL and np.linalg.norm(err[3:]) < ROT_TOL:
                return True, q
            J = pin.getFrameJacobian(self.model, self.data, self.tcp, pin.LOCAL)[:, self.cols]
            dq = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(6), err)
            n = np.linalg.norm(dq)
            q = q + (dq * (0.5 / n) if n > 0.5 else dq)
            q = np.where(a.continuous, (q + math.pi) % (2 * math.pi) - math.pi, np.clip(q, a.lower, a.upper))
        return False, q


def base_matrix(x, y, yaw):
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


def step_objects(planner, step_index: int) -> tuple[list[str], str | None]:
    """(objects picked before step ``step_index``, the object in the hand during it)."""
    steps = planner.problems.steps
    picked = [s.target for s in steps[:step_index] if s.action == "pick"]
    step = steps[step_index]
    held = step.target if step.action == "pick" else picked[-1] if step.action == "place" and picked else None
    return picked, held


class BaseAndArmCheck:
    """The oracle's own base-footprint and (optional) collision tests of one step of ``planner``."""

    def __init__(self, planner, step_index: int, collisions: bool):
        self.planner = planner
        self.polygon = None if planner.robot.footprint is None else np.asarray(planner.robot.footprint, float)
        cfg = planner.base_config
        self.keep = cfg.footprint_padding
        self.padding = cfg.collision_padding
        self.checker = (
            IndependentCheck(planner.robot, planner.scene) if (collisions or self.polygon is not None) else None
        )
        self.collisions = collisions
        self.picked, self.held = step_objects(planner, step_index)

    def base_clear(self, x: float, y: float, yaw: float) -> bool:
        B = base_matrix(x, y, yaw)
        poly = self.polygon @ B[:2, :2].T + (x, y)
        return all(polygon_distance(poly, o) >= self.keep for o in self.snapped)

    @property
    def snapped(self) -> list[np.ndarray]:
        """(4, 2) per obstacle: its bounding rectangle grown out to the planner's grid lines [m]."""
        if not hasattr(self, "_snapped"):
            nav = self.planner.world.nav
            res, (ox, oy) = nav.resolution, nav.origin
            self._snapped = []
            for _, o in self.checker.outlines:
                (x0, y0), (x1, y1) = o.min(axis=0), o.max(axis=0)
                x0, x1 = ox + math.floor((x0 - ox) / res + 1e-9) * res, ox + math.ceil((x1 - ox) / res - 1e-9) * res
                y0, y1 = oy + math.floor((y0 - oy) / res + 1e-9) * res, oy + math.ceil((y1 - oy) / res - 1e-9) * res
                self._snapped.append(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
        return self._snapped

    def arm_free(self, arm: str, qs: list, base, poses=None, carried=None) -> bool:
        if not self.collisions:
            return True
        names = self.planner.robot.arm(arm).joints
        step = {
            "step": 0,
            "arm": arm,
            "base": list(base),
            "poses": [{"joints": dict(zip(names, map(float, q)))} for q in qs],
        }
        if carried is not None:  # the object moves with the TCP reached at the last pose
            name, object_pose, support = carried
            T = base_matrix(*base) @ self.planner.robot.tcp_pose(arm, qs[-1])
            step["poses"][-1]["pose"] = pose7(T)
            step.update(
                {"object": name, "support": support, "placed_pose": pose7(T @ np.linalg.inv(poses[-1]) @ object_pose)}
            )
        c = self.checker.check_step(step, self.picked, self.held)
        return (
            not c.self_hits
            and not c.object_hits
            and c.scene_m >= self.padding
            and c.held_m >= self.padding
            and c.object_m >= self.padding
        )


def pose7(T) -> list[float]:
    """[x, y, z, qx, qy, qz, qw] of a (4, 4) pose (pinocchio's quaternion)."""
    q = pin.Quaternion(np.asarray(T)[:3, :3])
    return [*map(float, np.asarray(T)[:3, 3]), float(q.x), float(q.y), float(q.z), float(q.w)]


def find_placement(
    planner,
    trajectories,
    samples: int = 400,
    restarts: int = 3,
    radius: float = 1.2,
    seed: int = 0,
    step_index: int = 0,
    collisions: bool = False,
    arms=None,
    carried=None,
):
    """A base pose (x, y, yaw) from which one arm (of ``arms``, default all) reaches every pose of
    one of ``trajectories`` ((P, 4, 4) world poses) (collision-free with ``collisions``: step
    ``step_index`` of the planner's task says which objects are gone or in the hand; ``carried``,
    parallel to ``trajectories``: (object name, (4, 4) its pose at the last pose, support name) of a
    place, the object checked as held), or None after ``samples`` random base poses where the base fits."""
    rng = np.random.default_rng(seed)
    world = planner.world
    check = BaseAndArmCheck(planner, step_index, collisions)
    yaws = np.asarray(planner.yaws, float)
    solvers = {arm: PinIK(planner.robot, arm) for arm in (arms or planner.maps)}
    target = np.mean([T[-1, :2, 3] for T in trajectories], axis=0)
    tried = 0
    for _ in range(50 * samples):  # ``samples`` counts the base poses that fit: most draws hit furniture
        if tried >= samples:
            break
        r, th = radius * math.sqrt(rng.random()), 2 * math.pi * rng.random()
        x, y, yaw = target[0] + r * math.cos(th), target[1] + r * math.sin(th), 2 * math.pi * rng.random() - math.pi
        try:
            cell = world.nav.cell(x, y)
        except Exception:
            continue
        # base positions are the planner's grid cells (and yaws): it decides at their centres only
        x, y = float(world.nav.centres()[0][cell[1]]), float(world.nav.centres()[1][cell[0]])
        if check.polygon is None:
            if not world.feasible[cell]:
                continue
        else:
            yaw = float(yaws[np.argmin(np.abs((yaws - yaw + math.pi) % (2 * math.pi) - math.pi))])
            if not check.base_clear(x, y, yaw):
                continue
        tried += 1
        Binv = np.linalg.inv(base_matrix(x, y, yaw))
        for arm, ik in solvers.items():
            k = int(rng.integers(len(trajectories)))  # the samples spread over the trajectories
            T = trajectories[k]
            lo = np.where(ik.a.continuous, -math.pi, ik.a.lower)
            hi = np.where(ik.a.continuous, math.pi, ik.a.upper)
            starts = [ik.a.home] + [rng.uniform(lo, hi) for _ in range(restarts - 1)]
            if any(ik.out_of_reach(Binv @ pose) for pose in T):  # no start could reach it
                continue
            for q in starts:
                ok, qs = True, []
                for pose in T:
                    ok, q = ik.solve(Binv @ pose, q)
                    qs.append(q)
                    if not ok:
                        break
                if ok and check.arm_free(arm, qs, (x, y, yaw), T, None if carried is None else carried[k]):
                    return x, y, yaw
    return None


def find_transfer(planner, pick_index: int, samples: int = 300, collisions: bool = False):
    """((arm, grasp), pick base, place base) of a transfer that an independent search verifies: the
    pick with one grasp and arm and its place (step ``pick_index + 1``) with the same, the carried
    object checked; None when no (arm, grasp) pair has both."""
    from placement.planning.problems.steps import step_candidates

    steps = planner.problems.steps
    picks = step_candidates(planner.scene, steps[pick_index], planner.config)
    places = step_candidates(planner.scene, steps[pick_index + 1], planner.config)
    obj = steps[pick_index].target
    for arm in planner.maps:
        for g in picks:
            mine = [c for c in places if c.grasp == g.grasp]
            a = find_placement(planner, [g.poses], samples, step_index=pick_index, collisions=collisions, arms=[arm])
            if a is None or not mine:
                continue
            b = find_placement(
                planner,
                [c.poses for c in mine],
                samples,
                step_index=pick_index + 1,
                collisions=collisions,
                arms=[arm],
                carried=[(obj, c.object_pose, c.support) for c in mine],
            )
            if b is not None:
                return (arm, g.grasp), a, b
    return None
