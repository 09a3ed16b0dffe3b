"""Map build throughput of the rank-deficient arms against the PR2's, per sample at the same resolution.

Builds ``--samples`` samples per arm at ``--resolution`` [m] (default 1 M at 0.1 m, the (20, 9, 20)
bins) for the PR2's right arm, the two rank-5 example robots (so_arm_base: 5 joints;
lift_telescope: a lift, a telescoping chain and a 3-joint wrist) and centauro's left arm (6 joints on a
torso above wheeled legs), ``--runs`` times each, and reports
the median sampling rate [samples/s] and its ratio to the PR2's. Then, on one thread, where a sample's
time goes: FK + Jacobian, and the measure kernel on the same arrays, exact (no threshold) and against
the cell values of the map just built (what a build's later samples see). Writes the table to
docs/bench/rank_build.md atomically (``--out`` another file).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from pathlib import Path

import numba
import numpy as np
from bench_kernels import machine, median_time
from bench_output import write_atomic
from numba import njit

import placement
from placement.kernels.grid import cell_indices
from placement.kernels.isotropy import W_ROWS, isotropy_batched
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.manipulability import joint_penalties
from placement.kernels.sampling import sample_configs
from placement.kernels.subspace_batched import subspace_isotropy_batched
from placement.kinematics.manipulability import ROTATION_SCALE, arm_rank
from placement.maps.build import build_map

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = (
    ("pr2", "pr2", "right"),
    ("so_arm_base", str(ROOT / "examples/robots/so_arm_base.yaml"), "arm"),
    ("lift_telescope", str(ROOT / "examples/robots/lift_telescope.yaml"), "arm"),
    ("centauro", str(ROOT / "examples/robots/centauro.yaml"), "left"),
)


@njit(cache=True)
def measure_all(Q, J, thr, lower, upper, cont, rank):
    """The build's isotropy kernel on every row (J rotation rows already scaled), threshold thr[i]."""
    n = Q.shape[1]
    plo, phi = np.empty(n), np.empty(n)
    P, G = np.empty((6, n, 2)), np.empty((6, 6, 2, 2))
    A, B = np.empty((6, 6)), np.empty((6, 6))
    Ag, Rg = np.empty((21, 64)), np.empty((21, 64))
    W, S, C = np.empty((W_ROWS, 64)), np.empty((2, 6, 6)), np.empty((21, 21))
    de, ones = np.empty((2, 6)), np.ones((6, 2))
    out = np.empty(Q.shape[0])
    for i in range(Q.shape[0]):
        joint_penalties(Q[i], lower, upper, cont, plo, phi)
        if rank < 6:
            out[i] = subspace_isotropy_batched(J[i], plo, phi, ones, rank, thr[i], P, G, Ag, Rg, W, A, B, S, C, de)
        else:
            out[i] = isotropy_batched(J[i], plo, phi, ones, thr[i], P, G, Ag, W, A, B, de)
    return out


