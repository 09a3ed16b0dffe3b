"""Building a reachability map for one arm (the offline half of the product)."""

from __future__ import annotations

import datetime as _dt
import sys
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from placement.errors import GridError, PlacementError
from placement.kernels.sampling import configs_at, refined_config, refined_configs
from placement.kinematics.manipulability import ROTATION_SCALE, arm_rank
from placement.maps.buildspec import (
    DEFAULT_BINS,
    DEFAULT_RESOLUTION,
    INDEXES,
    MAX_SAMPLES,
    MAX_SEED,
    TorsoSpec,
    parse_choice,
    parse_count,
)
from placement.maps.completion import complete
from placement.maps.distributed import sample_distributed
from placement.maps.grid import Grid
from placement.maps.quantiles import value_quantiles
from placement.maps.reach import arm_reach, box_grid, reach_box
from placement.maps.sampling import sample_range
from placement.maps.selfcollision import ALPHA, BETA, SelfCollision
from placement.maps.torso import torso_settings
from placement.maps.witness import empty_witnesses, witness_info
from placement.progress import EtaBar
from placement.robots import Robot
from placement.storage.format import FORMAT_VERSION, BuiltMap
from placement.version import __version__

if TYPE_CHECKING:
    from dask.distributed import Client

__all__ = ["DEFAULT_BINS", "BuiltMap", "arm_reach", "build_grid", "build_map", "default_grid", "provable_grid"]


def default_grid(
    robot: Robot, arm: str, resolution: float = DEFAULT_RESOLUTION, bins: Sequence[int] = DEFAULT_BINS
) -> Grid:
    """The grid that covers every pose the arm reaches, at ``resolution`` [m]: the box of its TCP
    positions (:func:`placement.maps.reach.reach_box`) plus a margin of a cell and 5 % of the box."""
    lo, hi = reach_box(robot, arm)
    return box_grid(lo, hi, resolution, bins)


def provable_grid(
    robot: Robot, arm: str, resolution: float = DEFAULT_RESOLUTION, bins: Sequence[int] = DEFAULT_BINS
) -> Grid:
    """The cube around the arm's first joint that provably holds its reach (sum of link lengths and
    strokes, :func:`arm_reach`): the fallback when a sample falls outside :func:`default_grid`."""
    centre, reach = arm_reach(robot, arm)
    return Grid.around(centre, reach + resolution, resolution, tuple(bins))


def build_grid(
    robot: Robot, arm: str, resolution: float = DEFAULT_RESOLUTION, bins: Sequence[int] = DEFAULT_BINS
) -> Grid:
    """The grid :func:`build_map` fills for ``arm``, after the checks it makes before sampling (cheap)."""
    return default_grid(robot, arm, resolution, bins)


def compile_sampling(
    robot: Robot,
    arm: str,
    grid: Grid,
    index: str,
    self_collision: SelfCollision | None = None,
    self_distance: bool = False,
) -> None:
    """Compile the sampling kernels (a no-op once they are in numba's disk cache).

    Runs one sample into a four-cell scratch grid, which it cannot change, so that
    a first build compiles before its progress bar starts and the bar's rate and
    ETA measure sampling alone.
    """
    scratch = Grid(grid.origin, grid.resolution, (1, 1, 1, 2, 1, 2))
    values, witness = np.zeros(scratch.size, dtype=np.float32), empty_witnesses(scratch.size, 1)
    sample_range(
        robot,
        arm,
        scratch,
        values,
        witness,
        seed=0,
        start=0,
        count=1,
        index=index,
        self_collision=self_collision,
        self_distance=self_distance,
    )
    complete(
        robot,
        arm,
        scratch,
        values,
        witness,
        seed=0,
        plain=1,
        index=index,
        self_collision=self_collision,
        self_distance=self_distance,
    )
    a = robot.arm(arm)
    ch = a.chain
    # the completion kernel too (the scratch sample above rarely has a neighbour inside the scratch grid)
    args = (
        a.lower,
        a.upper,
        a.continuous.astype(np.bool_),
        *ch.arrays,
        grid.origin_array,
        grid.resolution,
        grid.shape_array,
    )
    refined_configs(np.uint64(0), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), *args)
    # and the serial one of ReachabilityMap.witness_q, so that no query compiles on first use
    refined_config(np.uint64(0), 0, 0, *args, np.empty(a.dof))
    if self_collision is not None:
        configs_at(np.uint64(0), np.zeros(1, dtype=np.int64), a.lower, a.upper)


