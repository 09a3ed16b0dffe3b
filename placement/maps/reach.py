"""How far an arm reaches: the box of TCP positions that sizes a map's grid, and the provable sphere.

The grid of a map covers the box of the TCP positions the arm reaches (:func:`reach_box`), found
by forward kinematics of :data:`REACH_SAMPLES` counter-based configurations and, along each of
the six axis directions, a projected gradient ascent from the :data:`CLIMB_STARTS` most extreme
of them, so the box is the reachable set's own bounding box up to the ascent's tolerance (about a
millimetre; ``tests/test_grid_sizing.py`` finds no TCP of a million samples outside it). The
grid adds :func:`grid_margin` on every side: one cell, so that a TCP on a face of the box never
rounds out of the grid, and 5 % of the extent, for an ascent that stopped at a local maximum short
of the true extreme (none did on the PR2 or the telescoping test arm). A sum of link lengths (:func:`arm_reach`, a provable
bound) is far looser: a 2.6 m cube for an arm that telescopes 1.5 m forward and stays within a
few centimetres sideways. If a build ever finds a sample outside the box, it starts again on the
provable cube (see :func:`placement.maps.build.build_map`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from placement.errors import GridError
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.sampling import sample_configs
from placement.maps.grid import Grid
from placement.robots import Robot

__all__ = ["CLIMB_STARTS", "REACH_SAMPLES", "arm_reach", "box_grid", "grid_margin", "reach_box"]

#: Configurations whose TCP positions span the box.
REACH_SAMPLES = 4096
#: Sampling seed of the box (fixed: the grid is a property of the arm and resolution, not of a build).
REACH_SEED = np.uint64(0x8EAC)
#: Ascents per axis direction, from the most extreme samples.
CLIMB_STARTS = 8
#: Ascent steps, first joint step [rad or m], and the step below which an ascent stops.
CLIMB_STEPS, CLIMB_STEP, CLIMB_MIN_STEP = 200, 0.2, 1e-5
#: Margin of the grid around the box: this many cells plus this fraction of the box's extent.
MARGIN_CELLS, MARGIN_FRACTION = 1, 0.05
#: Largest grid [cells] (as :meth:`Grid.around`).
MAX_CELLS = 4_000_000_000


def arm_reach(robot: Robot, arm: str) -> tuple[np.ndarray, float]:
    """Centre (first joint origin, base frame) [m] and an upper bound of the reach [m].

    The bound is the sum of the distances between consecutive joint origins plus
    the TCP offset and the strokes of prismatic joints: no configuration can put
    the TCP farther from the centre.
    """
    a = robot.arm(arm)
    chain = a.chain
    centre = chain.link_T[0][:3, 3].copy()
    reach = sum(float(np.linalg.norm(T[:3, 3])) for T in chain.link_T[1:])
    reach += float(np.linalg.norm(chain.tip_T[:3, 3]))
    reach += float(np.sum((a.upper - a.lower) * (chain.kind == 1)))
    return centre, reach


def _positions(robot: Robot, arm: str, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """TCP positions (N, 3) [m] and their translational Jacobians in the base frame (N, 3, n)."""
    ch = robot.arm(arm).chain
    T, J = fk_jacobian_batch(np.ascontiguousarray(Q), *ch.arrays)
    # the kernel's Jacobian is in the TCP frame: v_base = R v_tcp
    return T[:, :3, 3], np.einsum("nij,njk->nik", T[:, :3, :3], J[:, :3])


def _climb(robot: Robot, arm: str, Q: np.ndarray, axes: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """TCP positions (N, 3) [m] after a projected gradient ascent of ``signs * p[axes]`` from Q (N, n)
    within the joint limits; every step is kept only if it raises its objective, else halved."""
    a = robot.arm(arm)
    rows = np.arange(len(Q))
    q = np.clip(Q, a.lower, a.upper)
    p, Jt = _positions(robot, arm, q)
    f = signs * p[rows, axes]
    step = np.full(len(Q), CLIMB_STEP)
    for _ in range(CLIMB_STEPS):
        g = signs[:, None] * Jt[rows, axes]  # (N, n): d objective / d q
        # no push through a limit the joint is at
        g[((q >= a.upper) & (g > 0)) | ((q <= a.lower) & (g < 0))] = 0.0
        norm = np.linalg.norm(g, axis=1)
        moving = (norm > 0) & (step > CLIMB_MIN_STEP)
        if not moving.any():
            break
        trial = np.clip(q + (step / np.maximum(norm, 1e-300))[:, None] * g, a.lower, a.upper)
        tp, tJ = _positions(robot, arm, trial)
        tf = signs * tp[rows, axes]
        better = moving & (tf > f)
        q[better], p[better], Jt[better], f[better] = trial[better], tp[better], tJ[better], tf[better]
        step = np.where(better, step * 1.5, step * 0.5)
    return p


def reach_box(robot: Robot, arm: str) -> tuple[np.ndarray, np.ndarray]:
    """(lo (3,), hi (3,)) [m]: the bounding box of the TCP positions ``arm`` reaches, in the base frame.

    From :data:`REACH_SAMPLES` samples and :data:`CLIMB_STARTS` ascents per axis direction (see the
    module docstring); the same box every time (fixed seed), about 50 ms.
    """
    a = robot.arm(arm)
    Q = sample_configs(REACH_SEED, 0, REACH_SAMPLES, a.lower, a.upper)
    p, _ = _positions(robot, arm, Q)
    starts, axes, signs = [], [], []
    k = min(CLIMB_STARTS, len(Q))
    for axis in range(3):
        for sign in (-1.0, 1.0):
            best = np.argsort(-sign * p[:, axis], kind="stable")[:k]
            starts.append(best)
            axes += [axis] * k
            signs += [sign] * k
    climbed = _climb(robot, arm, Q[np.concatenate(starts)], np.array(axes), np.array(signs))
    return np.minimum(p.min(axis=0), climbed.min(axis=0)), np.maximum(p.max(axis=0), climbed.max(axis=0))


def grid_margin(lo: np.ndarray, hi: np.ndarray, resolution: float) -> np.ndarray:
    """The margin (3,) [m] a grid adds on each side of the box lo .. hi: a cell plus 5 % of its extent."""
    return cast(np.ndarray, MARGIN_CELLS * resolution + MARGIN_FRACTION * (np.asarray(hi) - np.asarray(lo)))


def box_grid(lo: np.ndarray, hi: np.ndarray, resolution: float, bins: Sequence[int]) -> Grid:
    """The grid over the box lo .. hi (3,) [m] plus :func:`grid_margin`, its corners on multiples of
    ``resolution`` [m]."""
    if not (resolution > 0 and np.isfinite(resolution)):
        raise GridError(f"resolution must be a positive length in metres, got {resolution}")
    margin = grid_margin(lo, hi, resolution)
    start = np.floor((np.asarray(lo) - margin) / resolution) * resolution
    end = np.ceil((np.asarray(hi) + margin) / resolution) * resolution
    n = np.maximum(np.round((end - start) / resolution).astype(int), 1)
    cells = int(np.prod(n)) * int(np.prod(bins))
    if cells > MAX_CELLS:
        raise GridError(f"grid of {cells:.3g} cells at resolution {resolution} m is too large")
    x, y, z = (float(v) for v in start)
    return Grid((x, y, z), float(resolution), tuple(int(v) for v in (*n, *bins)))
