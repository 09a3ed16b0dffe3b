"""Typed results of planning: one :class:`StepResult` per step, a :class:`PlanResult` per task.

``to_json()`` gives the plan document of docs/planning.md (the only place they are assembled);
``verify(robot)`` re-checks a plan with pinocchio's forward kinematics, independently of the
planner's own kernels.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import KW_ONLY, dataclass, field, replace
from typing import Any, Literal, Self

import numpy as np

from placement.errors import PlacementError
from placement.planning.arrays import FloatArray
from placement.planning.problems import UPRIGHT_TOLERANCE, tilt_between
from placement.planning.verification import (
    Resting,
    actuated_joints,
    base_matrix,
    fixed_problems,
    held,
    out_of_limits,
    pinocchio_q,
    scene_clearance,
    world_tcp,
)
from placement.robots import Robot, matrix_to_pose
from placement.scene import Scene


@dataclass(frozen=True)
class Certificate:
    """A plan's lower bound and its gap.

    Attributes:
        lower_bound_s: least travel time [s] of any plan on the method's regions (inf: no such
            plan exists; the task is infeasible for the method whatever IK does).
        travel_s: the plan's travel time [s] (None unless every step is planned).
        regions: what the bound ranges over ("maps" or "fixed placements").
        ms: time spent on the bound [ms] (0 when the method's own program gave it); JSON
            ``timings_ms.bound``.
        task_time_s: the plan's task time [s] (:mod:`placement.planning.task_time`; None unless every
            step is planned).
        stopped: why the bound was not computed (``lower_bound_s`` is NaN then; JSON ``stopped``,
            present only then), e.g. the task's time budget ran out; None when it was.
    """

    lower_bound_s: float
    travel_s: float | None
    regions: str
    ms: float = 0.0
    task_time_s: float | None = None
    stopped: str | None = None

    @property
    def gap(self) -> float | None:
        """``travel_s / lower_bound_s - 1`` (0 for a plan that travels 0; None without both)."""
        if self.travel_s is None or not math.isfinite(self.lower_bound_s):
            return None
        if self.lower_bound_s <= 0.0:
            return 0.0 if self.travel_s <= 1e-9 else None
        return self.travel_s / self.lower_bound_s - 1.0

    @property
    def task_gap(self) -> float | None:
        """``task_time_s / lower_bound_s - 1`` (None without both, or for a bound of 0)."""
        if self.task_time_s is None or not math.isfinite(self.lower_bound_s) or self.lower_bound_s <= 0.0:
            return None
        return self.task_time_s / self.lower_bound_s - 1.0

    def to_json(self) -> dict[str, Any]:
        gap, task_gap = self.gap, self.task_gap
        return {
            "lower_bound_s": round(self.lower_bound_s, 6) if math.isfinite(self.lower_bound_s) else None,
            "travel_s": None if self.travel_s is None else round(self.travel_s, 6),
            "gap": None if gap is None else round(gap, 6),
            "task_time_s": None if self.task_time_s is None else round(self.task_time_s, 6),
            "task_gap": None if task_gap is None else round(task_gap, 6),
            "regions": self.regions,
            "timings_ms": {"bound": round(self.ms, 3)},
        } | ({} if self.stopped is None else {"stopped": self.stopped})


@dataclass
class StepMaps:
    """A step's (ny, nx) layers, kept for plots: navigation and heuristic cost [m], the best
    manipulability over options (dimensionless), the combined cost (Eq. 6) and the path (m, 2)
    of (iy, ix) cells from the previous placement."""

    navigation: np.ndarray | None = None
    heuristic: np.ndarray | None = None
    manipulation: np.ndarray | None = None
    combined: np.ndarray | None = None
    path: np.ndarray | None = None


@dataclass(frozen=True)
class Cost:
    """The terms of Eq. 6 for the chosen placement (weighted; their sum is ``total``)."""

    navigation: float
    manipulation: float
    heuristic: float

    @property
    def total(self) -> float:
        return self.navigation + self.manipulation + self.heuristic


@dataclass(frozen=True)
class StepOutcome:
    """What every step's result has, planned or not (the base of :class:`PlacedStep` and
    :class:`InfeasibleStep`; a step's type is :data:`StepResult`).

    Attributes:
        step, action, target: which step (index, "pick"/"place"/"reach", object or place location name).
        timings_ms: time per stage [ms].
        tried: placements the IK search tried; not part of the JSON.
        maps: the step's layers when they were kept (plots); not part of the JSON.
    """

    step: int
    action: str
    target: str
    _: KW_ONLY  # the rest by name: their order is not part of the interface
    timings_ms: dict[str, float] = field(default_factory=dict)
    tried: int = 0
    maps: StepMaps | None = field(default=None, repr=False, compare=False)

    def timed(self, **ms: float) -> Self:
        """A copy with the stages ``ms`` [ms] set in (added to) its :attr:`timings_ms`."""
        return replace(self, timings_ms=self.timings_ms | ms)

    def _timings_json(self) -> dict[str, float]:
        return {k: round(v, 3) for k, v in self.timings_ms.items()}


@dataclass(frozen=True, kw_only=True)
class InfeasibleStep(StepOutcome):
    """A step no placement was verified for: why, in one line (``reason``) and as data (``diagnosis``,
    see :func:`placement.planning.methods.explain.explain`)."""

    status: Literal["infeasible"] = field(default="infeasible", init=False)
    reason: str
    diagnosis: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> Literal[False]:
        return False

    def to_json(self) -> dict[str, Any]:
        return {
            "step": self.step,
            "action": self.action,
            "target": self.target,
            "status": self.status,
            "reason": self.reason,
            "diagnosis": self.diagnosis,
            "timings_ms": self._timings_json(),
        }


@dataclass(frozen=True, kw_only=True)
class PlacedStep(StepOutcome):
    """A planned and verified step.

    Attributes:
        arm, grasp: the chosen arm and candidate trajectory name.
        base: (x [m], y [m], yaw [rad]) of the base frame on the floor.
        tcp: (P, 4, 4) TCP poses in the world frame, pre-pose first.
        q: (n,) the arm's IK solution for the last TCP pose [rad or m]; qs: (P, n) the solutions of
            every pose of ``tcp`` (None: ``q`` at every pose); joints: every arm joint (at the last
            pose), then every joint the preset holds fixed at the value this step holds it (a torso
            set per step; within the URDF limits, not necessarily the preset's), by name [rad or m].
        manipulability: the IRM value at the placement (dimensionless). cost: Eq. 6's terms.
        travel_time_s: navigation cost / v_max [s].
        clearance_m: smallest distance [m] between the arm and the scene over the trajectory, from
            the planner's collision check (None without one).
        trajectory: the chosen TCP trajectory's name (a place's: ``GRASP@yawDEG``, see
            :mod:`placement.planning.problems.transfer`; None: ``grasp``).
        object: the object a pick takes or a place sets down (None for a reach).
        placed_pose: a place's (4, 4) world pose of the object set down; support: the obstacle it
            stands on (None: none under it).
        resting: what the step assumes of the rest of the robot (base frame, idle arms, other
            joints; :mod:`placement.planning.verification.configuration`), None for results made without it
            (then the JSON has no ``configuration``).
    """

    status: Literal["ok"] = field(default="ok", init=False)
    arm: str
    grasp: str
    base: tuple[float, float, float]
    tcp: np.ndarray
    q: np.ndarray
    joints: dict[str, float]
    manipulability: float
    cost: Cost
    travel_time_s: float
    qs: np.ndarray | None = None
    clearance_m: float | None = None
    trajectory: str | None = None
    object: str | None = None
    placed_pose: np.ndarray | None = None
    support: str | None = None
    resting: Resting | None = None

    @property
    def ok(self) -> Literal[True]:
        return True

    def to_json(self) -> dict[str, Any]:
        names = self.joints_of_arm()
        cost = self.cost
        return {
            "step": self.step,
            "action": self.action,
            "target": self.target,
            "arm": self.arm,
            "grasp": self.grasp,
            "trajectory": self.trajectory or self.grasp,
            "base": [round(float(v), 6) for v in self.base],
            "tcp": [matrix_to_pose(T) for T in self.tcp],
            "poses": [
                {"pose": matrix_to_pose(T), "joints": {n: float(v) for n, v in zip(names, q)}}
                for T, q in zip(self.tcp, self.pose_qs())
            ],
            "joints": dict(self.joints),
            "clearance_m": None if self.clearance_m is None else float(self.clearance_m),
            "manipulability": float(self.manipulability),
            "cost": {
                "total": cost.total,
                "navigation": cost.navigation,
                "manipulation": cost.manipulation,
                "heuristic": cost.heuristic,
            },
            "travel_time_s": float(self.travel_time_s),
            "timings_ms": self._timings_json(),
        } | self._extras_json()

    def _extras_json(self) -> dict[str, Any]:
        """The keys of transfers and of the whole configuration (present only when known)."""
        conf = self.configuration()
        return self._transfer_json() | ({} if conf is None else {"configuration": conf})

    def _transfer_json(self) -> dict[str, Any]:
        """The object of a pick or place; a place's final object pose and support."""
        if self.object is None:
            return {}
        out: dict[str, Any] = {"object": self.object}
        if self.placed_pose is not None:
            out["placed_pose"] = matrix_to_pose(self.placed_pose)
            out["support"] = self.support
        return out

    def configuration(self) -> dict[str, Any] | None:
        """The robot's whole configuration at the step's last TCP pose (None without
        :attr:`resting`): ``base`` {frame, x [m], y [m], yaw [rad]}, the moving ``arm``, ``arms``
        {name: {state "moving" or "idle", joints (names), holds (the object in its gripper along the
        trajectory, or None)}}, ``fixed_joints`` (names) and ``joints``: :meth:`whole_joints`. Along
        the trajectory only the moving arm's joints change (pose k: :meth:`pose_qs` ``[k]``)."""
        r = self.resting
        if r is None:
            return None
        x, y, yaw = (round(float(v), 6) for v in self.base)
        holds = self.object if self.action == "place" else None
        return {
            "base": {"frame": r.base_frame, "x": x, "y": y, "yaw": yaw},
            "arm": self.arm,
            "arms": {
                a: {
                    "state": "moving" if a == self.arm else "idle",
                    "joints": list(names),
                    "holds": holds if a == self.arm else None,
                }
                for a, names in r.arms.items()
            },
            "fixed_joints": list(self.joints)[len(self.q) :],
            "joints": self.whole_joints(r),
        }

    def whole_joints(self, resting: Resting) -> dict[str, float]:
        """{every actuated joint: value [rad or m]} at the step's last TCP pose, in the model's order:
        the step's own ``joints`` (the arm's and the fixed ones at this step's values, e.g. a torso
        raised for this step), the idle arms' and the rest as ``resting`` (the step's
        :attr:`resting`, or one made for a step read from a file) says."""
        values = dict(resting.other)
        for idle in resting.idle.values():
            values.update(idle)
        values.update(self.joints)  # per step: a step that sets the torso overrides the preset's
        return {n: float(values.pop(n)) for n in resting.order if n in values} | values

    def joints_of_arm(self) -> list[str]:
        """The arm's joint names, in ``q`` order (the first entries of ``joints``)."""
        return list(self.joints)[: len(self.q)]

    def pose_qs(self) -> FloatArray:
        """(P, n) the arm's configuration at every TCP pose (the last one only, repeated, for
        results made without them)."""
        if self.qs is not None:
            return self.qs
        out: FloatArray = np.repeat(np.asarray(self.q)[None], len(self.tcp), axis=0)
        return out


