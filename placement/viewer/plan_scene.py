"""Whether a plan document agrees with itself and with its scene, before the viewer draws it.

A plan file may be edited, truncated by hand, or made for a scene of the same name whose objects
stood elsewhere; what the viewer draws, a user believes. Beyond the checks of reading it
(:func:`placement.viewer.plan_file.check_plan`: the scene's task, the robot's joints and limits, the
last TCP pose by FK), every planned step must hold:

* its ``configuration`` (the whole robot at the step) is the step's: the base pose and frame, the
  moving arm, the arm's and fixed joints' values, every joint one of the robot's, finite and within its
  URDF limits (idle arms, head, fingers), and its FK puts the TCP at the step's last pose;
* its TCP trajectory is one the scene allows for that step (recomputed from the scene: an object's
  grasps where the object stands, a place's poses where the transfer sets it down, a named
  trajectory), within :data:`TOLERANCE_M` and :data:`TOLERANCE_RAD` at every pose;
* a place's ``placed_pose`` is where that trajectory sets the object down;
* the plan's TCP offsets are the robot's.

:func:`plan_problems` lists what does not hold (empty: the plan is consistent).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from placement.errors import PlacementError
from placement.planning.problems import step_candidates, task_steps
from placement.planning.results import PlacedStep, StepResult, configuration_problems, configuration_tcp
from placement.planning.settings import PlannerConfig
from placement.robots import Robot, pose_to_matrix
from placement.scene import Scene

#: [m] and [rad]: how far a plan's pose may be from the one the scene gives (JSON rounds to 1e-6).
TOLERANCE_M = 1e-3
TOLERANCE_RAD = 1e-3
#: [rad or m] how far a joint value may stray beyond the URDF limits (rounding in JSON).
LIMIT_SLACK = 1e-9


def _off(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Distance [m] and angle [rad] between two (4, 4) poses."""
    d = float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
    c = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    return d, math.acos(float(np.clip(c, -1.0, 1.0)))


def _words(d: float, r: float) -> str:
    return f"{d * 100:.1f} cm and {math.degrees(r):.1f} deg"


def offset_problems(doc: dict[str, Any], robot: Robot, where: str) -> list[str]:
    """The plan's ``robot.arms.ARM.tcp_offset`` that differ from the robot's."""
    out = []
    arms = doc.get("robot", {}).get("arms", {}) if isinstance(doc.get("robot"), dict) else {}
    for arm, info in arms.items() if isinstance(arms, dict) else ():
        if arm not in robot.arms or not isinstance(info, dict) or "tcp_offset" not in info:
            continue
        try:
            T = pose_to_matrix([float(v) for v in info["tcp_offset"]])
        except (TypeError, ValueError):
            out.append(f"{where}: robot.arms.{arm}.tcp_offset: must be [x, y, z, qx, qy, qz, qw]")
            continue
        d, r = _off(T, np.asarray(robot.arm(arm).tcp_offset))
        if d > 1e-6 or r > 1e-6:
            out.append(f"{where}: robot.arms.{arm}.tcp_offset: {_words(d, r)} from robot '{robot.name}''s")
    return out


