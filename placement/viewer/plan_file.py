"""Plan files for the viewer: a plan document (the JSON of ``placement query --json``, SPEC section 7)
read and checked into :class:`~placement.planning.StepResult` objects, as the planner makes them."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..planning.results import Cost, StepResult
from ..robots import pose_to_matrix
from .server import ViewerError


class PlanFileError(ViewerError):
    """A plan file that cannot be shown; the one-line message names the file and the key."""


def title(s) -> str:
    """One line naming a :class:`~placement.planning.StepResult`: step, action, target, arm and grasp
    (or why it is infeasible)."""
    what = f"step {s.step}: {s.action} {s.target}"
    return f"{what} ({s.arm} arm, {s.grasp})" if s.ok else f"{what} (infeasible: {s.reason})"


def _need(cond: bool, where: str, msg: str) -> None:
    if not cond:
        raise PlanFileError(f"{where}: {msg}")


def _number(v, where: str) -> float:
    _need(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v), where,
          f"must be a finite number, got {json.dumps(v)[:40] if _jsonable(v) else type(v).__name__}")
    return float(v)


def _jsonable(v) -> bool:
    try:
        json.dumps(v)
        return True
    except (TypeError, ValueError, RecursionError):
        return False


def _text(d: dict, key: str, where: str) -> str:
    v = d.get(key)
    _need(isinstance(v, str) and v != "", f"{where}.{key}", "must be a non-empty string")
    return v


def _numbers(v, n: int | None, where: str) -> list[float]:
    _need(isinstance(v, list) and (n is None or len(v) == n), where,
          f"must be a list of {n if n is not None else 'some'} numbers")
    return [_number(x, f"{where}[{i}]") for i, x in enumerate(v)]


def parse_step(d, where: str, robot) -> StepResult:
    """One step of a plan document; ``robot`` names the arms and joints it may use."""
    _need(isinstance(d, dict), where, "must be a mapping")
    step = d.get("step")
    _need(isinstance(step, int) and not isinstance(step, bool) and step >= 0, f"{where}.step",
          "must be a step index (an integer >= 0)")
    action, target = _text(d, "action", where), _text(d, "target", where)
    if d.get("status", "ok") != "ok":
        _need(d.get("status") == "infeasible", f"{where}.status", "must be 'ok' or 'infeasible'")
        reason = d.get("reason")
        return StepResult(step, action, target, "infeasible", reason if isinstance(reason, str) else "no reason given")
    arm = _text(d, "arm", where)
    _need(arm in robot.arms, f"{where}.arm", f"no arm '{arm}' on robot '{robot.name}'; arms: {', '.join(robot.arms)}")
    base = tuple(_numbers(d.get("base"), 3, f"{where}.base"))
    tcp = d.get("tcp")
    _need(isinstance(tcp, list) and len(tcp) > 0, f"{where}.tcp", "must be a non-empty list of poses [x, y, z, qx, qy, qz, qw]")
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
    extra = {key: _number(d[key], f"{where}.{key}") if key in d else None
             for key in ("manipulability", "travel_time_s")}
    cost = d.get("cost") if isinstance(d.get("cost"), dict) else {}
    terms = ("navigation", "manipulation", "heuristic")
    cost = Cost(*(_number(cost[t], f"{where}.cost.{t}") for t in terms)) if all(t in cost for t in terms) else None
    grasp = d.get("grasp") if isinstance(d.get("grasp"), str) else "?"
    return StepResult(step, action, target, "ok", None, arm, grasp, base, np.stack(poses), q,
                      {j: float(v) for j, v in zip(names, q)}, extra["manipulability"], cost, extra["travel_time_s"])


def parse_plan(doc, where: str, robot) -> list[StepResult]:
    """The steps of a plan document ``doc`` (parsed JSON) read from ``where``; PlanFileError if it is
    not one, or uses an arm or joint ``robot`` lacks."""
    _need(isinstance(doc, dict), where, "not a plan document (a JSON object with 'steps')")
    steps = doc.get("steps")
    _need(isinstance(steps, list) and len(steps) > 0, f"{where}: steps",
          "must be a non-empty list (write one with `placement query SCENE --json > plan.json`)")
    name = (doc.get("robot") or {}).get("name") if isinstance(doc.get("robot"), dict) else None
    _need(name in (None, robot.name), f"{where}: robot.name",
          f"the plan is for robot '{name}', the scene's robot is '{robot.name}'")
    return [parse_step(s, f"{where}: steps[{i}]", robot) for i, s in enumerate(steps)]


def load_plan(path, robot) -> list[StepResult]:
    """The steps of the plan file at ``path`` (PlanFileError naming the file if it is unreadable)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanFileError(f"--plan {p}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise PlanFileError(f"--plan {p}: not JSON ({type(exc).__name__}: {str(exc)[:80]})") from None
    return parse_plan(doc, str(p), robot)