#: One step's result: planned (:class:`PlacedStep`, ``status`` "ok") or not
#: (:class:`InfeasibleStep`, ``status`` "infeasible"); ``step.ok`` narrows it.
StepResult = PlacedStep | InfeasibleStep


def placed_steps(steps: Iterable[StepResult]) -> list[PlacedStep]:
    """``steps``, each of them planned (PlacementError naming the first that is not)."""
    out = []
    for s in steps:
        if not s.ok:
            raise PlacementError(f"step {s.step} ({s.action} {s.target}) is not planned: {s.reason}")
        out.append(s)
    return out


def robot_info(robot: Robot, arms: Iterable[str]) -> dict[str, Any]:
    """The ``robot`` block of the plan document for the mapped ``arms``."""
    return {
        "name": robot.name,
        "base_frame": robot.base_frame,
        "arms": {
            a: {
                "joints": list(robot.arm(a).joints),
                "tip_frame": robot.arm(a).tip_frame,
                "tcp_offset": matrix_to_pose(robot.arm(a).tcp_offset),
            }
            for a in arms
        },
    }


@dataclass
class PlanResult:
    """A planned task: ``status`` "ok" when every step is planned, else "infeasible" (the steps up to
    and including the first infeasible one)."""

    scene: str
    method: str
    robot: dict[str, Any]
    steps: list[StepResult]
    update: dict[str, Any] | None = None
    #: the plan's lower bound and gaps, None when not computed
    certificate: Certificate | None = None

    @property
    def status(self) -> str:
        return "ok" if self.steps and all(s.ok for s in self.steps) else "infeasible"

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def failed_step(self) -> InfeasibleStep | None:
        """The first infeasible step, if any."""
        return next((s for s in self.steps if not s.ok), None)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "scene": self.scene,
            "method": self.method,
            "robot": self.robot,
            "status": self.status,
            "steps": [s.to_json() for s in self.steps],
        }
        if self.certificate is not None:
            out["certificate"] = self.certificate.to_json()
        if self.update is not None:
            out["update"] = self.update
        return out

    def verify(
        self, robot: Robot, pos_tol: float = 0.01, rot_tol: float = math.radians(3), scene: Scene | None = None
    ) -> list[str]:
        """Independent checks of every planned step with pinocchio FK: joints within limits, every
        fixed joint given and within its URDF limits (a step may hold it at another value than the
        preset's: a torso set per step), the TCP at every pose of the trajectory with that pose's
        joints (the last with ``joints``) and the step's fixed-joint values (``pos_tol`` [m],
        ``rot_tol`` [rad]), by FK of the step's whole ``configuration`` when it has one (every
        actuated joint given, the base pose applied to the base frame, the idle arms within their
        limits; see :func:`configuration_problems`), else of the arm on the robot ``held`` at the
        step's fixed-joint values (:meth:`Robot.with_fixed`); and
        every transfer: the place by the pick's arm and grasp, the object turned about the vertical
        only (within :data:`~placement.planning.problems.transfer.UPRIGHT_TOLERANCE`); with ``scene``, every
        base footprint's exact clearance from its obstacles (:mod:`placement.planning.verification.clearance`).
        Returns the problems found (empty: the plan holds)."""
        problems = [] if scene is None else scene_clearance(robot, scene, self.steps)
        for s in self.steps:
            if not s.ok:
                continue
            arm_name = s.arm
            arm = robot.arm(arm_name)
            q = np.array([s.joints[j] for j in arm.joints])
            where = f"step {s.step} ({s.action} {s.target})"
            if np.any(q < arm.lower - 1e-9) or np.any(q > arm.upper + 1e-9):
                problems.append(f"{where}: joints outside their limits")
            missing = [j for j in robot.fixed_joints if j not in s.joints]
            problems += [f"{where}: fixed joint {j} is missing" for j in missing]
            qs = np.array(s.pose_qs(), dtype=float)
            if s.qs is not None and not np.array_equal(qs[-1], q):
                problems.append(f"{where}: the last pose's joints differ from the step's joints")
            qs[-1] = q
            B = base_matrix(*s.base)
            problems += transfer_problems(s, self.steps, where, rot_tol=UPRIGHT_TOLERANCE)
            conf = s.configuration()
            if conf is not None:  # its fixed joints are the step's: checked there, and FK sets them
                problems += configuration_problems(robot, conf, where)
            else:
                problems += [f"{where}: {p}" for p in fixed_problems(robot, s.joints)]
            at = held(robot, s.joints) if conf is None else robot  # with the step's torso: the step's FK
            for i, (want, qi) in enumerate(zip(np.asarray(s.tcp), qs)):
                if np.any(qi < arm.lower - 1e-9) or np.any(qi > arm.upper + 1e-9):
                    problems.append(f"{where}: pose {i}: joints outside their limits")
                T = B @ at.tcp_pose(arm_name, qi) if conf is None else configuration_tcp(robot, conf, qi)
                err = float(np.linalg.norm(T[:3, 3] - want[:3, 3]))
                ang = math.acos(float(np.clip((np.trace(T[:3, :3].T @ want[:3, :3]) - 1) / 2, -1, 1)))
                if err > pos_tol or ang > rot_tol:
                    problems.append(f"{where}: pose {i}: TCP off by {err * 100:.1f} cm and {math.degrees(ang):.1f} deg")
        return problems


