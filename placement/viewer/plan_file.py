"""Plan files for the viewer: a plan document (the JSON of ``placement query --json``, docs/planning.md)
read and checked into :class:`~placement.planning.StepResult` objects, as the planner makes them.

A step may hold the preset's fixed joints (the PR2's torso lift) at its own values within their
URDF limits (the step's ``joints``); one it does not give is at the preset's value."""

from __future__ import annotations

import json
import math
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from placement.errors import ViewerError
from placement.planning.problems import UPRIGHT_TOLERANCE
from placement.planning.results import Cost, InfeasibleStep, PlacedStep, StepResult, transfer_problems
from placement.planning.verification import held, joint_limits, resting
from placement.robots import Robot, pose_to_matrix
from placement.validation import parse_json
from placement.viewer.plan_scene import plan_problems

if TYPE_CHECKING:
    from placement.scene import Scene


class PlanFileError(ViewerError):
    """A plan file that cannot be shown; the one-line message names the file and the key."""


#: Largest plan file read [bytes] (a plan of 100 steps is about 100 kB).
MAX_PLAN_BYTES = 64 * 2**20


def title(s: StepResult) -> str:
    """One line naming a :class:`~placement.planning.StepResult`: step, action, target, arm and grasp
    (or why it is infeasible)."""
    what = f"step {s.step}: {s.action} {s.target}"
    return f"{what} ({s.arm} arm, {s.grasp})" if s.ok else f"{what} (infeasible: {s.reason})"


def _need(cond: bool, where: str, msg: str) -> None:
    if not cond:
        raise PlanFileError(f"{where}: {msg}")


def _number(v: Any, where: str) -> float:  # v: a JSON value
    _need(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v),
        where,
        f"must be a finite number, got {json.dumps(v)[:40] if _jsonable(v) else type(v).__name__}",
    )
    return float(v)


def _jsonable(v: object) -> bool:
    try:
        json.dumps(v)
        return True
    except (TypeError, ValueError, RecursionError):
        return False


def _text(d: dict[str, Any], key: str, where: str) -> str:
    v = d.get(key)
    if not isinstance(v, str) or v == "":
        raise PlanFileError(f"{where}.{key}: must be a non-empty string")
    return v


def _numbers(v: Any, n: int | None, where: str) -> list[float]:
    _need(
        isinstance(v, list) and (n is None or len(v) == n),
        where,
        f"must be a list of {n if n is not None else 'some'} numbers",
    )
    return [_number(x, f"{where}[{i}]") for i, x in enumerate(v)]


def parse_step(d: Any, where: str, robot: Robot) -> StepResult:
    """One step of a plan document; ``robot`` names the arms and joints it may use. Its ``joints``
    are the arm's, then every fixed joint at the step's value (the preset's when the step gives
    none; PlanFileError naming step, joint and value for one outside the URDF limits); its
    ``resting`` is the one the planner assumes (other arms idle, other joints neutral)."""
    _need(isinstance(d, dict), where, "must be a mapping")
    step = d.get("step")
    _need(
        isinstance(step, int) and not isinstance(step, bool) and step >= 0,
        f"{where}.step",
        "must be a step index (an integer >= 0)",
    )
    action, target = _text(d, "action", where), _text(d, "target", where)
    if d.get("status", "ok") != "ok":
        _need(d.get("status") == "infeasible", f"{where}.status", "must be 'ok' or 'infeasible'")
        reason = d.get("reason")
        return InfeasibleStep(step, action, target, reason=reason if isinstance(reason, str) else "no reason given")
    arm = _text(d, "arm", where)
    _need(arm in robot.arms, f"{where}.arm", f"no arm '{arm}' on robot '{robot.name}'; arms: {', '.join(robot.arms)}")
    bx, by, byaw = _numbers(d.get("base"), 3, f"{where}.base")
    tcp = d.get("tcp")
    _need(
        isinstance(tcp, list) and len(tcp) > 0,
        f"{where}.tcp",
        "must be a non-empty list of poses [x, y, z, qx, qy, qz, qw]",
    )
    poses = []
    for i, p in enumerate(tcp):
        v = _numbers(p, 7, f"{where}.tcp[{i}]")
        try:
            poses.append(pose_to_matrix(v))
        except ValueError as exc:  # not a unit quaternion
            raise PlanFileError(f"{where}.tcp[{i}]: {exc}") from None
    joints = d.get("joints")
    _need(isinstance(joints, dict), f"{where}.joints", "must be a mapping of joint name to value")
    names = robot.arm(arm).joints
    missing = [j for j in names if j not in joints]
    _need(not missing, f"{where}.joints", f"lacks joint(s) {', '.join(missing)} of the {arm} arm")
    q = np.array([_number(joints[j], f"{where}.joints.{j}") for j in names])
    fixed = {j: _fixed_value(joints.get(j, v), robot, j, f"{where}.joints.{j}") for j, v in robot.fixed_joints.items()}
    # what the viewer only shows: NaN when a plan does not give it
    extra = {
        key: _number(d[key], f"{where}.{key}") if key in d else math.nan for key in ("manipulability", "travel_time_s")
    }
    cost = d.get("cost") if isinstance(d.get("cost"), dict) else {}
    terms = ("navigation", "manipulation", "heuristic")
    cost = Cost(*(_number(cost[t], f"{where}.cost.{t}") if t in cost else math.nan for t in terms))
    grasp = d.get("grasp") if isinstance(d.get("grasp"), str) else "?"
    # the transfer: the object a pick takes or a place sets down (plans made before transfers have none)
    return PlacedStep(
        step,
        action,
        target,
        arm=arm,
        grasp=grasp,
        base=(bx, by, byaw),
        tcp=np.stack(poses),
        q=q,
        joints={j: float(v) for j, v in zip(names, q)} | fixed,
        manipulability=extra["manipulability"],
        cost=cost,
        travel_time_s=extra["travel_time_s"],
        object=d.get("object") if isinstance(d.get("object"), str) else None,
        trajectory=d.get("trajectory") if isinstance(d.get("trajectory"), str) else None,
        resting=resting(robot, arm),
    )