def configuration_agreement(conf: Any, s: PlacedStep, robot: Robot, at: str) -> list[str]:
    """What is wrong with a planned step's ``configuration`` (None: the plan has none; fine)."""
    if conf is None:
        return []
    where = f"{at}.configuration"
    if not (isinstance(conf, dict) and isinstance(conf.get("base"), dict) and isinstance(conf.get("joints"), dict)):
        return [f"{where}: must be a mapping with base and joints"]
    base = conf["base"]
    try:
        pose = [float(base[k]) for k in ("x", "y", "yaw")]
    except (KeyError, TypeError, ValueError):
        return [f"{where}.base: must give x, y and yaw"]
    x, y, yaw = s.base
    if (
        abs(pose[0] - x) > TOLERANCE_M
        or abs(pose[1] - y) > TOLERANCE_M
        or abs(math.remainder(pose[2] - yaw, 2 * math.pi)) > TOLERANCE_RAD
    ):
        return [f"{where}.base: ({pose[0]:g}, {pose[1]:g}, {pose[2]:g}) is not the step's base ({x:g}, {y:g}, {yaw:g})"]
    if conf.get("arm") != s.arm:
        return [f"{where}.arm: {conf.get('arm')!r} is not the step's arm {s.arm!r}"]
    model = robot.model
    joints = conf["joints"]
    for j, v in joints.items():
        if not (isinstance(j, str) and model.existJointName(j)):
            return [f"{where}.joints: robot '{robot.name}' has no joint {str(j)[:60]!r}"]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return [f"{where}.joints.{j}: must be a finite number"]
        jm = model.joints[model.getJointId(j)]
        lo, hi = float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q])
        if jm.nq == 1 and math.isfinite(lo) and math.isfinite(hi) and not lo - LIMIT_SLACK <= v <= hi + LIMIT_SLACK:
            return [f"{where}.joints.{j}: {v:g} is outside the URDF limits [{lo:g}, {hi:g}]"]
    for j, v in s.joints.items():
        if j in joints and abs(float(joints[j]) - v) > 1e-9 + 1e-9 * abs(v):
            return [f"{where}.joints.{j}: {float(joints[j]):g}, but the step's joints give {v:g}"]
    try:
        problems = configuration_problems(robot, conf, where)
        if problems:
            return problems[:1]
        arm = robot.arm(s.arm)
        T = configuration_tcp(robot, conf, np.array([float(joints[j]) for j in arm.joints]))
    except (KeyError, TypeError, ValueError, PlacementError) as exc:
        return [f"{where}: {str(exc).splitlines()[0][:120] or type(exc).__name__}"]
    d, r = _off(T, s.tcp[-1])
    if d > 0.01 or r > math.radians(3):
        return [f"{where}: its FK puts the TCP {_words(d, r)} from the step's last pose"]
    return []


def scene_agreement(
    doc_step: dict[str, Any], s: PlacedStep, scene: Scene, robot: Robot, config: PlannerConfig, at: str
) -> list[str]:
    """Whether planned step ``s`` does what the scene allows: its trajectory one of the step's
    candidates (see the module docstring), a place's placed pose where it sets the object down."""
    step = task_steps(scene)[s.step]
    try:
        cands = step_candidates(scene, step, config, robot.gripper.max_opening)
    except PlacementError as exc:
        return [f"{at}: {str(exc).splitlines()[0][:120]}"]
    name = s.trajectory or s.grasp
    cand = next((c for c in cands if c.name == name), None)
    if cand is None:
        return [
            f"{at}.trajectory: {str(name)[:60]!r} is not one of the scene's {len(cands)} trajectories for {step.action} {step.target}"
        ]
    tcp = s.tcp
    if len(tcp) != len(cand.poses):
        return [f"{at}.tcp: {len(tcp)} poses, but trajectory {name!r} of the scene has {len(cand.poses)}"]
    for k, (got, want) in enumerate(zip(tcp, cand.poses)):
        d, r = _off(got, want)
        if d > TOLERANCE_M or r > TOLERANCE_RAD:
            return [
                f"{at}.tcp[{k}]: {_words(d, r)} from trajectory {name!r} as the scene gives it (the scene changed?)"
            ]
    if step.action == "place" and cand.object_pose is not None:
        placed = doc_step.get("placed_pose")
        try:
            T = pose_to_matrix([float(v) for v in placed]) if placed is not None else None
        except (TypeError, ValueError):
            return [f"{at}.placed_pose: must be [x, y, z, qx, qy, qz, qw]"]
        if T is None:
            return [f"{at}.placed_pose: a place must say where it sets the object down"]
        d, r = _off(T, cand.object_pose)
        if d > TOLERANCE_M or r > TOLERANCE_RAD:
            return [f"{at}.placed_pose: {_words(d, r)} from where the trajectory sets '{step.carries}' down"]
    return []


def plan_problems(doc: dict[str, Any], steps: list[StepResult], scene: Scene, robot: Robot, where: str) -> list[str]:
    """What in the plan document ``doc`` (read as ``steps``) disagrees with itself or ``scene`` (see
    the module docstring); empty when nothing does."""
    out = offset_problems(doc, robot, where)
    config = PlannerConfig.from_overrides(scene.planner, where)
    for i, s in enumerate(steps):
        if not s.ok:
            continue
        at = f"{where}: steps[{i}]"
        d = doc["steps"][i]
        out += configuration_agreement(d.get("configuration"), s, robot, at)
        out += scene_agreement(d, s, scene, robot, config, at)
        if out:
            break
    return out
