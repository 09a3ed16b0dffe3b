"""Why a step is infeasible, in plain words (``reason``) and as data (``diagnosis``).

The diagnosis names the pose that is out of reach (index and role in its trajectory), the arm, by
how much (the smallest IK residual the search saw), how many placements were tried and how they
failed, and what would help, read from the maps: the band of heights at which the arm's map holds
values for that pose's orientation, and the arm's horizontal reach there against the nearest free
base cell.
"""

from __future__ import annotations

import math
import weakref
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from placement.kernels.grid import pitch_bin, wrap_bin, zyx_angles
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import FloatArray
from placement.planning.context import PlanningContext
from placement.planning.methods.search import Failure, Search
from placement.planning.problems import Option, Step, blocked_summary, pose_reach, pose_role
from placement.planning.results import InfeasibleStep
from placement.planning.torso import option_map
from placement.planning.world import World
from placement.robots import matrix_to_pose

#: A band of TCP heights (lowest, highest) [m].
Band = tuple[float, float]


def orientation_words(pose: FloatArray) -> str:
    """ "top-down", "horizontal" or "tilted": where the TCP's approach axis (z) points."""
    down = float(pose[2, 2])
    return "top-down" if down < -0.95 else "horizontal" if abs(down) < 0.05 else "tilted"


def height_band(rmap: ReachabilityMap, pose: FloatArray) -> Band | None:
    """Lowest and highest TCP height [m] (above the base frame on the floor) at which ``rmap``
    holds any value for the orientation of ``pose`` (4, 4) (None if it holds none)."""
    g = rmap.grid
    _, pitch, roll = zyx_angles(pose)
    return _band(rmap, pitch_bin(pitch, g.shape[4]), wrap_bin(roll, g.shape[5]))


#: Per map (as long as it lives), its :func:`_band` per (pitch bin, roll bin).
_BANDS: weakref.WeakKeyDictionary[ReachabilityMap, dict[tuple[int, int], Band | None]] = weakref.WeakKeyDictionary()


def _band(rmap: ReachabilityMap, ip: int, ir: int) -> Band | None:
    """:func:`height_band` of the orientation bins (pitch ``ip``, roll ``ir``), kept with the map: it
    reads every height's slice, and a failed step with a thousand candidates asked it for each of
    their poses (seconds past the task's budget)."""
    known = _BANDS.setdefault(rmap, {})
    if (ip, ir) not in known:
        g = rmap.grid
        hit = [iz for iz in range(g.shape[2]) if rmap.slice(iz, ip, ir).any()]
        known[(ip, ir)] = (
            None
            if not hit
            else (float(g.origin[2] + hit[0] * g.resolution), float(g.origin[2] + (hit[-1] + 1) * g.resolution))
        )
    return known[(ip, ir)]


def nearest_free_m(w: World, xy: FloatArray) -> float:
    """Horizontal distance [m] from ``xy`` (2,) [m] to the nearest base-feasible cell centre of
    ``w`` (inf if none)."""
    iy, ix = np.nonzero(w.feasible)
    if iy.size == 0:
        return math.inf
    xs, ys = w.nav.centres()
    return float(np.sqrt((xs[ix] - xy[0]) ** 2 + (ys[iy] - xy[1]) ** 2).min())


def _hint(
    ctx: PlanningContext, fixed: bool, o: Option, pose_index: int, role: str, band: Band | None, searched: bool
) -> str:
    """What would help with pose ``pose_index`` of option ``o`` (``searched``: IK tried placements;
    ``fixed``: the method ranks the pre-defined placements)."""
    pose = o.candidate.poses[pose_index]
    z, how = float(pose[2, 3]), orientation_words(pose)
    arm = f"arm {o.arm}"
    held = "" if o.torso is None else f" with the torso at {o.torso:g}"
    if band is None:
        return f"{arm} reaches no {how} TCP orientation like this one at any height{held} (another grasp would help)"
    lo, hi = band
    if z > hi or z < lo:
        # the band is the map's own limit for this orientation: the heights where it holds any value
        return (
            f"the {role} pose at {z:.2f} m is {'above' if z > hi else 'below'} the {lo:.2f}-{hi:.2f} m band "
            f"{arm} reaches {how}: the heights where its map{held} holds any {how} pose like it"
        )
    reach = pose_reach(option_map(ctx, o), pose)
    near = nearest_free_m(ctx.world, pose[:2, 3])
    if near > reach:
        return (
            f"the {role} pose at {z:.2f} m is within the {lo:.2f}-{hi:.2f} m band {arm} reaches {how}, but "
            f"the nearest free base cell is {near:.2f} m away and the arm reaches {max(reach, 0):.2f} m "
            f"there (an object closer to a free side would help)"
        )
    inside = (
        f"the {role} pose at {z:.2f} m is within the {lo:.2f}-{hi:.2f} m band {arm} reaches {how} and "
        f"within its {reach:.2f} m reach of a free base cell"
    )
    if searched:
        return f"{inside}, but IK confirmed none of the map cells the placements tried fall in"
    if fixed:
        return f"{inside}, but the map marks none of the fixed placements beside the tables reached for it"
    return (
        f"{inside}, but the map values there stay below {arm}'s threshold {ctx.option_threshold(o):.4g} "
        f"(a lower planner.threshold_quantile would help)"
    )


def _worst_pose(ctx: PlanningContext, opts: Sequence[Option]) -> tuple[int, int, Band | None]:
    """(option index, pose index, band) of the pose farthest outside its height band (the first
    option's last pose when every pose is inside)."""
    best: tuple[int, int, Band | None] = (0, len(opts[0].candidate.poses) - 1, None)
    worst = -math.inf
    for k, o in enumerate(opts):
        for i, pose in enumerate(o.candidate.poses):
            band = height_band(option_map(ctx, o), pose)
            z = float(pose[2, 3])
            out = math.inf if band is None else max(band[0] - z, z - band[1])
            if out > worst:
                best, worst = (k, i, band), out
    return best