def profile(robot, arm, built, resolution, m):
    """One-thread time per sample [us] of FK, binning, and the kernel exact / against the built map."""
    a = robot.arm(arm)
    ch = a.chain
    rank = arm_rank(robot, arm)
    grid = built.meta["grid"]
    origin = np.asarray(grid["origin"], dtype=float)
    shape = np.asarray(built.values.shape, dtype=np.int64)
    values = built.values.ravel()
    Q = sample_configs(np.uint64(12345), 0, m, a.lower, a.upper)
    fk_jacobian_batch(Q[:4], ch.link_T, ch.axis, ch.kind, ch.tip_T)
    t_fk = median_time(lambda: fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T))
    T, J = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
    cell_indices(T[:4], origin, resolution, shape)
    t_bin = median_time(lambda: cell_indices(T, origin, resolution, shape))
    cells = cell_indices(T, origin, resolution, shape)
    inside = cells >= 0
    Q, J, cells = Q[inside], J[inside], cells[inside]
    J[:, 3:] *= ROTATION_SCALE
    cont = a.continuous.astype(np.bool_)
    exact = np.full(len(Q), -1.0)
    thr = values[cells].astype(np.float64)
    measure_all(Q[:4], J[:4], exact[:4], a.lower, a.upper, cont, rank)
    k = min(len(Q), m // 4)  # the exact value of every sample is the slow part: a quarter of them
    t_exact = median_time(lambda: measure_all(Q[:k], J[:k], exact[:k], a.lower, a.upper, cont, rank))
    t_pruned = median_time(lambda: measure_all(Q, J, thr, a.lower, a.upper, cont, rank))
    kept = measure_all(Q, J, thr, a.lower, a.upper, cont, rank)
    return {
        "fk": t_fk / m * 1e6,
        "bin": t_bin / m * 1e6,
        "exact": t_exact / k * 1e6,
        "pruned": t_pruned / len(Q) * 1e6,
        "settled": float(np.mean(kept < 0.0)),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--samples", type=int, default=1_000_000, help="samples per build")
    ap.add_argument("--runs", type=int, default=3, help="builds per robot (the median rate is reported)")
    ap.add_argument("--resolution", type=float, default=0.1, help="position cell edge [m]")
    ap.add_argument("--profile", type=int, default=100_000, help="samples of the one-thread profile")
    ap.add_argument("--out", default=str(ROOT / "docs/bench/rank_build.md"))
    args = ap.parse_args(argv)
    rates, profiles, ranks, dofs = {}, {}, {}, {}
    for name, preset, arm in ROBOTS:
        robot = placement.load_robot(preset)
        ranks[name], dofs[name] = arm_rank(robot, arm), robot.arm(arm).dof
        runs, built = [], None
        for _ in range(args.runs):
            built = build_map(robot, arm, samples=args.samples, resolution=args.resolution, progress=False)
            runs.append(float(built.meta["samples_per_s"]))
        rates[name] = (statistics.median(runs), runs)
        with numba_threads(1):
            profiles[name] = profile(robot, arm, built, args.resolution, args.profile)
        print(name, rates[name], profiles[name], file=sys.stderr)
    base = rates["pr2"][0]
    lines = [
        f"Map build throughput per robot: {args.samples / 1e6:g} M samples of one arm at {args.resolution:g} m, "
        f"(20, 9, 20) bins, isotropy index, median of {args.runs} builds (`tools/bench_rank.py`). "
        "Ratio: the PR2's rate over the robot's (the requirement: at most 2).",
        "",
        "| robot / arm | dof | rank | samples/s (runs) | PR2 / robot |",
        "|---|---|---|---|---|",
    ]
    for name, _, arm in ROBOTS:
        med, runs = rates[name]
        each = ", ".join(f"{r / 1e3:.0f}" for r in runs)
        lines.append(
            f"| {name} / {arm} | {dofs[name]} | {ranks[name]} | {med / 1e3:.0f} k ({each} k) | {base / med:.2f}x |"
        )
    lines += [
        "",
        f"Where a sample's time goes, one thread, {args.profile // 1000} k samples [us per sample]: FK + Jacobian; "
        "binning the pose; the measure kernel exact (no threshold); the kernel against the cell values of the "
        "map just built (what most of a build's samples see), and the share of those samples it settles "
        "as unable to raise their cell.",
        "",
        "| robot | FK + J | binning | kernel, exact | kernel, vs built map | settled |",
        "|---|---|---|---|---|---|",
    ]
    for name, _, _ in ROBOTS:
        p = profiles[name]
        lines.append(
            f"| {name} | {p['fk']:.2f} | {p['bin']:.3f} | {p['exact']:.1f} | {p['pruned']:.2f} | "
            f"{100 * p['settled']:.0f} % |"
        )
    lines += ["", f"Machine: {machine()}; load average at the end {os.getloadavg()[0]:.2f}.", ""]
    text = "\n".join(lines)
    print(text)
    write_atomic(Path(args.out), text)


class numba_threads:
    """Run a block with ``n`` numba threads (the profile is one-thread)."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __enter__(self) -> None:
        self.old = numba.get_num_threads()
        numba.set_num_threads(self.n)

    def __exit__(self, *exc: object) -> None:
        numba.set_num_threads(self.old)


if __name__ == "__main__":
    main()
