"""A map build's sampling on a Dask cluster: the sample range split into tasks, each sampled into a
private grid on a worker, the reached cells merged here (bitwise equal to the local build)."""

from __future__ import annotations

import numpy as np

from placement.kernels.sampling import reduce_max
from placement.maps.grid import Grid
from placement.maps.sampling import sample_range
from placement.maps.selfcollision import SelfCollision
from placement.maps.witness import empty_witnesses
from placement.robots import load_robot


def sample_distributed(
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
