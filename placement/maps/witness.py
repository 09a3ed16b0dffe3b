"""Map witnesses: which sample set each cell's value, and the configuration it stands for.

Every reached cell of a map stores one integer ``w`` (the cell's *witness*):

* ``w < plain`` (``plain`` = the build's sample count): counter-based sample
  number ``w`` of the build seed (:func:`placement.kernels.sampling.configs_at`).
* ``plain <= w < plain * (1 + K)`` (K = 12 face neighbours of a 6D cell): a
  completion sample, ``c = w - plain``: a few damped least-squares steps from
  sample ``c // K`` towards the centre of the ``c % K``-th face neighbour of
  that sample's cell (:func:`placement.kernels.sampling.refined_configs`).
* the dtype's largest value: the cell was never reached (value 0).

So a witness is a pure function of the build seed, the arm's chain and the
grid: :func:`witness_configs` regenerates the joint configuration, and
``placement maps verify`` recomputes every stored value from it, bitwise.
Among samples of equal value the smallest number wins (plain samples before
completion samples).

Storage: dense, chunked and CRC-checked like the values. uint32 while every
number fits (``plain * (1 + K) < 2^32 - 1``, e.g. up to 330 M samples per arm;
4 bytes per cell: 1.3 GB at 5 cm for the PR2 arm's 328 M cells), else int64.
Compressed, the empty cells (most of the grid) cost almost nothing on disk.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np
import numpy.typing as npt

from placement.errors import MapError
from placement.kernels.sampling import NEIGHBOURS, configs_at, refined_config, refined_configs

if TYPE_CHECKING:
    from placement.maps.grid import Grid
    from placement.robots.preset import Arm, Robot

K = int(NEIGHBOURS.shape[0])


class WitnessedMap(Protocol):
    """What :func:`verify_witnesses` reads of a map: a ReachabilityMap or a BuiltMap."""

    @property
    def meta(self) -> dict[str, Any]: ...
    @property
    def grid(self) -> Grid: ...
    @property
    def values(self) -> np.ndarray: ...
    @property
    def witness(self) -> np.ndarray | None: ...


UINT32_LIMIT = 2**32 - 1


def witness_dtype(plain: int) -> np.dtype[np.uint32 | np.int64]:
    """The smallest witness dtype for a build of ``plain`` samples (uint32 or int64)."""
    return np.dtype(np.uint32) if plain * (1 + K) < UINT32_LIMIT else np.dtype(np.int64)


def empty_value(dtype: npt.DTypeLike) -> int:
    """The witness of a never-reached cell: the largest value of ``dtype`` (loses every tie)."""
    return int(np.iinfo(np.dtype(dtype)).max)


def empty_witnesses(size: int, plain: int) -> npt.NDArray[np.uint32 | np.int64]:
    """A flat witness array (size,) of never-reached cells for a build of ``plain`` samples."""
    dt = witness_dtype(plain)
    return np.full(size, empty_value(dt), dtype=dt)


def completion_id(plain: int, source: npt.ArrayLike, direction: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Witness numbers (m,) int64 of completion samples from sample ``source`` along neighbour ``direction``."""
    return plain + np.asarray(source, dtype=np.int64) * K + np.asarray(direction, dtype=np.int64)


def witness_info(plain: int, completion: bool) -> dict[str, Any]:
    """The ``witness`` entry of an arm's metadata (how to read the witness array)."""
    dt = witness_dtype(plain)
    return {
        "dtype": dt.name,
        "empty": empty_value(dt),
        "plain_samples": int(plain),
        "numbering": "w < plain_samples: sample w of the seed; else completion sample "
        f"c = w - plain_samples from sample c // {K} towards face neighbour c % {K}",
        "completion": bool(completion),
        "ties": "smallest witness among equal values",
    }


def plain_samples(meta: dict[str, Any]) -> int:
    """The build's sample count from an arm's metadata (MapError if the witness entry is malformed)."""
    try:
        return int(meta["witness"]["plain_samples"])
    except (KeyError, TypeError, ValueError):
        raise MapError(f"map of arm '{meta.get('arm')}' has no readable witness metadata; rebuild it") from None


