"""The sampling loop of a map build: counter-based joint samples of one arm, evaluated and folded into
the per-cell maximum with their witnesses (one loop for the local and the distributed build)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from placement.errors import PlacementError
from placement.kernels.sampling import configs_at, reduce_max, sample_block
from placement.kinematics.manipulability import INDEX_NAMES, ROTATION_SCALE, arm_rank
from placement.maps.grid import Grid
from placement.maps.selfcollision import SelfCollision
from placement.robots import Robot

NEEDS_CHECKER = "the self-distance penalty needs a SelfCollision checker (self_collision=...)"


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
    on_block: Callable[[int, np.ndarray], object] | None = None,
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
        raise PlacementError(NEEDS_CHECKER)
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
        if self_collision is None:
            raise PlacementError(NEEDS_CHECKER)
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
        *ch.arrays,
        INDEX_NAMES.index(index),
        ROTATION_SCALE,
        grid.origin_array,
        grid.resolution,
        grid.shape_array,
        values,
        rowfac,
        cells,
        vals,
        arm_rank(robot, arm),
    )
    if self_collision is not None and not self_distance:  # (row_factors already rejected collisions)
        raising = np.flatnonzero((cells >= 0) & (vals.astype(np.float32) > values[np.maximum(cells, 0)]))
        if raising.size:
            q = configs_at(np.uint64(seed), ids[raising], a.lower, a.upper) if configs is None else given[raising]
            vals[raising[self_collision.collides(q)]] = -1.0
    reduce_max(values, witness, cells, vals, ids)
    return int(np.count_nonzero(cells < 0))