def _fixed_value(v: Any, robot: Robot, joint: str, where: str) -> float:
    """The value [rad or m] of fixed joint ``joint`` a step gives (``v``, from JSON), within its URDF limits."""
    value = _number(v, where)
    lo, hi, continuous = joint_limits(robot, joint)
    _need(
        continuous or lo - LIMIT_SLACK <= value <= hi + LIMIT_SLACK,
        where,
        f"{value:g} is outside the URDF limits [{lo:g}, {hi:g}] of robot '{robot.name}'",
    )
    return value


def parse_plan(doc: Any, where: str, robot: Robot) -> list[StepResult]:
    """The steps of a plan document ``doc`` (parsed JSON) read from ``where``; PlanFileError if it is
    not one, or uses an arm or joint ``robot`` lacks."""
    _need(isinstance(doc, dict), where, "not a plan document (a JSON object with 'steps')")
    steps = doc.get("steps")
    _need(
        isinstance(steps, list) and len(steps) > 0,
        f"{where}: steps",
        "must be a non-empty list (write one with `placement query SCENE --json > plan.json`)",
    )
    name = (doc.get("robot") or {}).get("name") if isinstance(doc.get("robot"), dict) else None
    _need(
        name in (None, robot.name),
        f"{where}: robot.name",
        f"the plan is for robot {_cut(name)}, the scene's robot is '{robot.name}'",
    )
    return [parse_step(s, f"{where}: steps[{i}]", robot) for i, s in enumerate(steps)]