def witness_configs(arm: Arm, grid: Grid, seed: int, plain: int, witnesses: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Joint configurations (m, n) [rad or m] of witnesses (m,) of a map of ``arm`` (a robot's Arm).

    Raises MapError for a witness that is empty or out of the numbering.
    """
    w = np.asarray(witnesses).astype(np.int64, copy=False).reshape(-1)
    if w.size == 1 and 0 <= w[0] < plain * (1 + K):
        return one_witness_config(arm, grid, seed, plain, int(w[0]))[None]
    if w.size and (w.min() < 0 or w.max() >= plain * (1 + K)):
        raise MapError(
            f"witness {int(w.max()) if w.max() >= plain * (1 + K) else int(w.min())} is outside the "
            f"numbering of a {plain}-sample build (empty cell or corrupt witness)"
        )
    ch = arm.chain
    out = np.empty((w.size, arm.dof))
    is_plain = w < plain
    seed64 = np.uint64(seed)
    if is_plain.any():
        out[is_plain] = configs_at(seed64, np.ascontiguousarray(w[is_plain]), arm.lower, arm.upper)
    if not is_plain.all():
        c = w[~is_plain] - plain
        q, _ = refined_configs(
            seed64,
            c // K,
            c % K,
            arm.lower,
            arm.upper,
            arm.continuous.astype(np.bool_),
            *ch.arrays,
            grid.origin_array,
            grid.resolution,
            grid.shape_array,
        )
        out[~is_plain] = q
    return out


def one_witness_config(arm: Arm, grid: Grid, seed: int, plain: int, w: int) -> npt.NDArray[np.float64]:
    """The configuration (n,) [rad or m] of one valid witness ``w`` (no checks, serial: microseconds)."""
    lo, hi = arm.lower, arm.upper
    if w < plain:
        return cast("npt.NDArray[np.float64]", configs_at(np.uint64(seed), np.array([w], dtype=np.int64), lo, hi)[0])
    c = w - plain
    ch = arm.chain
    out = np.empty(arm.dof)
    refined_config(
        np.uint64(seed),
        c // K,
        c % K,
        lo,
        hi,
        arm.continuous.astype(np.bool_),
        *ch.arrays,
        grid.origin_array,
        grid.resolution,
        grid.shape_array,
        out,
    )
    return out


def verify_witnesses(
    robot: Robot,
    rmap: WitnessedMap,
    sample: int | None = None,
    seed: int = 0,
    block: int = 1 << 16,
    progress: Callable[[int, int], object] | None = None,
) -> dict[str, Any]:
    """Recompute stored values from their witnesses and compare them bitwise.

    Args:
        robot: the robot the map was built for; rmap: a ReachabilityMap or BuiltMap with witnesses.
        sample: check this many reached cells drawn uniformly (without replacement) with ``seed``;
            None: every reached cell (about 1-3 us per cell on 2 cores).
        progress: optional ``progress(done, total)`` after each block.

    Returns a JSON-serialisable dict: ``arm``, ``cells_checked``, ``mismatches`` (cells whose
    recomputed cell or float32 value differs, plus cells whose witness and value disagree on
    being empty), ``first`` (up to 5 of them: cell, witness, stored, recomputed), ``time_s``.
    """
    from placement.kernels.sampling import sample_block
    from placement.kinematics.manipulability import INDEX_NAMES
    from placement.maps.selfcollision import SelfCollision

    t0 = time.perf_counter()
    meta = rmap.meta
    arm_name = meta["arm"]
    a = robot.arm(arm_name)
    grid = rmap.grid
    plain = plain_samples(meta)
    empty = empty_value(meta["witness"]["dtype"])
    values = rmap.values.reshape(-1)
    if rmap.witness is None:
        raise MapError(f"the map of arm '{arm_name}' has no witnesses to verify (a convergence snapshot)")
    wit = rmap.witness.reshape(-1)
    first: list[dict[str, Any]] = []
    reached = np.flatnonzero(values > 0)
    # a reached cell without a witness, or a witness on an empty cell
    odd = np.flatnonzero((values > 0) == (wit == empty))
    mismatches = int(odd.size)
    first += [{"cell": int(c), "witness": int(wit[c]), "stored": float(values[c]), "recomputed": None} for c in odd[:5]]
    cells = reached[wit[reached] != empty]
    if sample is not None and sample < cells.size:
        cells = np.sort(np.random.default_rng(seed).choice(cells, size=int(sample), replace=False))
    measure = meta["measure"]
    index = INDEX_NAMES.index(measure["index"])
    checker = SelfCollision(robot, arm_name) if measure.get("self_distance_penalty") else None
    ch = a.chain
    no_prune = np.zeros(0, dtype=np.float32)
    for lo in range(0, cells.size, block):
        part = cells[lo : lo + block]
        q = witness_configs(a, grid, int(meta["seed"]), plain, wit[part])
        rowfac = checker.row_factors(q) if checker is not None else np.ones((0, 6, 2))
        got_cell = np.empty(part.size, dtype=np.int64)
        got = np.empty(part.size)
        sample_block(
            np.uint64(meta["seed"]),
            0,
            part.size,
            q,
            a.lower,
            a.upper,
            a.continuous.astype(np.bool_),
            *ch.arrays,
            index,
            float(measure["rotation_scale"]),
            grid.origin_array,
            grid.resolution,
            grid.shape_array,
            no_prune,
            rowfac,
            got_cell,
            got,
            int(measure.get("rank", 6)),  # the rank the map was built with (maps without it: rank 6)
        )
        got32 = got.astype(np.float32)
        bad = np.flatnonzero((got_cell != part) | (got32.view(np.uint32) != values[part].view(np.uint32)))
        mismatches += int(bad.size)
        first += [
            {
                "cell": int(part[b]),
                "witness": int(wit[part[b]]),
                "stored": float(values[part[b]]),
                "recomputed": float(got32[b]) if got_cell[b] == part[b] else f"lands in cell {int(got_cell[b])}",
            }
            for b in bad[: max(0, 5 - len(first))]
        ]
        if progress is not None:
            progress(lo + part.size, cells.size)
    return {
        "arm": arm_name,
        "cells_reached": int(reached.size),
        "cells_checked": int(cells.size),
        "mismatches": mismatches,
        "first": first[:5],
        "time_s": round(time.perf_counter() - t0, 3),
    }
