"""``placement robots check``: what a loaded preset's robot reaches before any map is built.

For every arm and both approaches (top-down, horizontal) the :func:`~placement.robots.onboarding.reach.reach_band`,
a check that the TCP's approach axis points out of the gripper (away from the wrist), warnings in
plain words where a table of :data:`TABLE_HEIGHT` and its pre-grasp :data:`PRE_GRASP` above are at or
beyond the edge of a band (with the held torso values that would clear it, :func:`torso_fix`), and
where an arm spans fewer than the 6 pose directions (:mod:`.rank`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from placement.robots.chain import PRISMATIC, ancestors, extract_chain
from placement.robots.model_cache import frame_id
from placement.robots.onboarding.rank import pose_rank, rank_warning
from placement.robots.onboarding.reach import (
    APPROACHES,
    SAMPLES,
    Band,
    band_of,
    base_clearance,
    chain_fk,
    reach_band,
    sample_configs,
)
from placement.robots.onboarding.torso import Family, family_grid, joint_axes_kind, set_joint, words_of

if TYPE_CHECKING:
    from placement.robots.preset import Robot


#: Typical table top [m] and the pre-grasp height above a grasp [m] the warnings refer to.
TABLE_HEIGHT = 0.75
PRE_GRASP = 0.10
#: A band edge closer than this to a height of interest puts that height "at the edge" [m].
EDGE = 0.05


def held_words(robot: Robot) -> str:
    """'with torso_lift_joint at 0.20 m' (every fixed joint), or 'with no joint held'."""
    if not robot.fixed_joints:
        return "with no joint held"
    parts = []
    for name, value in robot.fixed_joints.items():
        jid = robot.model.getJointId(name)
        prismatic = robot.model.joints[jid].shortname().replace("JointModel", "").startswith("P")
        parts.append(f"{name} at {value:.2f} {'m' if prismatic else 'rad'}")
    return "with " + ", ".join(parts)


def band_warnings(robot: Robot, band: Band) -> list[str]:
    """Plain-words warnings about ``band`` for a table at :data:`TABLE_HEIGHT`."""
    what = {"down": "a top-down grasp", "horizontal": "a horizontal (side) grasp"}[band.approach]
    who = f"arm '{band.arm}' {held_words(robot)}"
    grasp = TABLE_HEIGHT + (0.0 if band.approach == "down" else 0.05)
    need = (grasp, grasp + PRE_GRASP) if band.approach == "down" else (grasp, grasp)
    if band.empty:
        return [f"{who}: {what} is never reached (no sampled configuration has that approach)"]
    span = f"{band.z_min:.2f}-{band.z_max:.2f} m high"
    if not band.z_min <= grasp <= band.z_max:
        return [f"{who}: {what} reaches only {span}; {TABLE_HEIGHT} m tables are out of reach"]
    if need[0] - band.z_min < EDGE or band.z_max - need[1] < EDGE:
        return [
            f"{who}: {what} reaches only {span}; {TABLE_HEIGHT} m tables are at the edge"
            + (f" (the pre-grasp {PRE_GRASP:.2f} m above is at {need[1]:.2f} m)" if band.approach == "down" else "")
        ]
    return []


def tcp_axis_check(robot: Robot, arm: str) -> dict[str, Any]:
    """Where the TCP's approach axis points at the home configuration: {"cos": cosine between TCP z and
    the wrist -> TCP direction, "wrist": [m], "tcp": (4, 4) as lists, "ok": bool}. A negative cosine
    means the approach axis points back into the arm."""
    a = robot.arm(arm)
    data = robot.model.createData()
    q = robot.full_q(arm, a.home)
    pin.framesForwardKinematics(robot.model, data, q)
    base = data.oMf[robot.base_frame_id].inverse()
    wrist = (base * data.oMi[a.joint_ids[-1]]).translation
    T = robot.tcp_pose(arm, a.home)
    d = T[:3, 3] - wrist
    n = np.linalg.norm(d)
    cos = float(T[:3, 2] @ d / n) if n > 1e-3 else float("nan")
    return {
        "cos": None if not np.isfinite(cos) else round(cos, 4),
        "wrist": [round(float(v), 4) for v in wrist],
        "tcp": np.round(T, 4).tolist(),
        "ok": bool(not np.isfinite(cos) or cos > 0.3),
    }


#: Joint samples per posture tried for a fix.
FIX_SAMPLES = 20_000


def torso_joints(robot: Robot, arm: str) -> list[int]:
    """Held joints between the base frame and ``arm`` (joint ids, root first): the torso that carries it."""
    model = robot.model
    first = robot.arm(arm).joint_ids[0]
    under_base = set(ancestors(model, model.frames[robot.base_frame_id].parentJoint))
    return sorted(
        j for j in ancestors(model, first)[1:] if model.names[j] in robot.fixed_joints and j not in under_base
    )


def fix_words(robot: Robot, posture: dict[int, float]) -> str:
    """'raising torso_lift_joint to 0.25 m' (one joint) or 'holding torso_1 at 0.4 rad, ...' (several)."""
    model = robot.model
    if len(posture) == 1:
        ((j, v),) = posture.items()
        prismatic = joint_axes_kind(model, j) == PRISMATIC
        verb = "raising" if v > robot.fixed_joints[model.names[j]] else "lowering"
        return f"{verb if prismatic else 'turning'} {model.names[j]} to {v:.2f} {'m' if prismatic else 'rad'}"
    return f"holding {words_of(model, posture)} (upright)"


def torso_fix(robot: Robot, band: Band, seed: int = 0) -> str | None:
    """Plain words naming held torso values (upright postures, :func:`~.torso.family_grid`) that clear
    the warnings of ``band``, the ones nearest the preset's values; None when none does or no torso."""
    torso = torso_joints(robot, band.arm)
    if not torso:
        return None
    model, a = robot.model, robot.arm(band.arm)
    q = robot.reference_q()
    current = {j: robot.fixed_joints[model.names[j]] for j in torso}
    options = []
    for posture in family_grid(model, q, Family([torso], "torso")):
        if all(abs(posture[j] - current[j]) < 1e-6 for j in posture):
            continue
        qc = q.copy()
        for j, v in posture.items():
            set_joint(model, qc, j, v)
        for j in a.joint_ids:
            set_joint(model, qc, j, 0.0)
        tip = frame_id(model, a.tip_frame)
        chain = extract_chain(model, qc, robot.base_frame_id, a.joint_ids, tip, a.tcp_offset, (robot.name, a.name))
        T = chain_fk(chain, sample_configs(a.lower, a.upper, FIX_SAMPLES, seed))
        b = band_of(T, band.approach, band.arm, robot.fixed_joints, base_clearance(robot))
        if not band_warnings(robot, b):
            shift = sum(abs(posture[j] - current[j]) for j in posture)
            options.append((shift, posture, b))
    if not options:
        return None
    _, posture, b = min(options, key=lambda t: t[0])
    what = {"down": "top-down", "horizontal": "horizontal"}[band.approach]
    return f"{fix_words(robot, posture)} brings the {what} band of arm '{band.arm}' to {b.z_min:.2f}-{b.z_max:.2f} m"