def _sample_all(
    robot: Robot,
    arm: str,
    grid: Grid,
    samples: int,
    seed: int,
    index: str,
    block: int,
    progress: bool,
    on_block: Callable[[int, np.ndarray], object] | None,
    client: Client | None,
    tasks: int | None,
    checker: SelfCollision | None,
    self_collision: bool,
    self_distance: bool,
    label: str,
) -> tuple[np.ndarray, np.ndarray, int, float]:
    """The sampling pass of :func:`build_map` on ``grid``: (values, witness (flat), samples outside, time [s])."""
    try:
        values = np.zeros(grid.size, dtype=np.float32)
        witness = empty_witnesses(grid.size, samples)
    except MemoryError:
        raise GridError(f"grid of {grid.size:.3g} cells does not fit in memory; use a coarser resolution") from None
    t0 = time.perf_counter()
    with EtaBar(total=samples, desc=label, unit="sample", unit_scale=True, disable=not progress, leave=False) as bar:
        if client is None:
            last = [0]

            def tick(done: int, vals: np.ndarray) -> None:
                bar.update(done - last[0])
                last[0] = done
                if on_block is not None:
                    on_block(done, vals)

            outside = sample_range(
                robot,
                arm,
                grid,
                values,
                witness,
                seed=seed,
                start=0,
                count=samples,
                index=index,
                block=block,
                on_block=tick,
                self_collision=checker,
                self_distance=self_distance,
            )
        else:
            outside = sample_distributed(
                client,
                robot,
                arm,
                grid,
                values,
                witness,
                seed,
                samples,
                index,
                tasks,
                bar,
                self_collision,
                self_distance,
            )
    return values, witness, outside, time.perf_counter() - t0