def _read(path: Path | str) -> tuple[Any, str]:
    """The parsed JSON (any JSON value) of the plan file at ``path`` and the name to give it in messages."""
    p = Path(path)
    try:
        st = p.stat()  # a FIFO or a device would block or never end: only a regular file is read
        if not stat.S_ISREG(st.st_mode) or st.st_size > MAX_PLAN_BYTES:
            raise PlanFileError(
                f"--plan {p}: "
                + (
                    "not a regular file"
                    if not stat.S_ISREG(st.st_mode)
                    else f"{st.st_size:,} bytes, more than the {MAX_PLAN_BYTES:,} a plan file may have"
                )
            )
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanFileError(f"--plan {p}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        return parse_json(text), str(p)
    except (ValueError, RecursionError) as exc:
        raise PlanFileError(f"--plan {p}: not JSON ({type(exc).__name__}: {str(exc)[:80]})") from None


def load_plan(path: Path | str, robot: Robot) -> list[StepResult]:
    """The steps of the plan file at ``path`` (PlanFileError naming the file if it is unreadable)."""
    doc, where = _read(path)
    return parse_plan(doc, where, robot)


#: A plan's TCP poses must be where its joints put the TCP within these (as ``PlanResult.verify``).
FK_TOLERANCE_M = 0.01
FK_TOLERANCE_RAD = math.radians(3)

#: [rad or m] how far a joint value may stray beyond the URDF limits (rounding in JSON).
LIMIT_SLACK = 1e-9


def _cut(v: object) -> str:
    """A value from the plan file, quoted short (a file may hold megabytes in one string) and on one line
    (a line break or other control character is written as JSON escapes it)."""
    text = v if isinstance(v, str) else json.dumps(v) if _jsonable(v) else type(v).__name__
    if not text.isprintable():
        text = json.dumps(text)[1:-1]
    return f"'{text}'" if len(text) <= 60 else f"'{text[:40]}...' ({len(text):,} characters)"


def check_plan(doc: dict[str, Any], steps: list[StepResult], scene: Scene, robot: Robot, where: str) -> None:
    """PlanFileError (one line naming ``where`` and the key) unless the plan document ``doc`` (whose
    steps :func:`parse_plan` read as ``steps``) was made for ``scene`` and ``robot``: the same scene
    name and robot name, the arms with the robot's joints and tip frames, every step the scene's task
    step of that index (action and target) up to the first infeasible one, bases inside the scene's
    bounds, only joints of the robot, arm joints within the URDF limits (every pose's), fixed joints
    within theirs (at the step's values, not necessarily the preset's), the last TCP pose where
    the joints put the TCP (with the step's fixed-joint values); and what
    :func:`~placement.viewer.plan_scene.plan_problems` checks (each step's configuration, its
    trajectory one the scene gives, a place's placed pose, the TCP offsets)."""
    from placement.planning.problems import task_steps

    name = doc.get("scene")
    _need(
        isinstance(name, str),
        f"{where}: scene",
        "the plan does not name its scene (write it with `placement query SCENE --json > plan.json`)",
    )
    _need(name == scene.name, f"{where}: scene", f"the plan is for scene {_cut(name)}, not '{scene.name}'")
    info = doc.get("robot")
    if not (isinstance(info, dict) and isinstance(info.get("name"), str)):
        raise PlanFileError(f"{where}: robot.name: the plan does not name its robot")
    arms = info.get("arms", {})
    _need(isinstance(arms, dict), f"{where}: robot.arms", "must be a mapping of arm name to its joints")
    for arm, a in arms.items():
        at = f"{where}: robot.arms.{_cut(arm)[1:-1]}"
        _need(arm in robot.arms, at, f"robot '{robot.name}' has no arm {_cut(arm)}; arms: {', '.join(robot.arms)}")
        _need(
            isinstance(a, dict)
            and a.get("joints") == list(robot.arm(arm).joints)
            and a.get("tip_frame", robot.arm(arm).tip_frame) == robot.arm(arm).tip_frame,
            at,
            f"the joints or tip frame differ from robot '{robot.name}''s (a plan for another robot model)",
        )
    task = task_steps(scene)
    _need(
        len(steps) <= len(task),
        f"{where}: steps",
        f"{len(steps)} steps, but the task of scene '{scene.name}' has {len(task)}",
    )
    for i, (s, t) in enumerate(zip(steps, task)):
        at = f"{where}: steps[{i}]"
        _need(s.step == t.index, f"{at}.step", f"is {s.step}, expected {t.index}")
        _need(
            (s.action, s.target) == (t.action, t.target),
            at,
            f"{s.action} {_cut(s.target)} is not step {t.index} of scene '{scene.name}' ({t.action} '{t.target}')",
        )
        if s.ok:
            _check_step(doc["steps"][i], s, scene, robot, at)
    if len(steps) < len(task):
        _need(
            not steps[-1].ok,
            f"{where}: steps",
            f"the plan stops after {len(steps)} of the task's {len(task)} steps without an infeasible one",
        )
    for i, s in enumerate(steps):  # a place by its pick's arm and grasp, the object upright as picked
        problems = transfer_problems(s, steps, "", rot_tol=UPRIGHT_TOLERANCE) if s.ok else []
        _need(not problems, f"{where}: steps[{i}]", problems[0].lstrip(": ") if problems else "")
    problems = plan_problems(doc, steps, scene, robot, where)  # the configurations, the scene's trajectories
    if problems:
        raise PlanFileError(problems[0])


def _check_step(d: dict[str, Any], s: PlacedStep, scene: Scene, robot: Robot, at: str) -> None:
    """The planned step ``s`` (read from ``d``): base in bounds, joints of the robot within limits,
    the TCP where the joints put it (the fixed joints at the step's values)."""
    xmin, ymin, xmax, ymax = scene.bounds
    x, y, yaw = s.base
    _need(
        xmin <= x <= xmax and ymin <= y <= ymax,
        f"{at}.base",
        f"({x:.3f}, {y:.3f}) is outside the scene's bounds [{xmin:g}, {ymin:g}, {xmax:g}, {ymax:g}]",
    )
    arm = robot.arm(s.arm)
    model = robot.model
    for j, v in d["joints"].items():
        _need(
            isinstance(j, str) and model.existJointName(j),
            f"{at}.joints.{_cut(j)[1:-1]}",
            f"robot '{robot.name}' has no such joint",
        )
        value = _number(v, f"{at}.joints.{j}")
        jm = model.joints[model.getJointId(j)]
        if jm.nq == 1 and j not in arm.joints:  # the arm's joints are checked below (continuous ones too)
            lo, hi = float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q])
            _need(
                lo - LIMIT_SLACK <= value <= hi + LIMIT_SLACK,
                f"{at}.joints.{j}",
                f"{value:g} is outside the URDF limits [{lo:g}, {hi:g}] of robot '{robot.name}'",
            )
    qs = [s.q]
    poses = d.get("poses")
    if poses is not None:
        _need(
            isinstance(poses, list) and len(poses) == len(s.tcp),
            f"{at}.poses",
            f"must be a list of {len(s.tcp)} poses, one per TCP pose",
        )
        qs = []
        for k, p in enumerate(poses):
            pj = p.get("joints") if isinstance(p, dict) else None
            if not (isinstance(pj, dict) and set(pj) == set(arm.joints)):
                raise PlanFileError(
                    f"{at}.poses[{k}].joints: must give exactly the joints of arm '{s.arm}': {', '.join(arm.joints)}"
                )
            qs.append(np.array([_number(pj[j], f"{at}.poses[{k}].joints.{j}") for j in arm.joints]))
    for q, label in [(s.q, "joints"), *((q, f"poses[{k}].joints") for k, q in enumerate(qs) if poses is not None)]:
        bad = np.flatnonzero((q < arm.lower - LIMIT_SLACK) | (q > arm.upper + LIMIT_SLACK))
        if len(bad):
            j = int(bad[0])
            raise PlanFileError(
                f"{at}.{label}.{arm.joints[j]}: {q[j]:g} is outside the URDF limits "
                f"[{arm.lower[j]:g}, {arm.upper[j]:g}] of robot '{robot.name}'"
            )
    c, sn = math.cos(yaw), math.sin(yaw)
    B = np.array([[c, -sn, 0, x], [sn, c, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]])
    T = B @ held(robot, s.joints).tcp_pose(s.arm, s.q)  # the step's torso: the TCP it moves
    held_text = "".join(f", {j} {s.joints[j]:g}" for j in robot.fixed_joints if j in s.joints)
    want = s.tcp[-1]
    off = float(np.linalg.norm(T[:3, 3] - want[:3, 3]))
    turn = math.acos(float(np.clip((np.trace(T[:3, :3].T @ want[:3, :3]) - 1) / 2, -1, 1)))
    _need(
        off <= FK_TOLERANCE_M and turn <= FK_TOLERANCE_RAD,
        f"{at}.joints",
        f"put the TCP {off * 100:.1f} cm and {math.degrees(turn):.1f} deg from the step's last TCP pose "
        f"(robot '{robot.name}', base {list(s.base)}{held_text}): a plan for another robot or scene",
    )


def load_checked_plan(path: Path | str, scene: Scene) -> list[StepResult]:
    """The steps of the plan file at ``path``, checked to belong to ``scene`` (a Scene) and its robot
    (see :func:`check_plan`); PlanFileError naming the file and the key otherwise."""
    from placement.robots import load_robot

    robot = load_robot(scene.robot_preset)
    doc, where = _read(path)
    steps = parse_plan(doc, where, robot)
    check_plan(doc, steps, scene, robot, where)
    return steps