def check_robot(robot: Robot, samples: int = SAMPLES, seed: int = 0) -> dict[str, Any]:
    """Reach bands, TCP axis checks and warnings of every arm of ``robot`` (JSON-ready)."""
    out: dict[str, Any] = {
        "robot": robot.name,
        "preset": str(robot.source),
        "base_frame": robot.base_frame,
        "fixed_joints": dict(robot.fixed_joints),
        "arms": {},
        "warnings": [],
    }
    for arm in robot.arms:
        a = robot.arm(arm)
        bands = {ap: reach_band(robot, arm, ap, samples, seed) for ap in APPROACHES}
        axis = tcp_axis_check(robot, arm)
        out["arms"][arm] = {
            "dof": len(a.joints),
            "tip_frame": a.tip_frame,
            "prismatic_joints": int(np.sum(a.chain.kind == PRISMATIC)),
            "bands": {ap: b.to_json() for ap, b in bands.items()},
            "tcp_axis": axis,
        }
        rank = pose_rank(a.chain, a.lower, a.upper)
        out["arms"][arm]["pose_rank"] = rank
        w = rank_warning(arm, rank)
        if w:
            out["warnings"].append(w)
        for b in bands.values():
            found = band_warnings(robot, b)
            out["warnings"] += found
            fix = torso_fix(robot, b, seed) if found else None
            if fix:
                out["warnings"].append(fix)
        if not axis["ok"]:
            out["warnings"].append(
                f"arm '{arm}': at home the TCP's approach axis (z) points back towards the wrist "
                f"(cosine {axis['cos']}): the tcp_offset is probably wrong"
            )
    return out


def render_table(doc: dict[str, Any]) -> str:
    """The terminal table of :func:`check_robot`'s result."""
    lines = [
        f"robot {doc['robot']} ({doc['preset']}), base frame {doc['base_frame']}, held: "
        + (", ".join(f"{k}={v:g}" for k, v in doc["fixed_joints"].items()) or "nothing"),
        f"{'arm':<8} {'approach':<11} {'height [m]':>13} {'distance [m]':>13} {'matched':>9}",
    ]
    fmt: Callable[[float | None, float | None], str] = lambda lo, hi: "-" if lo is None else f"{lo:.2f} - {hi:.2f}"  # noqa: E731
    for arm, v in doc["arms"].items():
        for ap, b in v["bands"].items():
            lines.append(
                f"{arm:<8} {ap:<11} {fmt(b['z_min'], b['z_max']):>13} {fmt(b['r_min'], b['r_max']):>13} "
                f"{b['matched']:>9}"
            )
    lines += [f"warning: {w}" for w in doc["warnings"]]
    lines += [f"plot: {p}" for p in doc.get("plots", [])]
    return "\n".join(lines)