def build_map(
    robot: Robot,
    arm: str,
    *,
    samples: int,
    seed: int = 0,
    resolution: float = DEFAULT_RESOLUTION,
    bins: Sequence[int] = DEFAULT_BINS,
    index: str = "isotropy",
    block: int = 1 << 19,
    progress: bool = True,
    on_block: Callable[[int, np.ndarray], object] | None = None,
    client: Client | None = None,
    tasks: int | None = None,
    self_collision: bool = False,
    self_distance: bool = False,
    completion: bool = False,
    torso: TorsoSpec | None = None,
    label: str | None = None,
) -> BuiltMap:
    """Sample ``samples`` configurations of ``arm`` and keep the best value per 6D cell, with its witness.

    Args:
        robot: the robot (see :func:`placement.load_robot`).
        arm: arm name.
        samples: number of uniform joint samples, 1 .. MAX_SAMPLES (1e11).
        seed: sampling seed, 0 .. 2^64 - 1; same seed and samples give a bitwise-identical map.
        resolution: position cell edge [m] (default 0.05, the paper's 5 cm).
        bins: orientation bin counts (n_yaw even, n_pitch odd, n_roll even).
        index: "isotropy" (Simox default) or "volume".
        block: samples per parallel block (memory vs. pruning freshness; does not change the result).
        progress: show a progress bar on stderr; its ETA (see :mod:`placement.progress`)
            appears once 5 % of the samples are done.
        on_block: optional ``f(samples_done, values_flat)`` called after each block
            (for convergence curves); must not modify the array. Local builds only.
        client: a ``dask.distributed.Client``; the sample range is split into
            ``tasks`` sub-ranges (default: 4 per worker thread), each worker runs the
            same kernel into a private grid (one dense grid per running task) and
            returns its reached cells; the maximum is merged here. The map is
            bitwise identical to the local build.
        self_collision: reject samples where the arm collides with the robot
            (see :mod:`placement.maps.selfcollision` for the geometry); much slower,
            since every sample that would raise its cell is tested.
        self_distance: also apply the self-distance penalty (implies
            self_collision; every sample needs a distance query: slow).
        completion: after sampling, one completion pass from the witnesses into the empty
            face neighbours of reached cells (see :func:`placement.maps.completion.complete`;
            runs locally with a client too).
        torso: lift settings the map also stands for (see :mod:`placement.maps.torso`): checked
            against the robot before sampling and recorded as ``meta["torso"]``; costs no samples. Only a
            prismatic lift (a shifted map): a joint that needs one build per setting (a revolute torso)
            is built by :func:`placement.maps.torso_builds.build_torso_maps`.
        label: the progress bar's name (default ``robot/arm``).

    The result's ``witness`` (flat-compatible 6D array, see :mod:`placement.maps.witness`) names the
    sample behind every cell's value; meta["witness"] says how to read it.
    """
    if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in (samples, seed)):
        raise PlacementError(f"samples and seed must be integers, got {samples!r} and {seed!r}")
    samples = parse_count(int(samples), "samples", 1, MAX_SAMPLES)
    seed = parse_count(int(seed), "seed", 0, MAX_SEED)
    parse_choice(index, "manipulability index", INDEXES)
    grid = build_grid(robot, arm, resolution, bins)
    a = robot.arm(arm)
    lift = None if torso is None else torso_settings(robot, arm, torso, self_collision=self_collision or self_distance)
    if lift is not None and lift.shift is None:
        raise PlacementError(
            f"torso.joint: '{lift.joint}' needs one build per setting ({len(lift.allowed)} builds); "
            "build it with placement.maps.torso_builds.build_torso_maps"
        )
    checker = SelfCollision(robot, arm) if (self_collision or self_distance) else None
    grid_bound = "sampled reach"
    if client is None:
        compile_sampling(robot, arm, grid, index, checker, self_distance)
    name = label or f"{robot.name}/{arm}"
    how = (samples, seed, index, block, progress, on_block, client, tasks, checker, self_collision, self_distance, name)
    values, witness, outside, elapsed = _sample_all(robot, arm, grid, *how)
    if outside:
        # the sampled box missed part of the reach (never seen: tests/test_grid_sizing.py): start again
        # on the cube the link lengths bound, which no sample can leave
        print(
            f"warning: {robot.name}/{arm}: {outside} samples fell outside the grid of the arm's sampled reach; "
            "building again on the link-length bound",
            file=sys.stderr,
        )
        grid, grid_bound = provable_grid(robot, arm, resolution, bins), "link lengths"
        values, witness, outside, again = _sample_all(robot, arm, grid, *how)
        elapsed += again
        if outside:
            raise PlacementError(f"{outside} samples fell outside the grid: the reach bound is wrong")
    sampled = int(np.count_nonzero(values))
    t1 = time.perf_counter()
    candidates = 0
    if completion:
        if client is not None:
            compile_sampling(robot, arm, grid, index, checker, self_distance)
        with EtaBar(
            total=1, desc=f"{name} completion", unit="cell", unit_scale=True, disable=not progress, leave=False
        ) as bar:

            def step(done: int, total: int) -> None:
                bar.total = total
                bar.update(done - bar.n)

            candidates = complete(
                robot,
                arm,
                grid,
                values,
                witness,
                seed=seed,
                plain=samples,
                index=index,
                self_collision=checker,
                self_distance=self_distance,
                on_block=step,
            )
    completion_time = time.perf_counter() - t1
    values = values.reshape(grid.shape)
    witness = witness.reshape(grid.shape)
    filled = int(np.count_nonzero(values))
    meta = {
        "format_version": FORMAT_VERSION,
        "robot": robot.name,
        "urdf_sha256": robot.urdf_sha256,
        "arm": arm,
        "base_frame": robot.base_frame,
        "tip_frame": a.tip_frame,
        "tcp_offset": a.tcp_offset.tolist(),
        "joints": list(a.joints),
        "fixed_joints": dict(robot.fixed_joints),
        "grid": grid.to_dict(),
        "grid_bound": grid_bound,
        "measure": {
            "name": "extended_manipulability",
            "index": index,
            "rotation_scale": ROTATION_SCALE,
            # the arm's generic rank: each octant's r largest singular values count (kernels/subspace.py)
            "rank": arm_rank(robot, arm),
            "joint_limit_penalty": True,
            "self_distance_penalty": (
                {
                    "form": "exp(-alpha d) d^-beta on translational rows towards the nearest body part",
                    "alpha_per_m": ALPHA,
                    "beta": BETA,
                }
                if self_distance
                else False
            ),
            "self_collision": checker is not None,
            "self_collision_geometry": checker.describe() if checker is not None else None,
            "cell_value": "max over samples in the cell; 0 = never reached",
        },
        "samples": int(samples),
        "seed": int(seed),
        "build_time_s": round(elapsed + completion_time, 3),
        "sampling_time_s": round(elapsed, 3),
        "samples_per_s": round(samples / elapsed, 1) if elapsed > 0 else None,
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "software": f"placement {__version__}",
        "filled_cells": filled,
        "max_value": float(values.max()),
        # the planner's threshold_quantile resolves against these (placement/maps/quantiles.py)
        "value_quantiles": value_quantiles(values),
        "witness": witness_info(samples, completion),
    }
    if lift is not None:
        meta["torso"] = lift.to_dict()
    if completion:
        meta["completion"] = {
            "candidates": candidates,
            "cells_before": sampled,
            "cells_added": filled - sampled,
            "time_s": round(completion_time, 3),
        }
    return BuiltMap(values, meta, witness)