def configuration_problems(robot: Robot, conf: dict[str, Any], where: str) -> list[str]:
    """What is wrong with a step's ``configuration`` (:meth:`StepResult.configuration`) for
    ``robot``: its base frame, an actuated joint missing or a joint the model lacks, an idle arm's
    joint outside its limits, the fixed joints not those of the preset or one outside its URDF
    limits (naming the joint, value and limits; a value other than the preset's is no problem)."""
    out = []
    if conf["base"]["frame"] != robot.base_frame:
        out.append(f"{where}: configuration: base frame {conf['base']['frame']}, not {robot.base_frame}")
    joints = conf["joints"]
    missing = [j for j in actuated_joints(robot) if j not in joints]
    unknown = [j for j in joints if not robot.model.existJointName(j)]
    if missing or unknown:
        out.append(f"{where}: configuration: joints missing {missing}, unknown {unknown}")
        return out
    for a, arm in conf["arms"].items():
        bad = out_of_limits(robot, a, joints) if arm["state"] == "idle" else []
        if bad:
            out.append(f"{where}: configuration: idle arm {a}: {', '.join(bad)} outside their limits")
    if set(conf["fixed_joints"]) != set(robot.fixed_joints):
        out.append(f"{where}: configuration: fixed joints {conf['fixed_joints']}, not {list(robot.fixed_joints)}")
    out += [f"{where}: configuration: {p}" for p in fixed_problems(robot, joints)]
    return out


