"""`make bench`: kernel and end-to-end speed, map quality; prints a Markdown table.

Every timing is the median of several runs on this machine; ratios compare
against baselines measured in the same run. Writes the table to docs/bench/map_build.md (which
docs/benchmarks.md includes), its data to docs/bench/map_build.json and the convergence figure to
docs/bench/convergence.png, each atomically (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from bench_kernels import kernel_rows, machine, median_time
from bench_output import write_atomic, write_file_atomic

import placement
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.sampling import sample_configs
from placement.maps.accuracy import pose_metrics
from placement.maps.build import default_grid

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--samples", type=int, default=None, help="end-to-end build samples (default: the spec's)")
    ap.add_argument(
        "--runs",
        type=int,
        default=2,
        help="end-to-end builds of one arm (the median is reported; the full build adds one per arm)",
    )
    ap.add_argument("--spec", default=str(ROOT / "maps/pr2.yaml"))
    ap.add_argument("--out", default=str(ROOT / "docs/bench"), help="folder of map_build.md, .json, convergence.png")
    ap.add_argument(
        "--check", type=int, default=150, help="IK checks per class (cell level) and per metric (pose level)"
    )
    ap.add_argument("--arm", default="right")
    ap.add_argument("--no-full", action="store_true", help="skip the build of every arm of the spec")
    args = ap.parse_args(argv)
    import yaml

    spec = yaml.safe_load(Path(args.spec).read_text())
    robot = placement.load_robot(spec["robot"])
    arm = args.arm
    a = robot.arm(arm)
    ch = a.chain
    rows = []

    # first, while this process is small: a child's peak RSS counts what it shares with its parent at fork
    full = None if args.no_full else full_build(args.spec, spec, robot)

    rows += kernel_rows(a)

    # --- end-to-end: the default build of one arm (maps/pr2.yaml), with convergence ----
    bins = tuple(spec.get("bins", (20, 9, 20)))
    res = float(spec.get("resolution", 0.05))
    samples = int(args.samples or spec["samples"])
    grid = default_grid(robot, arm, res, bins)
    checkpoints = sorted(
        {c for c in (5_000_000, 10_000_000, 25_000_000, 50_000_000, 100_000_000) if c < samples} | {samples}
    )
    completion = bool(spec.get("completion", False))
    curve, snapshots, rates, totals, peaks = [], [], [], [], []
    t_start = [0.0]
    for run in range(args.runs):

        def on_block(done, v, first=(run == 0)):
            if first:
                if not curve:
                    t_start[0] = time.perf_counter()
                curve.append((done, int(np.count_nonzero(v)), time.perf_counter() - t_start[0]))
                if len(snapshots) < len(checkpoints) and done >= checkpoints[len(snapshots)]:
                    snapshots.append((done, v.copy(), time.perf_counter() - t_start[0]))

        built = placement.build_map(
            robot,
            arm,
            samples=samples,
            seed=int(spec.get("seed", 0)),
            resolution=res,
            bins=bins,
            progress=False,
            on_block=on_block,
            completion=completion,
        )
        rates.append(built.meta["samples_per_s"])
        totals.append(built.meta["build_time_s"])
        peaks.append(peak_rss_gib())
        print(
            f"build run {run + 1}/{args.runs}: {built.meta['build_time_s']:.1f} s, "
            f"{built.meta['samples_per_s'] / 1e3:.0f} k samples/s",
            file=sys.stderr,
        )
    rate = statistics.median(rates)
    rows.append(
        (
            f"end-to-end default build of one arm: {samples / 1e6:.0f} M samples, {grid.shape} grid, "
            f"{numba.get_num_threads()} threads (median of {args.runs})",
            f"{rate / 1e3:.0f} k samples/s",
            f"{samples / rate:.1f} s; runs {', '.join(f'{r / 1e3:.0f}' for r in rates)} k/s",
        )
    )
    if completion:
        c = built.meta["completion"]
        rows.append(
            (
                "completion from witnesses (after sampling)",
                f"+{c['cells_added']} cells",
                f"{c['time_s']:.1f} s for {c['candidates'] / 1e6:.1f} M candidates; "
                f"{c['cells_before']} -> {built.meta['filled_cells']} cells",
            )
        )
    rows.append(
        (
            "whole build of one arm (sampling + completion), peak memory of this process",
            f"{statistics.median(totals):.0f} s",
            f"{max(peaks):.2f} GiB peak RSS",
        )
    )
    if full is not None:
        rows.append(full)

    tmp = Path(tempfile.mkdtemp())
    try:
        for fmt in ("zarr", "hdf5"):
            path = tmp / ("map" + (".h5" if fmt == "hdf5" else ""))
            t = time.perf_counter()
            placement.save_maps(path, robot, {arm: built}, fmt)
            t_save = time.perf_counter() - t
            size = sum(f.stat().st_size for f in path.rglob("*")) if path.is_dir() else path.stat().st_size
            Qq = sample_configs(np.uint64(7), 0, 100_000, a.lower, a.upper)
            poses, _ = fk_jacobian_batch(Qq, ch.link_T, ch.axis, ch.kind, ch.tip_T)

            def query(path=path, arm=arm, poses=poses):
                rm = placement.open_map(path, arm, robot)
                return rm.value(poses)

            query()
            t_q = median_time(query, 3)
            rows.append(
                (
                    f"{fmt}: write / size / open + 1e5 value() queries",
                    f"{t_save:.1f} s / {size / 1e6:.1f} MB",
                    f"{t_q * 1e3:.0f} ms",
                )
            )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    # --- quality against IK, final map and along the way ------------------
    chk = placement.check_map(robot, built, samples=args.check, seed=0)
    pose = chk["pose_level"]

    def pct(x, ci):
        return f"{100 * (x or 0):.1f} % (95 % CI {100 * ci[0]:.0f}-{100 * ci[1]:.0f} %)" if ci else "n/a"

    rows.append(
        (
            "pose-level precision: uniform poses in reachable cells, IK to 1 cm / 0.05 rad from the witness",
            pct(pose["precision"], pose["precision_ci95"]),
            f"{pose['precision_reached']} of {pose['precision_poses']} poses",
        )
    )
    rows.append(
        (
            "pose-level recall: uniform in-reach cells whose centre an independent IK reaches",
            pct(pose["recall"], pose["recall_ci95"]),
            f"{pose['recall_marked']} of {pose['recall_cells']} cells ({pose['recall_draws']} drawn)",
        )
    )
    rows.append(
        (
            "cell-level precision against IK (one-cell tolerance, TP / (TP + FP))",
            f"{100 * (chk['precision'] or 0):.1f} %",
            f"{chk['true_positives']} TP, {chk['false_positives']} FP",
        )
    )
    rows.append(
        (
            "cell-level recall estimate against IK",
            f"{100 * (chk['recall_estimate'] or 0):.1f} %",
            f"NPV {100 * (chk['negative_predictive_value'] or 0):.1f} %",
        )
    )
    filled = built.meta["filled_cells"]
    rows.append(("fill: cells reached / grid cells", f"{filled} / {grid.size}", f"{100 * filled / grid.size:.2f} %"))
    convergence = []
    for done, values, elapsed in snapshots:
        snap = placement.BuiltMap(values.reshape(grid.shape), dict(built.meta, samples=done))
        c = pose_metrics(robot, snap, samples=args.check, seed=0)
        convergence.append(
            {
                "samples": done,
                "time_s": elapsed,
                "filled": int(np.count_nonzero(values)),
                "fill_ratio": float(np.count_nonzero(values) / grid.size),
                "recall": c["recall"],
                "precision": c["precision"],
                "completion": False,
            }
        )
    if completion:
        convergence.append(
            {
                "samples": samples,
                "time_s": curve[-1][2] + built.meta["completion"]["time_s"],
                "filled": filled,
                "fill_ratio": filled / grid.size,
                "recall": pose["recall"],
                "precision": pose["precision"],
                "completion": True,
            }
        )
    rows.append(
        (
            "convergence: samples -> fill / pose recall / pose precision",
            "; ".join(
                f"{c['samples'] / 1e6:.0f} M{' + completion' if c['completion'] else ''}: "
                f"{100 * c['fill_ratio']:.1f} / {100 * (c['recall'] or 0):.0f} / "
                f"{100 * (c['precision'] or 0):.0f} %"
                for c in convergence
            ),
            "docs/bench/convergence.png",
        )
    )

    out = Path(args.out)
    _plot(curve, convergence, grid.size, out / "convergence.png", f"{robot.name}/{arm}, grid {grid.shape}")
    table = ["| measurement | value | ratio / detail |", "|---|---|---|"]
    table += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    text = "\n".join([f"Machine: {machine()}", "", *table, ""])
    write_atomic(out / "map_build.md", text)
    write_atomic(
        out / "map_build.json",
        json.dumps(
            {
                "rows": rows,
                "curve": curve,
                "convergence": convergence,
                "check": {k: v for k, v in chk.items() if not isinstance(v, (list, dict))},
            },
            indent=1,
            default=str,
        ),
    )
    print(text)


def full_build(spec_path: str, spec: dict, robot) -> tuple[str, str, str]:
    """The spec built as `make maps` builds it (every arm, saved), in a child process: wall time, the
    child's peak memory, each arm's build time from its metadata."""
    import resource
    import subprocess

    tmp = Path(tempfile.mkdtemp())
    try:
        t = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "placement.cli.main",
                "maps",
                "build",
                "--spec",
                spec_path,
                "--out",
                str(tmp / "maps"),
                "-q",
            ],
            check=True,
            cwd=ROOT,
        )
        wall = time.perf_counter() - t
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 2**20
        arms = list(spec.get("arms", robot.arms))
        per = [placement.open_map(tmp / "maps", arm, robot).meta["build_time_s"] for arm in arms]
        size = sum(f.stat().st_size for f in (tmp / "maps").rglob("*") if f.is_file())
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return (
        f"all arms of {Path(spec_path).name} ({', '.join(arms)}) as `make maps` builds them, one run "
        "(goal <= 10 min, <= 8 GiB)",
        f"{wall / 60:.1f} min",
        f"{peak:.2f} GiB peak RSS; per arm {', '.join(f'{v:.0f}' for v in per)} s; {size / 1e6:.0f} MB on disk",
    )


def peak_rss_gib() -> float:
    """Peak resident memory of this process so far [GiB] (Linux ru_maxrss is in KiB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _plot(curve, convergence, cells, path, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([c[0] for c in curve])
    y = np.array([c[1] for c in curve])
    fig, ax = plt.subplots(figsize=(6.5, 4))
    ax.plot(x / 1e6, 100 * y / cells, color="tab:blue", label="fill: cells reached / grid cells")
    ax.set_xlabel("samples [millions]")
    ax.set_ylabel("fill [% of grid cells]", color="tab:blue")
    ax.grid(True, alpha=0.3)
    ax2 = ax.twinx()
    plain = [c for c in convergence if not c["completion"]]
    cx = np.array([c["samples"] for c in plain]) / 1e6
    ax2.plot(cx, [100 * (c["recall"] or 0) for c in plain], "o-", color="tab:orange", label="pose-level recall (IK)")
    ax2.plot(
        cx,
        [100 * (c["precision"] or 0) for c in plain],
        "s--",
        color="tab:green",
        label="pose-level precision (IK, 1 cm / 0.05 rad)",
    )
    for c in convergence:
        if c["completion"]:
            ax2.plot(
                [c["samples"] / 1e6],
                [100 * (c["recall"] or 0)],
                "*",
                ms=12,
                color="tab:red",
                label=f"recall after completion (+{c['time_s'] - plain[-1]['time_s']:.0f} s)"
                if plain
                else "recall after completion",
            )
            ax2.plot(
                [c["samples"] / 1e6],
                [100 * (c["precision"] or 0)],
                "P",
                ms=9,
                color="tab:purple",
                label="precision after completion",
            )
    ax2.set_ylabel("recall / precision [%]")
    ax2.set_ylim(0, 105)
    lines = ax.get_lines() + ax2.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], loc="lower right", fontsize=8)
    ax.set_title(f"Map convergence ({title})", fontsize=9)
    fig.tight_layout()
    write_file_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
