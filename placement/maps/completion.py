"""Map completion: after sampling, one more sample for every empty cell next to a reached one, refined
from its neighbour's witness towards the cell's centre pose."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from placement.kernels.sampling import completion_sources, refined_configs
from placement.maps.grid import Grid
from placement.maps.sampling import fold
from placement.maps.selfcollision import SelfCollision
from placement.maps.witness import K, completion_id
from placement.robots import Robot


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
    on_block: Callable[[int, int], object] | None = None,
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
            *ch.arrays,
            grid.origin_array,
            grid.resolution,
            grid.shape_array,
        )
        fold(robot, arm, grid, values, witness, seed, part[ok], q[ok], index, self_collision, self_distance)
        if on_block is not None:
            on_block(lo + len(part), len(ids))
    return int(len(ids))
