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

import numpy as np

from placement.errors import MapError, PlacementError
from placement.kinematics.ik import solve_ik
from placement.maps.build import arm_reach
from placement.maps.buildspec import MAX_SEED, parse_count
from placement.robots import Robot

_CHUNK = 1 << 24
MAX_CHECK_SAMPLES = 100_000  # IK checks per class; ~10 ms each


def _ratio(num: float, den: float) -> float | None:
    return float(num / den) if den > 0 else None


def check_map(
    robot: Robot,
    rmap,
    samples: int = 200,
    seed: int = 0,
    threshold: float = 0.0,
    *,
    ik_seeds: int = 8,
    max_iter: int = 200,
    pose_level: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Accuracy of ``rmap`` against IK on random cells it calls reachable and unreachable.

    Args:
        robot: the robot the map was built for.
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
    grid = rmap.grid
    values = rmap.values
    if values.shape != grid.shape:
        raise MapError(f"map values have shape {values.shape}, its grid says {grid.shape}")
    flat = values.reshape(-1)
    n_orient = int(np.prod(grid.shape[3:]))
    n_pos_cells = int(np.prod(grid.shape[:3]))

    centre, reach, in_reach = reach_sphere(robot, arm, grid)

    # One pass: positive cells (flat indices) and positives per position cell.
    pos_cells = []
    pos_per_position = np.zeros(n_pos_cells, dtype=np.int64)
    step = max(1, _CHUNK // n_orient) * n_orient
    for lo in range(0, flat.size, step):
        block = flat[lo : lo + step] > threshold
        pos_cells.append(np.flatnonzero(block) + lo)
        pos_per_position[lo // n_orient : lo // n_orient + block.size // n_orient] = block.reshape(-1, n_orient).sum(
            axis=1
        )
    pos_cells = np.concatenate(pos_cells) if pos_cells else np.zeros(0, dtype=np.int64)
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
    precision = _ratio(tp, tp + fp)
    npv = _ratio(tn, tn + fn)
    # Class-size weighted estimates over the population (map positives + in-reach map negatives).
    recall = specificity = acc_est = None
    if precision is not None and npv is not None:
        true_pos_pop = n_pos * precision  # map positives that IK reaches
        missed_pop = n_neg * (1.0 - npv)  # map negatives that IK reaches
        true_neg_pop = n_neg * npv
        false_pos_pop = n_pos * (1.0 - precision)
        recall = _ratio(true_pos_pop, true_pos_pop + missed_pop)
        specificity = _ratio(true_neg_pop, true_neg_pop + false_pos_pop)
        acc_est = _ratio(true_pos_pop + true_neg_pop, n_pos + n_neg)
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
        "accuracy": _ratio(tp + tn, len(cells)),
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


def reach_sphere(robot: Robot, arm: str, grid) -> tuple[np.ndarray, float, np.ndarray]:
    """(centre (3,) [m], reach bound [m], in_reach (nx*ny*nz,) bool): position cells whose centre lies
    in the arm's reach sphere (:func:`placement.maps.build.arm_reach`)."""
    centre, reach = arm_reach(robot, arm)
    axes = [grid.origin[i] + (np.arange(grid.shape[i]) + 0.5) * grid.resolution for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    in_reach = ((X - centre[0]) ** 2 + (Y - centre[1]) ** 2 + (Z - centre[2]) ** 2 <= reach**2).reshape(-1)
    return centre, reach, in_reach


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


def poses_in_cells(grid, cells: np.ndarray, rng: np.random.Generator) -> np.ndarray:
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
    rmap,
    samples: int = 200,
    seed: int = 0,
    threshold: float = 0.0,
    *,
    ik_seeds: int = 8,
    max_iter: int = 200,
    max_draws: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
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
        "precision": _ratio(hits, k),
        "precision_ci95": wilson(hits, k),
        "precision_poses": int(k),
        "precision_reached": int(hits),
        "witness_seeded": witness is not None and "witness" in meta,
        "recall": _ratio(marked, kept),
        "recall_ci95": wilson(marked, kept),
        "recall_cells": int(kept),
        "recall_marked": int(marked),
        "recall_draws": int(draws),
        "reachable_fraction_in_reach": _ratio(kept, draws),
        "time_s": round(time.perf_counter() - t0, 3),
    }