def explain(
    ctx: PlanningContext, fixed: bool, step: Step, opts: Sequence[Option], search: Search | None, base_reason: str = ""
) -> tuple[str, dict[str, Any]]:
    """(reason, diagnosis) of an infeasible step: ``search`` is the IK search (None when no
    placement kept the map threshold; ``base_reason`` then says that in words); ``fixed``: the
    method ranks the pre-defined placements beside the tables."""
    if not opts:
        return base_reason or "the step has no candidate trajectory", {}
    summary = blocked_summary(opts)
    blocked = summary[0] if summary is not None else 0
    if search is None and summary is not None and blocked == len(opts):
        # the gripper alone rules out every candidate: neither maps nor IK were asked
        o = summary[1]
        return base_reason, {
            "arm": o.arm,
            "trajectory": o.candidate.name,
            "gripper_blocked": len(opts),
            "culprit": o.blocked,
            "hint": "another grasp, or room around the object for the gripper, would help",
        }
    ik_fails = [f for f in search.failures if f.kind == "ik"] if search else []
    collisions: Counter[str] = search.culprits() if search else Counter()
    f: Failure | None = None
    if ik_fails:
        f = min(ik_fails, key=lambda f: f.residual_m + 0.1 * f.residual_rad)
        k, i = f.option, f.pose if f.pose is not None else len(opts[f.option].candidate.poses) - 1
        band = height_band(option_map(ctx, opts[k]), opts[k].candidate.poses[i])
    else:
        k, i, band = _worst_pose(ctx, opts)
    o = opts[k]
    pose = o.candidate.poses[i]
    role = pose_role(step.action, i, len(o.candidate.poses))
    hint = _hint(ctx, fixed, o, i, role, band, search is not None)
    culprit = collisions.most_common(1)[0][0] if collisions else None
    ncol = sum(collisions.values()) if search else 0
    d: dict[str, Any] = {
        "arm": o.arm,
        "trajectory": o.candidate.name,
        "pose_index": i,
        "pose_role": role,
        "pose": matrix_to_pose(pose),
        "height_m": round(float(pose[2, 3]), 6),
        "orientation": orientation_words(pose),
        "band_m": [round(v, 6) for v in band] if band else None,
        "residual_m": None if f is None else round(f.residual_m, 6),
        "residual_rad": None if f is None else round(f.residual_rad, 6),
        "tried": search.tried if search else 0,
        "ik_failures": len(ik_fails),
        "collision_failures": ncol,
        "culprit": culprit,
        "stopped": search.stop if search else None,
        "gripper_blocked": blocked,
        "hint": hint,
    }
    if search is None:
        return f"{base_reason}; {hint}", d
    if search.stop == "task" and search.tried == 0:
        return ctx.budget_words(), d
    stop = {
        "budget": f", when the {ctx.config.ik_budget_ms:g} ms IK budget ran out",
        "task": ", when " + ctx.budget_words().replace(" before this step was verified", ""),
        "cap": f", the most the search tries ({ctx.config.ik_cap})",
    }.get(search.stop, ", every candidate")
    if search.tried == 0:
        return f"the base cannot get to any of the placements that reach the target from where it is; {hint}", d
    tried = f"no placement verified after {search.tried} tries{stop} ({len(ik_fails)} failed IK, {ncol} in collision)"
    parts = []
    if ncol and ncol >= len(ik_fails):
        parts.append(
            f"IK reached every pose at {ncol} of them but the arm collided there"
            + (f", mostly {culprit}" if culprit else "")
        )
    if f is not None:
        parts.append(
            f"the {role} pose (pose {i} of '{o.candidate.name}', {float(pose[2, 3]):.2f} m high) is out of "
            f"reach for arm {o.arm} by {f.residual_m * 100:.1f} cm and {f.residual_rad:.2f} rad at best"
        )
    return f"{tried}: {'; '.join(parts + [hint])}", d


#: A step no path of the base reaches: its reason (the hint follows, see :func:`no_path_hint`).
NO_PATH = "no collision-free path for the base reaches a placement of this step"


def no_path_hint(cells: int, driven: int, whence: str = "the start") -> str:
    """Where the maps keep the threshold and how much of it the base can reach from ``whence``."""
    where = (
        f"the maps keep the threshold on {cells} base cells around the target, {driven} of them reachable from {whence}"
    )
    if driven:
        return where
    return (
        f"{where}: they lie where the footprint cannot drive (behind a passage narrower than it, unknown "
        "cells or a keepout mask); occupancy_map unknown: free, or a smaller footprint, may help"
    )


def diagnosed(
    ctx: PlanningContext,
    step: Step,
    opts: Sequence[Option],
    reason: str,
    hint: str,
    facts: dict[str, Any] | None = None,
) -> InfeasibleStep:
    """The infeasible result of ``step``: ``reason; hint``, with the diagnosis of :func:`explain` (the
    pose of the options nearest their limits), ``hint`` as its hint and ``facts`` over its keys (what
    the checks found: ``tried``, ``ik_failures``, ``collision_failures``, ``culprit``)."""
    _, diagnosis = explain(ctx, False, step, opts, None, reason)
    if diagnosis:
        diagnosis.update(facts or {})
        diagnosis["hint"] = hint
    return InfeasibleStep(step.index, step.action, step.target, reason=f"{reason}; {hint}", diagnosis=diagnosis)
