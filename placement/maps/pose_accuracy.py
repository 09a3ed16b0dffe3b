"""Pose-level accuracy of a map against inverse kinematics: precision over poses drawn inside the cells the
map calls reachable, recall over cells an independent IK reaches, with 95 % Wilson intervals (1 cm, 0.05 rad).

The cell-level check that reports them too is :func:`placement.maps.accuracy.check_map`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from placement.errors import MapError
from placement.kinematics.ik import solve_ik
from placement.maps.build import arm_reach
from placement.maps.grid import Grid
from placement.robots import Robot

if TYPE_CHECKING:
    from placement.maps.rmap import ReachabilityMap
    from placement.storage.format import BuiltMap


#: a robot's held torso joints match a map's setting this closely [rad or m]
SETTING_TOLERANCE = 1e-9


def is_setting_map(meta: dict[str, Any]) -> bool:
    """Whether a map (``meta``) is one torso setting's build of a map built once per setting (its
    ``setting`` record, or the reference's ``torso`` record without a shift); a shifted map is not: the
    reference robot checks every setting of it."""
    record = meta.get("torso")
    return bool(meta.get("setting")) or bool(record and record.get("shift") is None)


def check_setting(robot: Robot, meta: dict[str, Any]) -> None:
    """MapError unless ``robot`` holds every fixed joint where the build of a torso setting's map
    (``meta``) held it: IK of another setting's robot would measure the map against the wrong arm."""
    if not is_setting_map(meta):
        return
    for joint, value in (meta.get("fixed_joints") or {}).items():
        held = robot.fixed_joints.get(joint)
        if held is None or abs(held - float(value)) > SETTING_TOLERANCE:
            now = "does not hold it" if held is None else f"holds it at {held:g}"
            raise MapError(
                f"map of arm '{meta.get('arm')}' was built with {joint} at {float(value):g}, the robot {now}; "
                f"check a torso setting's map with the robot held there (robot.with_fixed)"
            )


def ratio(num: float, den: float) -> float | None:
    """num / den, None when den is 0."""
    return float(num / den) if den > 0 else None


