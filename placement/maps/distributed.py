"""A map build's sampling on a Dask cluster: the sample range split into tasks, each sampled into a
private grid on a worker, the reached cells merged here (bitwise equal to the local build)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from placement.kernels.sampling import reduce_max
from placement.maps.grid import Grid
from placement.maps.sampling import sample_range
from placement.maps.selfcollision import SelfCollision
from placement.maps.witness import empty_witnesses
from placement.process_env import configure_process
from placement.robots import Robot, load_robot

if TYPE_CHECKING:
    from dask.distributed import Client, Future

    from placement.progress import EtaBar

#: What a task returns: reached cells (flat indices), their values and witnesses, samples outside the grid.
_Part = tuple[npt.NDArray[np.intp], npt.NDArray[np.float32], np.ndarray, int]


def sample_distributed(
    client: Client,
    robot: Robot,
    arm: str,
    grid: Grid,
    values: npt.NDArray[np.float32],
    witness: np.ndarray,
    seed: int,
    samples: int,
    index: str,
    tasks: int | None,
    bar: EtaBar,
    self_collision: bool,
    self_distance: bool,
) -> int:
    """Sample ``samples`` samples of ``seed`` on the cluster into ``values`` and ``witness`` (flat, see
    :func:`placement.maps.sampling.sample_range`) in ``tasks`` tasks (default 4 per worker thread),
    advancing ``bar`` as each finishes; returns how many fell outside the grid."""
    from dask.distributed import as_completed

    if tasks is None:
        # (dask.distributed leaves Client.nthreads unannotated: {worker address: threads})
        nthreads = cast("Callable[[], dict[str, int]]", client.nthreads)
        threads = sum(nthreads().values()) or 1
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
    # (and as_completed: it yields the futures as they finish)
    completed = cast("Callable[[Iterable[Future[_Part]]], Iterator[Future[_Part]]]", as_completed)
    for fut in completed(futures):
        idx, vals, wit, out = fut.result()
        # the witness tie rule makes the merge independent of the order the tasks finish in
        reduce_max(values, witness, idx, vals.astype(np.float64), wit.astype(np.int64))
        outside += out
        bar.update(futures[fut])
    return outside


def _remote_range(
    preset: str,
    arm: str,
    grid_dict: dict[str, Any],
    seed: int,
    start: int,
    count: int,
    index: str,
    self_collision: bool = False,
    self_distance: bool = False,
    total: int = 0,
) -> _Part:
    """Dask task: a sub-range into a private grid, returned sparse (flat indices int64, values float32,
    witnesses)."""
    configure_process()  # a worker is a process of its own: its kernels wait passively too
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
