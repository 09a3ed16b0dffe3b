"""Building a reachability map for one arm (the offline half of the product)."""

from __future__ import annotations

import datetime as _dt
import time

import numpy as np

from placement.errors import GridError, PlacementError
from placement.kernels.sampling import (
    completion_sources,
    configs_at,
    reduce_max,
    refined_config,
    refined_configs,
    sample_block,
)
from placement.kinematics.manipulability import INDEX_NAMES, ROTATION_SCALE
from placement.maps.buildspec import (
    DEFAULT_BINS,
    DEFAULT_RESOLUTION,
    INDEXES,
    MAX_SAMPLES,
    MAX_SEED,
    parse_choice,
    parse_count,
)
from placement.maps.grid import Grid
from placement.maps.selfcollision import ALPHA, BETA, SelfCollision
from placement.maps.witness import K, completion_id, empty_witnesses, witness_info
from placement.progress import EtaBar
from placement.robots import Robot, load_robot
from placement.storage.format import FORMAT_VERSION, BuiltMap
from placement.version import __version__

__all__ = ["DEFAULT_BINS", "BuiltMap", "arm_reach", "build_grid", "build_map", "default_grid", "sample_range"]


def arm_reach(robot: Robot, arm: str) -> tuple[np.ndarray, float]:
    """Centre (first joint origin, base frame) [m] and an upper bound of the reach [m].

    The bound is the sum of the distances between consecutive joint origins plus
    the TCP offset: no configuration can put the TCP farther from the centre.
    """
    chain = robot.arm(arm).chain
    centre = chain.link_T[0][:3, 3].copy()
    reach = sum(float(np.linalg.norm(T[:3, 3])) for T in chain.link_T[1:])
    reach += float(np.linalg.norm(chain.tip_T[:3, 3]))
    # prismatic joints extend the reach by their stroke
    a = robot.arm(arm)
    reach += float(np.sum((a.upper - a.lower) * (chain.kind == 1)))
    return centre, reach


def default_grid(robot: Robot, arm: str, resolution: float = DEFAULT_RESOLUTION, bins=DEFAULT_BINS) -> Grid:
    """The grid that covers every pose the arm can reach, at ``resolution`` [m]."""
    centre, reach = arm_reach(robot, arm)
    return Grid.around(centre, reach + resolution, resolution, tuple(bins))


def build_grid(robot: Robot, arm: str, resolution: float = DEFAULT_RESOLUTION, bins=DEFAULT_BINS) -> Grid:
    """The grid :func:`build_map` fills for ``arm``, after the checks it makes before sampling (cheap)."""
    a = robot.arm(arm)
    if a.dof < 6:
        raise PlacementError(f"arm '{arm}' has {a.dof} joints; the extended manipulability needs at least 6")
    return default_grid(robot, arm, resolution, bins)


def sample_range(
    robot: Robot,
    arm: str,
    grid: Grid,
    values: np.ndarray,
    witness: np.ndarray,
    *,
    seed: int,
    start: int,
    count: int,
    index: str,
    block: int = 1 << 19,
    on_block=None,
    self_collision: SelfCollision | None = None,
    self_distance: bool = False,
) -> int:
    """Fold samples ``start .. start+count-1`` of ``seed`` into ``values`` (flat float32, per-cell max)
    and ``witness`` (flat, the winning sample's number, see :mod:`placement.maps.witness`).

    The one sampling loop of both the local and the distributed build. Returns
    how many samples fell outside the grid (0 unless the reach bound is wrong).
    ``on_block(samples_done_in_range, values)`` is called after each block.
    With ``self_collision``, a sample that would raise its cell is dropped if
    the arm collides with the robot; samples that cannot raise their cell need
    no test, so the map is the maximum over collision-free samples exactly.
    With ``self_distance`` as well (the checker is then required), every
    sample gets its self-distance row penalties before it is evaluated.
    """
    if self_distance and self_collision is None:
        raise PlacementError("the self-distance penalty needs a SelfCollision checker (self_collision=...)")
    if self_distance:
        # ~1.6 ms of distance queries per sample: small blocks keep the progress bar moving
        # (the block size never changes the map)
        block = min(block, 1 << 12)
    block = int(max(1, min(block, count)))
    done = 0
    outside = 0
    while done < count:
        n = min(block, count - done)
        ids = np.arange(start + done, start + done + n, dtype=np.int64)
        outside += fold(robot, arm, grid, values, witness, seed, ids, None, index, self_collision, self_distance)
        done += n
        if on_block is not None:
            on_block(done, values)
    return outside