def reach_sphere(robot: Robot, arm: str, grid: Grid) -> tuple[np.ndarray, float, np.ndarray]:
    """(centre (3,) [m], reach bound [m], in_reach (nx*ny*nz,) bool): position cells whose centre lies
    in the arm's reach sphere (:func:`placement.maps.build.arm_reach`)."""
    centre, reach = arm_reach(robot, arm)
    axes = [grid.origin[i] + (np.arange(grid.shape[i]) + 0.5) * grid.resolution for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    in_reach = ((X - centre[0]) ** 2 + (Y - centre[1]) ** 2 + (Z - centre[2]) ** 2 <= reach**2).reshape(-1)
    return centre, reach, in_reach


POSE_POS_TOL = 0.01  # [m]: pose-level metrics ask IK for the drawn pose itself, not "somewhere in the cell"
POSE_ROT_TOL = 0.05  # [rad]
Z95 = 1.959963984540054


def wilson(k: int, n: int) -> list[float] | None:
    """95 % Wilson score interval [lo, hi] of a proportion k / n (None for n = 0)."""
    if n == 0:
        return None
    p = k / n
    d = 1 + Z95**2 / n
    mid = (p + Z95**2 / (2 * n)) / d
    half = Z95 * np.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / d
    return [float(max(0.0, mid - half)), float(min(1.0, mid + half))]


def poses_in_cells(grid: Grid, cells: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Poses (N, 4, 4) drawn uniformly inside the cells ``cells`` (N,): position uniform in the cube,
    yaw / pitch / roll uniform within their bins [rad]."""
    from placement.maps.grid import pose_from_zyx

    idx = np.stack(np.unravel_index(np.asarray(cells, dtype=np.int64), grid.shape), axis=-1).astype(float)
    u = rng.random((len(cells), 6))
    dyaw, dpitch, droll = grid.angle_steps
    pos = grid.origin_array + (idx[:, :3] + u[:, :3]) * grid.resolution
    return pose_from_zyx(
        pos,
        (idx[:, 3] - 0.5 + u[:, 3]) * dyaw,
        -np.pi / 2 + (idx[:, 4] + u[:, 4]) * dpitch,
        (idx[:, 5] - 0.5 + u[:, 5]) * droll,
    )


def pose_metrics(
    robot: Robot,
    rmap: ReachabilityMap | BuiltMap,
    samples: int = 200,
    seed: int = 0,
    threshold: float = 0.0,
    *,
    ik_seeds: int = 8,
    max_iter: int = 200,
    max_draws: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Pose-level precision and recall of a map against IK (1 cm, 0.05 rad).

    * precision: ``samples`` cells drawn uniformly among those the map calls reachable
      (value > threshold), one pose drawn uniformly inside each (:func:`poses_in_cells`);
      the fraction IK reaches to POSE_POS_TOL / POSE_ROT_TOL, IK seeded by the cell's witness
      (when the map has witnesses) and then ``ik_seeds - 1`` random restarts.
    * recall: cells drawn uniformly among those in the reach sphere, kept when an independent
      IK (home + random restarts, no witness) reaches the cell's centre pose to the same
      tolerances, until ``samples`` are kept or ``max_draws`` (default 50 * samples) are drawn;
      the fraction of kept cells the map marks reachable.

    Returns a dict with ``precision``, ``recall`` (None without data), their 95 % Wilson
    intervals ``*_ci95``, the counts, ``pos_tol_m``, ``rot_tol_rad`` and ``time_s``.
    """
    from placement.maps.witness import witness_configs

    t0 = time.perf_counter()
    meta = rmap.meta
    check_setting(robot, meta)
    arm = meta["arm"]
    grid = rmap.grid
    flat = rmap.values.reshape(-1)
    rng = np.random.default_rng(seed)
    reached = np.flatnonzero(flat > threshold)
    k = min(samples, reached.size)
    cells = np.sort(rng.choice(reached, size=k, replace=False)) if k else reached[:0]
    del reached
    poses = poses_in_cells(grid, cells, rng)
    witness = getattr(rmap, "witness", None)
    starts = [None] * k
    if witness is not None and k and "witness" in meta:
        starts = list(
            witness_configs(
                robot.arm(arm),
                grid,
                int(meta["seed"]),
                int(meta["witness"]["plain_samples"]),
                witness.reshape(-1)[cells],
            )
        )
    max_draws = 50 * samples if max_draws is None else max_draws
    total = k + samples
    hits = 0
    for i in range(k):
        hits += solve_ik(
            robot,
            arm,
            poses[i],
            q_seed=starts[i],
            seeds=ik_seeds,
            rng_seed=seed * 7919 + i,
            pos_tol=POSE_POS_TOL,
            rot_tol=POSE_ROT_TOL,
            max_iter=max_iter,
        ).success
        if progress is not None:
            progress(i + 1, total)
    _, _, in_reach = reach_sphere(robot, arm, grid)
    positions = np.flatnonzero(in_reach)
    n_orient = int(np.prod(grid.shape[3:]))
    kept = marked = draws = 0
    # its own stream: the same seed draws the same recall cells for any map of this grid (paired comparisons)
    rng = np.random.default_rng([seed, 1])
    while kept < samples and draws < max_draws:
        cell = int(positions[rng.integers(positions.size)]) * n_orient + int(rng.integers(n_orient))
        draws += 1
        res = solve_ik(
            robot,
            arm,
            grid.centre(np.array([cell]))[0],
            seeds=ik_seeds,
            rng_seed=seed * 104729 + draws,
            pos_tol=POSE_POS_TOL,
            rot_tol=POSE_ROT_TOL,
            max_iter=max_iter,
        )
        if res.success:
            kept += 1
            marked += bool(flat[cell] > threshold)
            if progress is not None:
                progress(k + kept, total)
    return {
        "pos_tol_m": POSE_POS_TOL,
        "rot_tol_rad": POSE_ROT_TOL,
        "precision": ratio(hits, k),
        "precision_ci95": wilson(hits, k),
        "precision_poses": int(k),
        "precision_reached": int(hits),
        "witness_seeded": witness is not None and "witness" in meta,
        "recall": ratio(marked, kept),
        "recall_ci95": wilson(marked, kept),
        "recall_cells": int(kept),
        "recall_marked": int(marked),
        "recall_draws": int(draws),
        "reachable_fraction_in_reach": ratio(kept, draws),
        "time_s": round(time.perf_counter() - t0, 3),
    }