def configuration_tcp(robot: Robot, conf: dict[str, Any], q: FloatArray) -> FloatArray:
    """(4, 4) world TCP pose of the moving arm by pinocchio FK of the whole configuration ``conf``
    with the arm at ``q`` (n,) [rad or m] and the base frame at the configuration's base pose."""
    arm = conf["arm"]
    known = {j: v for j, v in conf["joints"].items() if robot.model.existJointName(j)}  # unknown: reported
    joints = known | dict(zip(robot.arm(arm).joints, (float(v) for v in q)))
    b = conf["base"]
    return world_tcp(robot, arm, pinocchio_q(robot, joints), base_matrix(b["x"], b["y"], b["yaw"]))


def transfer_problems(s: PlacedStep, steps: list[StepResult], where: str, rot_tol: float) -> list[str]:
    """What is wrong with the transfer that place step ``s`` ends (empty for other steps): its pick
    (the last pick before it of the same object) must have the same arm and grasp, and the TCP's
    rotation from the grasp to the place must turn about the vertical only (the object is rigid in
    the hand, so that is the object's turn) within ``rot_tol`` [rad]."""
    if s.action != "place" or s.object is None:
        return []
    before = steps[: next(i for i, x in enumerate(steps) if x is s)]
    pick = next((p for p in reversed(before) if p.action == "pick" and p.ok and p.object == s.object), None)
    if pick is None:
        return [f"{where}: no planned pick of '{s.object}' before it"]
    out = []
    if (pick.arm, pick.grasp) != (s.arm, s.grasp):
        out.append(
            f"{where}: placed by arm {s.arm} with grasp {s.grasp}, picked by arm {pick.arm} with grasp {pick.grasp}"
        )
    tilt = tilt_between(np.asarray(s.tcp)[-1][:3, :3], np.asarray(pick.tcp)[-1][:3, :3])
    if tilt > rot_tol:
        out.append(f"{where}: '{s.object}' set down tilted {math.degrees(tilt):.1f} deg from how it was picked")
    return out