def fold(
    robot: Robot,
    arm: str,
    grid: Grid,
    values: np.ndarray,
    witness: np.ndarray,
    seed: int,
    ids: np.ndarray,
    configs: np.ndarray | None,
    index: str,
    self_collision: SelfCollision | None = None,
    self_distance: bool = False,
) -> int:
    """Evaluate one block of samples numbered ``ids`` (m,) (ascending, consecutive when ``configs`` is None:
    the counter-based samples) or of the given ``configs`` (m, n) [rad or m], and fold them into
    ``values``/``witness``. Returns how many fell outside the grid."""
    a = robot.arm(arm)
    ch = a.chain
    n = len(ids)
    given = np.zeros((0, a.dof)) if configs is None else np.ascontiguousarray(configs, dtype=float)
    cells = np.empty(n, dtype=np.int64)
    vals = np.empty(n, dtype=np.float64)
    rowfac = np.ones((0, 6, 2))
    if self_distance:
        q = configs_at(np.uint64(seed), ids, a.lower, a.upper) if configs is None else given
        rowfac = self_collision.row_factors(q)
    sample_block(
        np.uint64(seed),
        int(ids[0]) if n else 0,
        n,
        given,
        a.lower,
        a.upper,
        a.continuous.astype(np.bool_),
        ch.link_T,
        ch.axis,
        ch.kind,
        ch.tip_T,
        INDEX_NAMES.index(index),
        ROTATION_SCALE,
        grid.origin_array,
        grid.resolution,
        grid.shape_array,
        values,
        rowfac,
        cells,
        vals,
    )
    if self_collision is not None and not self_distance:  # (row_factors already rejected collisions)
        raising = np.flatnonzero((cells >= 0) & (vals.astype(np.float32) > values[np.maximum(cells, 0)]))
        if raising.size:
            q = configs_at(np.uint64(seed), ids[raising], a.lower, a.upper) if configs is None else given[raising]
            vals[raising[self_collision.collides(q)]] = -1.0
    reduce_max(values, witness, cells, vals, ids)
    return int(np.count_nonzero(cells < 0))


def complete(
    robot: Robot,
    arm: str,
    grid: Grid,
    values: np.ndarray,
    witness: np.ndarray,
    *,
    seed: int,
    plain: int,
    index: str,
    block: int = 1 << 18,
    self_collision: SelfCollision | None = None,
    self_distance: bool = False,
    on_block=None,
) -> int:
    """Map completion: every empty cell next to a reached one gets one more sample, a few DLS steps
    from the witness of its first reached face neighbour (with a plain-sample witness) towards its
    centre pose (see :func:`placement.kernels.sampling.completion_sources`, and
    :mod:`placement.maps.witness` for its number), folded in like any other.

    The candidates come from the map after sampling and are applied in increasing witness number,
    so the result does not depend on ``block``. Returns the number of candidates.
    """
    a = robot.arm(arm)
    ch = a.chain
    sources, dirs = completion_sources(values, witness, plain, grid.shape_array)
    ids = np.sort(completion_id(plain, sources, dirs))
    del sources, dirs
    for lo in range(0, len(ids), block):
        part = ids[lo : lo + block]
        c = part - plain
        q, ok = refined_configs(
            np.uint64(seed),
            c // K,
            c % K,
            a.lower,
            a.upper,
            a.continuous.astype(np.bool_),
            ch.link_T,
            ch.axis,
            ch.kind,
            ch.tip_T,
            grid.origin_array,
            grid.resolution,
            grid.shape_array,
        )
        fold(robot, arm, grid, values, witness, seed, part[ok], q[ok], index, self_collision, self_distance)
        if on_block is not None:
            on_block(lo + len(part), len(ids))
    return int(len(ids))


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
        ch.link_T,
        ch.axis,
        ch.kind,
        ch.tip_T,
        grid.origin_array,
        grid.resolution,
        grid.shape_array,
    )
    refined_configs(np.uint64(0), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), *args)
    # and the serial one of ReachabilityMap.witness_q, so that no query compiles on first use
    refined_config(np.uint64(0), 0, 0, *args, np.empty(a.dof))
    if self_collision is not None:
        configs_at(np.uint64(0), np.zeros(1, dtype=np.int64), a.lower, a.upper)


