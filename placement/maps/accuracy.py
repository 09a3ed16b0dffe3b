"""Map accuracy against inverse kinematics, the way capability maps report it.

A reachability map is a sampled approximation: a cell it calls reachable may
hold only awkward poses (its centre may be out of reach), and a cell it calls
unreachable may simply not have been hit by a sample yet. :func:`check_map`
measures both by running IK (:func:`placement.kinematics.ik.solve_ik`) on cell centres:

* **Positives**: ``samples`` cells drawn uniformly (without replacement) from
  the cells whose value is above ``threshold``.
* **Negatives**: ``samples`` cells drawn uniformly (without replacement) from
  the cells whose value is at or below ``threshold`` *and whose position cell
  centre lies within the arm's reach bound* (:func:`placement.maps.build.arm_reach`:
  a sphere around the first joint, radius = sum of the link lengths + TCP
  offset). Without that restriction most negatives would be corners of the
  grid cube that no configuration can reach, and the negative predictive value
  would look good for free.
* The pose is the cell centre (:meth:`Grid.centre`). It counts as **reached
  within one cell** when IK succeeds with position tolerance = the grid
  resolution [m] and rotation tolerance = the largest orientation bin width
  (``max(grid.angle_steps)``) [rad]. IK respects joint limits; self-collision
  is not checked (the map does not check it either).

Counts: TP = positive reached, FP = positive not reached, TN = negative not
reached, FN = negative reached. Since both classes are sampled equally, the
rates that mix them (recall, specificity, accuracy) are estimated by weighting
precision and NPV with the class sizes of the map (``*_estimate``);
``accuracy`` is the plain accuracy over the drawn (balanced) sample. The
negatives mostly measure how converged the map is (cells not sampled yet):
a map built from few samples has a low NPV and recall, not a wrong precision.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from placement.errors import MapError, PlacementError
from placement.kinematics.ik import solve_ik
from placement.maps.buildspec import MAX_SEED, parse_count
from placement.maps.pose_accuracy import (
    POSE_POS_TOL,
    POSE_ROT_TOL,
    check_setting,
    pose_metrics,
    poses_in_cells,
    ratio,
    reach_sphere,
    wilson,
)
from placement.robots import Robot

if TYPE_CHECKING:
    from placement.maps.rmap import ReachabilityMap
    from placement.storage.format import BuiltMap

# the pose level's names keep their import path here (the CLI, tools and tests read them from this module)
__all__ = [
    "MAX_CHECK_SAMPLES",
    "POSE_POS_TOL",
    "POSE_ROT_TOL",
    "check_map",
    "pose_metrics",
    "poses_in_cells",
    "reach_sphere",
    "wilson",
]

_CHUNK = 1 << 24
#: IK checks per class and arm: 5,000 took 31 s for one arm of the 5 cm PR2 maps on 2 busy cores (15 s
#: of it reading and checking the map's chunks; 200 took 17 s); 100,000 ran past 120 s
MAX_CHECK_SAMPLES = 5_000


def check_map(
    robot: Robot,
    rmap: ReachabilityMap | BuiltMap,
    samples: int = 200,
    seed: int = 0,
    threshold: float = 0.0,
    *,
    ik_seeds: int = 8,
    max_iter: int = 200,
    pose_level: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Accuracy of ``rmap`` against IK on random cells it calls reachable and unreachable.

    Args:
        robot: the robot the map was built for (a map of one torso setting: with the torso held there,
            ``robot.with_fixed({joint: value})``; MapError otherwise).
        rmap: a :class:`placement.ReachabilityMap` (from :func:`placement.open_map`)
            or a :class:`placement.BuiltMap` (from :func:`placement.build_map`);
            its arm is ``rmap.meta["arm"]``. The whole array is read.
        samples: cells drawn per class (positives and negatives each), 1 ..
            MAX_CHECK_SAMPLES; fewer if the class has fewer cells.
        seed: 0 .. 2^64 - 1, seed of the cell draws and of the IK restarts (deterministic).
        threshold: map value at or below which a cell counts as unreachable
            (0 = never reached; the planner's feasibility threshold otherwise).
        ik_seeds: IK start configurations (see :func:`placement.kinematics.ik.solve_ik`).
        max_iter: IK iterations per start.
        pose_level: also the honest pose-level metrics (:func:`pose_metrics`, same samples and
            seed), under ``pose_level``; the cell-level numbers above use a cell-sized tolerance.
        progress: optional ``progress(done, total)`` called after each IK solve.

    Returns:
        A JSON-serialisable dict: ``robot``, ``arm``, ``samples``, ``seed``,
        ``threshold``, ``pos_tol_m``, ``rot_tol_rad``, ``positives_drawn``,
        ``negatives_drawn``, ``true_positives``, ``false_positives``,
        ``true_negatives``, ``false_negatives``, ``precision`` (TP / (TP+FP)),
        ``negative_predictive_value`` (TN / (TN+FN)), ``recall_estimate``,
        ``specificity_estimate``, ``accuracy`` (over the drawn cells),
        ``accuracy_estimate`` (class-size weighted), ``map_positive_cells``,
        ``map_negative_cells_in_reach``, ``reach`` (``centre`` [m], ``radius_m``),
        ``positive_cells`` / ``negative_cells`` (the drawn flat cell indices, sorted),
        ``false_positive_cells`` / ``false_negative_cells`` (flat cell indices),
        ``time_s`` (total), ``ik_time_s`` and ``ik_ms_per_pose``. A rate whose
        denominator is 0 is None.
    """
    t_start = time.perf_counter()
    if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in (samples, seed)):
        raise PlacementError(f"samples and seed must be integers, got {samples!r} and {seed!r}")
    samples = parse_count(int(samples), "samples", 1, MAX_CHECK_SAMPLES)
    seed = parse_count(int(seed), "seed", 0, MAX_SEED)
    meta = rmap.meta
    arm = meta["arm"]
    if meta.get("robot") != robot.name or meta.get("urdf_sha256", robot.urdf_sha256) != robot.urdf_sha256:
        raise MapError(
            f"map of arm '{arm}' was built for robot '{meta.get('robot')}' (or another URDF), not '{robot.name}'"
        )
    check_setting(robot, meta)  # a torso setting's map: IK with the torso where it was built
    grid = rmap.grid
    values = rmap.values
    if values.shape != grid.shape:
        raise MapError(f"map values have shape {values.shape}, its grid says {grid.shape}")
    flat = values.reshape(-1)
    n_orient = int(np.prod(grid.shape[3:]))
    n_pos_cells = int(np.prod(grid.shape[:3]))

    centre, reach, in_reach = reach_sphere(robot, arm, grid)

    # One pass: positive cells (flat indices) and positives per position cell.
    pos_blocks = []
    pos_per_position = np.zeros(n_pos_cells, dtype=np.int64)
    step = max(1, _CHUNK // n_orient) * n_orient
    for lo in range(0, flat.size, step):
        block = flat[lo : lo + step] > threshold
        pos_blocks.append(np.flatnonzero(block) + lo)
        pos_per_position[lo // n_orient : lo // n_orient + block.size // n_orient] = block.reshape(-1, n_orient).sum(
            axis=1
        )
    pos_cells = np.concatenate(pos_blocks) if pos_blocks else np.zeros(0, dtype=np.int64)
    n_pos = int(pos_cells.size)
    reach_positions = np.flatnonzero(in_reach)
    n_neg = int(len(reach_positions) * n_orient - pos_per_position[reach_positions].sum())

    rng = np.random.default_rng(seed)
    k_pos = min(samples, n_pos)
    positives = np.sort(pos_cells[rng.choice(n_pos, size=k_pos, replace=False)]) if k_pos else pos_cells[:0]
    del pos_cells
    negatives = _draw_negatives(rng, flat, threshold, reach_positions, n_orient, n_neg, min(samples, n_neg))

    pos_tol = float(grid.resolution)
    rot_tol = float(max(grid.angle_steps))
    cells = np.concatenate([positives, negatives]).astype(np.int64)
    poses = grid.centre(cells) if len(cells) else np.zeros((0, 4, 4))
    reached = np.zeros(len(cells), dtype=bool)
    t_ik = time.perf_counter()
    for k in range(len(cells)):
        res = solve_ik(
            robot,
            arm,
            poses[k],
            seeds=ik_seeds,
            rng_seed=int(seed) * 1_000_003 + k,
            pos_tol=pos_tol,
            rot_tol=rot_tol,
            max_iter=max_iter,
        )
        reached[k] = res.success
        if progress is not None:
            progress(k + 1, len(cells))
    ik_time = time.perf_counter() - t_ik
    pose = (
        pose_metrics(robot, rmap, samples, seed, threshold, ik_seeds=ik_seeds, max_iter=max_iter)
        if pose_level
        else None
    )

    hit_pos, hit_neg = reached[:k_pos], reached[k_pos:]
    tp, fp = int(hit_pos.sum()), int((~hit_pos).sum())
    fn, tn = int(hit_neg.sum()), int((~hit_neg).sum())
    precision = ratio(tp, tp + fp)
    npv = ratio(tn, tn + fn)
    # Class-size weighted estimates over the population (map positives + in-reach map negatives).
    recall = specificity = acc_est = None
    if precision is not None and npv is not None:
        true_pos_pop = n_pos * precision  # map positives that IK reaches
        missed_pop = n_neg * (1.0 - npv)  # map negatives that IK reaches
        true_neg_pop = n_neg * npv
        false_pos_pop = n_pos * (1.0 - precision)
        recall = ratio(true_pos_pop, true_pos_pop + missed_pop)
        specificity = ratio(true_neg_pop, true_neg_pop + false_pos_pop)
        acc_est = ratio(true_pos_pop + true_neg_pop, n_pos + n_neg)
    return {
        "robot": robot.name,
        "arm": arm,
        "samples": int(samples),
        "seed": int(seed),
        "threshold": float(threshold),
        "pos_tol_m": pos_tol,
        "rot_tol_rad": rot_tol,
        "positives_drawn": int(k_pos),
        "negatives_drawn": int(len(negatives)),
        "true_positives": tp,
        "false_positives": fp,
        "true_negatives": tn,
        "false_negatives": fn,
        "precision": precision,
        "negative_predictive_value": npv,
        "recall_estimate": recall,
        "specificity_estimate": specificity,
        "accuracy": ratio(tp + tn, len(cells)),
        "accuracy_estimate": acc_est,
        "map_positive_cells": n_pos,
        "map_negative_cells_in_reach": n_neg,
        "reach": {"centre": [float(v) for v in centre], "radius_m": float(reach)},
        "positive_cells": [int(c) for c in positives],
        "negative_cells": [int(c) for c in negatives],
        "false_positive_cells": [int(c) for c in positives[~hit_pos]],
        "false_negative_cells": [int(c) for c in negatives[hit_neg]],
        "ik": {"seeds": int(ik_seeds), "max_iter": int(max_iter)},
        "ik_time_s": round(ik_time, 4),
        "ik_ms_per_pose": round(ik_time / len(cells) * 1e3, 3) if len(cells) else None,
        "pose_level": pose,
        "time_s": round(time.perf_counter() - t_start, 4),
    }


def _draw_negatives(
    rng: np.random.Generator,
    flat: np.ndarray,
    threshold: float,
    reach_positions: np.ndarray,
    n_orient: int,
    n_neg: int,
    k: int,
) -> np.ndarray:
    """k distinct flat indices drawn uniformly from the in-reach cells with value <= threshold."""
    if k <= 0:
        return np.zeros(0, dtype=np.int64)
    n_cand = len(reach_positions) * n_orient
    if n_neg <= k or n_neg < 0.01 * n_cand:
        # Rare negatives (or too few to choose from): enumerate them exactly.
        found = []
        orient = np.arange(n_orient)
        for lo in range(0, len(reach_positions), 1024):
            cells = (reach_positions[lo : lo + 1024, None] * n_orient + orient[None, :]).reshape(-1)
            found.append(cells[flat[cells] <= threshold])
        cells = np.concatenate(found)
        return np.sort(cells[rng.choice(cells.size, size=k, replace=False)])
    # Rejection sampling: uniform over in-reach cells, keep the unreachable ones, no repeats.
    chosen: dict[int, None] = {}
    while len(chosen) < k:
        m = 4 * (k - len(chosen)) * max(1, round(n_cand / n_neg))
        c = reach_positions[rng.integers(0, len(reach_positions), size=m)] * n_orient + rng.integers(
            0, n_orient, size=m
        )
        for cell in c[flat[c] <= threshold]:
            chosen.setdefault(int(cell))
            if len(chosen) == k:
                break
    return np.sort(np.fromiter(chosen, dtype=np.int64, count=k))