def _distributed(
    client, robot, arm, grid, values, witness, seed, samples, index, tasks, bar, self_collision, self_distance
) -> int:
    from dask.distributed import as_completed

    if tasks is None:
        threads = sum(client.nthreads().values()) or 1
        tasks = 4 * threads
    tasks = int(max(1, min(tasks, samples)))
    edges = np.linspace(0, samples, tasks + 1).astype(np.int64)
    preset = robot.source
    futures = {
        client.submit(
            _remote_range,
            preset,
            arm,
            grid.to_dict(),
            int(seed),
            int(lo),
            int(hi - lo),
            index,
            self_collision,
            self_distance,
            samples,
            pure=False,
        ): int(hi - lo)
        for lo, hi in zip(edges[:-1], edges[1:])
        if hi > lo
    }
    outside = 0
    for fut in as_completed(futures):
        idx, vals, wit, out = fut.result()
        # the witness tie rule makes the merge independent of the order the tasks finish in
        reduce_max(values, witness, idx, vals.astype(np.float64), wit.astype(np.int64))
        outside += out
        bar.update(futures[fut])
    return outside


def _remote_range(
    preset: str,
    arm: str,
    grid_dict: dict,
    seed: int,
    start: int,
    count: int,
    index: str,
    self_collision: bool = False,
    self_distance: bool = False,
    total: int = 0,
):
    """Dask task: a sub-range into a private grid, returned sparse (flat indices int64, values float32,
    witnesses)."""
    robot = load_robot(preset)
    grid = Grid.from_dict(grid_dict)
    values = np.zeros(grid.size, dtype=np.float32)
    witness = empty_witnesses(grid.size, total)
    checker = SelfCollision(robot, arm) if (self_collision or self_distance) else None
    outside = sample_range(
        robot,
        arm,
        grid,
        values,
        witness,
        seed=seed,
        start=start,
        count=count,
        index=index,
        self_collision=checker,
        self_distance=self_distance,
    )
    idx = np.flatnonzero(values)
    return idx, values[idx], witness[idx], outside


def build_map(
    robot: Robot,
    arm: str,
    *,
    samples: int,
    seed: int = 0,
    resolution: float = DEFAULT_RESOLUTION,
    bins=DEFAULT_BINS,
    index: str = "isotropy",
    block: int = 1 << 19,
    progress: bool = True,
    on_block=None,
    client=None,
    tasks: int | None = None,
    self_collision: bool = False,
    self_distance: bool = False,
    completion: bool = False,
) -> BuiltMap:
    """Sample ``samples`` configurations of ``arm`` and keep the best value per 6D cell, with its witness.

    Args:
        robot: the robot (see :func:`placement.load_robot`).
        arm: arm name.
        samples: number of uniform joint samples, 1 .. MAX_SAMPLES (1e11).
        seed: sampling seed, 0 .. 2^64 - 1; same seed and samples give a bitwise-identical map.
        resolution: position cell edge [m] (default 0.05, SPEC's 5 cm).
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
            face neighbours of reached cells (see :func:`complete`; runs locally with a client too).

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
    checker = SelfCollision(robot, arm) if (self_collision or self_distance) else None
    try:
        values = np.zeros(grid.size, dtype=np.float32)
        witness = empty_witnesses(grid.size, samples)
    except MemoryError:
        raise GridError(f"grid of {grid.size:.3g} cells does not fit in memory; use a coarser resolution") from None
    if client is None:
        compile_sampling(robot, arm, grid, index, checker, self_distance)
    t0 = time.perf_counter()
    with EtaBar(
        total=samples, desc=f"{robot.name}/{arm}", unit="sample", unit_scale=True, disable=not progress, leave=False
    ) as bar:
        if client is None:
            last = [0]

            def tick(done, vals):
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
            outside = _distributed(
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
    elapsed = time.perf_counter() - t0
    if outside:
        raise PlacementError(f"{outside} samples fell outside the grid: the reach bound is wrong")
    sampled = int(np.count_nonzero(values))
    t1 = time.perf_counter()
    candidates = 0
    if completion:
        if client is not None:
            compile_sampling(robot, arm, grid, index, checker, self_distance)
        with EtaBar(
            total=1,
            desc=f"{robot.name}/{arm} completion",
            unit="cell",
            unit_scale=True,
            disable=not progress,
            leave=False,
        ) as bar:

            def step(done, total):
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
        "measure": {
            "name": "extended_manipulability",
            "index": index,
            "rotation_scale": ROTATION_SCALE,
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
        "witness": witness_info(samples, completion),
    }
    if completion:
        meta["completion"] = {
            "candidates": candidates,
            "cells_before": sampled,
            "cells_added": filled - sampled,
            "time_s": round(completion_time, 3),
        }
    return BuiltMap(values, meta, witness)
