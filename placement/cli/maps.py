"""`placement maps build | info | check | verify | view`."""

from __future__ import annotations

import dataclasses
import logging
import sys
from pathlib import Path

import click
import numpy as np
from tqdm import tqdm

from placement.cli.options import arm_option, emit, robot_option, setup_logging, standard_options
from placement.cli.params import Checked, OneLineCommand, OneLineGroup
from placement.cli.view import maps_view
from placement.errors import ArmNotFound, PlacementError
from placement.maps.accuracy import MAX_CHECK_SAMPLES, check_map, pose_metrics
from placement.maps.build import build_grid, build_map
from placement.maps.buildspec import (
    FORMATS,
    INDEXES,
    MAX_RESOLUTION,
    MAX_SAMPLES,
    MAX_SEED,
    MIN_RESOLUTION,
    BuildSpec,
    load_build_spec,
    parse_bins,
    parse_count,
    parse_length,
)
from placement.maps.rmap import MapOutput, check_root, open_map
from placement.maps.witness import verify_witnesses
from placement.progress import EtaBar
from placement.robots import load_robot
from placement.storage import open_store
from placement.storage.digest import DIGEST_KEY
from placement.storage.format import CRC_KEY, WITNESS_CRC_KEY
from placement.warmup import BUILD_COMPILE_S, announce_compilation

log = logging.getLogger("placement")


def count_type(lo: int, hi: int) -> Checked:
    return Checked("count", lambda v, w: parse_count(v, w, lo, hi))


SEED = count_type(0, MAX_SEED)


@click.group(cls=OneLineGroup)
def maps():
    """Build and inspect reachability maps (offline)."""


@maps.command(cls=OneLineCommand)
@robot_option
@arm_option
@click.option(
    "--spec", "spec_path", default=None, metavar="YAML", help="Build spec (maps/pr2.yaml); options override it."
)
@click.option(
    "--samples",
    type=count_type(1, MAX_SAMPLES),
    default=None,
    help=f"Joint samples per arm [count, 1 to {MAX_SAMPLES:.0e}] (default 1e6).",
)
@click.option("--seed", type=SEED, default=None, help="Sampling seed (same seed + samples = same map).")
@click.option(
    "--resolution",
    default=None,
    type=Checked("length", lambda v, w: parse_length(v, w, MIN_RESOLUTION, MAX_RESOLUTION)),
    help=f"Position cell edge [m, {MIN_RESOLUTION} to {MAX_RESOLUTION}] (default 0.05).",
)
@click.option(
    "--bins",
    type=Checked("bins", parse_bins),
    default=None,
    metavar="YAW,PITCH,ROLL",
    help="Orientation bins (default 20,9,20).",
)
@click.option("--index", type=click.Choice(INDEXES), default=None, help="Manipulability index.")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default=None, help="Storage backend.")
@click.option("--out", required=True, type=click.Path(), help="Map directory (zarr) or file (hdf5).")
@click.option(
    "--dask",
    "dask_address",
    default=None,
    metavar="ADDRESS",
    help="Spread sampling over a Dask cluster (scheduler address, e.g. tcp://host:8786).",
)
@click.option(
    "--self-collision/--no-self-collision",
    default=None,
    help="Reject samples where the arm hits the robot (URDF collision shapes; much slower).",
)
@click.option(
    "--self-distance/--no-self-distance",
    default=None,
    help="Penalise motion towards the robot's own body (implies --self-collision; slow).",
)
@click.option(
    "--completion/--no-completion",
    default=None,
    help="After sampling, fill empty cells next to reached ones from their witnesses (a few IK steps).",
)
@standard_options
def build(
    robot,
    arm,
    spec_path,
    samples,
    seed,
    resolution,
    bins,
    index,
    fmt,
    out,
    dask_address,
    self_collision,
    self_distance,
    completion,
    as_json,
    verbose,
    quiet,
):
    """Sample each arm and write its 6D reachability map atomically.

    Everything (spec, robot, arms, grid, output path) is checked before sampling starts.
    """
    setup_logging(verbose, quiet)
    spec = load_build_spec(spec_path) if spec_path else BuildSpec()
    options = {
        "robot": robot,
        "arms": (arm,) if arm else None,
        "samples": samples,
        "seed": seed,
        "resolution": resolution,
        "bins": bins,
        "index": index,
        "format": fmt,
        "self_collision": self_collision,
        "self_distance": self_distance,
        "completion": completion,
    }
    spec = dataclasses.replace(spec, **{k: v for k, v in options.items() if v is not None})
    robot = load_robot(spec.robot)
    try:
        arms = spec.arms_of(robot)
    except ArmNotFound as exc:
        if arm or not spec_path:
            raise
        raise PlacementError(f"build spec {spec_path}: arms: {exc}") from None
    for a in arms:
        build_grid(robot, a, spec.resolution, spec.bins)
    out_path = Path(out)
    if spec.format == "hdf5" and out_path.suffix not in (".h5", ".hdf5"):
        out_path = out_path.with_suffix(".h5")
    with MapOutput(out_path, robot, spec.format, arms, "--out") as output:  # proven writable, arms reserved
        client = dask_client(dask_address) if dask_address else None
        announce_compilation(BUILD_COMPILE_S)
        built = {}
        for a in arms:
            built[a] = m = build_map(
                robot,
                a,
                samples=spec.samples,
                seed=spec.seed,
                resolution=spec.resolution,
                bins=spec.bins,
                index=spec.index,
                progress=not quiet,
                client=client,
                self_collision=spec.self_collision,
                self_distance=spec.self_distance,
                completion=spec.completion,
            )
            log.info(
                "%s/%s: %d samples in %.1f s (%.0f samples/s), %d cells filled",
                robot.name,
                a,
                spec.samples,
                m.meta["build_time_s"],
                m.meta["samples_per_s"] or 0,
                m.meta["filled_cells"],
            )
        output.save(built)
    summary = {
        "path": str(out_path),
        "format": spec.format,
        "robot": robot.name,
        "arms": {
            a: {k: m.meta[k] for k in ("samples", "seed", "build_time_s", "samples_per_s", "filled_cells", "max_value")}
            for a, m in built.items()
        },
    }
    emit(
        summary,
        as_json,
        lambda s: "\n".join(
            f"{s['path']}: {a} {v['samples']} samples, {v['build_time_s']} s, {v['filled_cells']} cells filled"
            for a, v in s["arms"].items()
        ),
    )


def dask_client(address: str):
    """A ``dask.distributed.Client`` of the scheduler at ``address``, or a one-line PlacementError."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise PlacementError("--dask needs dask.distributed: pip install 'placement[dask]'") from None
    try:
        return Client(address, timeout="10s")
    except Exception as exc:  # OSError / TimeoutError from the comm layer
        raise PlacementError(f"cannot reach Dask scheduler at {address}: {str(exc).splitlines()[0]}") from None


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


@maps.command(cls=OneLineCommand)
@click.argument("path", type=click.Path())
@robot_option
@arm_option
@standard_options
def info(path, robot, arm, as_json, verbose, quiet):
    """Metadata, fill ratio and value histogram of a map; reads and checks every chunk of every arm."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    check_root(Path(path), store.root)
    stored = list(store.root.get("arms") or [])
    store.close()
    shown = [arm] if arm else stored
    root = {k: v for k, v in store.root.items() if k != DIGEST_KEY}
    out = {"path": str(path), "size_bytes": _size(Path(path)), "root": root, "arms": {}}
    for a in dict.fromkeys([*shown, *stored]):  # the shown arm first: a wrong --arm fails before the reading
        rmap = open_map(path, a, robot)
        with tqdm(
            total=rmap.grid.shape[2], desc=f"info {a}", unit="layer", disable=_no_bars(quiet), leave=False
        ) as bar:
            stats = scan(rmap, progress=bar.update)  # reads and checks every chunk of the values and witnesses
        if a in shown:
            meta = {k: v for k, v in rmap.meta.items() if k not in (CRC_KEY, WITNESS_CRC_KEY)}
            out["arms"][a] = {"meta": meta, **stats}
    emit(out, as_json, _render_info)


HISTOGRAM_EDGES = [0.0, 0.01, 0.0235, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0]


def _no_bars(quiet: bool) -> bool:
    """No progress bars with -q, nor when stderr is not a terminal (a pipe, a log file, a test runner
    that mixes stderr into stdout): what info and check print stays plain."""
    return quiet or not sys.stderr.isatty()


def scan(rmap, progress=None) -> dict:
    """Fill and value statistics of a map, reading every chunk of its values and witnesses (each checked
    against its CRC32) one z layer at a time (memory: two layers, not the whole map); ``progress(1)``
    after each layer."""
    store, arm = rmap.store, rmap.arm
    counts = np.zeros(len(HISTOGRAM_EDGES) - 1, dtype=np.int64)
    total, high, cells = 0.0, 0.0, 0
    for iz in range(rmap.grid.shape[2]):
        values = store.read_slab(arm, iz)
        store.read_slab(arm, iz, witness=True)
        reached = values[values > 0]
        counts += np.histogram(reached, bins=HISTOGRAM_EDGES)[0]
        cells += reached.size
        total += float(reached.sum(dtype=np.float64))
        high = max(high, float(reached.max(initial=0.0)))
        if progress is not None:
            progress(1)
    size = rmap.grid.size
    return {
        "chunks_checked": 2 * int(np.prod(np.shape(rmap.meta[CRC_KEY]))),
        "cells": size,
        "filled_cells": cells,
        "fill_ratio": cells / size,
        "value": {
            "max": high,
            "mean": total / cells if cells else 0.0,
            "histogram": {"edges": HISTOGRAM_EDGES, "counts": counts.tolist()},
        },
    }


def _render_info(d: dict) -> str:
    r = d["root"]
    lines = [f"{d['path']}  ({d['size_bytes'] / 1e6:.1f} MB)  robot {r.get('robot')}  base {r.get('base_frame')}"]
    for a, v in d["arms"].items():
        m = v["meta"]
        g = m["grid"]
        lines.append(
            f"  arm {a}: tip {m['tip_frame']}, grid {g['shape']} at {g['resolution']} m, "
            f"{m['measure']['index']}, {m['samples']} samples (seed {m['seed']}), "
            f"built in {m['build_time_s']} s"
        )
        lines.append(
            f"    filled {v['filled_cells']} of {v['cells']} cells ({100 * v['fill_ratio']:.2f} %), "
            f"max {v['value']['max']:.4f}, mean {v['value']['mean']:.4f}"
        )
        h = v["value"]["histogram"]
        lines.append(
            "    histogram: "
            + ", ".join(f"[{lo:g}, {hi:g}): {c}" for lo, hi, c in zip(h["edges"], h["edges"][1:], h["counts"]))
        )
    return "\n".join(lines)


@maps.command(cls=OneLineCommand)
@click.argument("path", type=click.Path())
@robot_option
@arm_option
@click.option(
    "--samples",
    type=count_type(1, MAX_CHECK_SAMPLES),
    default=200,
    help=f"IK checks per class (reachable / unreachable) [count, 1 to {MAX_CHECK_SAMPLES:,}].",
)
@click.option("--seed", type=SEED, default=0, help="Seed of the cell draws and IK restarts.")
@standard_options
def check(path, robot, arm, samples, seed, as_json, verbose, quiet):
    """Accuracy of a map against inverse kinematics on random poses (reads and checks every chunk first)."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    arms = [arm] if arm else list(store.root.get("arms") or [])
    out = {"path": str(path), "arms": {}}
    for a in arms:
        log.info("arm %s: reading and checking every chunk", a)
        rmap = open_map(path, a, robot).load()
        out["arms"][a] = _check_arm(
            load_robot(robot or store.root.get("preset") or store.root["robot"]), rmap, a, samples, seed, quiet
        )
    emit(out, as_json, _render_check)


def _check_arm(robot, rmap, arm: str, samples: int, seed: int, quiet: bool) -> dict:
    """:func:`check_map` of one arm with a bar for its cell-level IK solves and one for the pose-level
    ones (:func:`pose_metrics`, which check_map runs without a progress hook): the same document."""

    def bar(what):
        return tqdm(total=1, desc=f"check {arm}: {what}", unit="IK", disable=_no_bars(quiet), leave=False)

    def ticker(b):
        def tick(done, total):
            b.total = total
            b.update(done - b.n)

        return tick

    with bar("cells") as b:
        doc = check_map(robot, rmap, samples=samples, seed=seed, pose_level=False, progress=ticker(b))
    with bar("poses") as b:
        doc["pose_level"] = pose_metrics(robot, rmap, samples, seed, doc["threshold"], progress=ticker(b))
    doc["time_s"] = round(doc["time_s"] + doc["pose_level"]["time_s"], 4)
    return doc


def _render_check(d: dict) -> str:
    lines = []
    for a, r in d["arms"].items():
        p = r["pose_level"]

        def rate(x, ci):
            return "n/a" if x is None else f"{100 * x:.1f} % (95 % CI {100 * ci[0]:.1f}-{100 * ci[1]:.1f})"

        lines.append(
            f"{d['path']} arm {a}: pose-level (IK to {p['pos_tol_m']} m, {p['rot_tol_rad']} rad): "
            f"precision {rate(p['precision'], p['precision_ci95'])} of {p['precision_poses']} poses in "
            f"reachable cells; recall {rate(p['recall'], p['recall_ci95'])} of {p['recall_cells']} "
            f"IK-reachable cells ({p['recall_draws']} drawn in reach)"
        )
        lines.append(
            "  cell-level (one-cell tolerance): "
            + ", ".join(f"{k} {v}" for k, v in r.items() if not isinstance(v, (dict, list)))
        )
    return "\n".join(lines)


@maps.command(cls=OneLineCommand)
@click.argument("path", type=click.Path())
@robot_option
@arm_option
@click.option(
    "--sample",
    type=count_type(1, 10**12),
    default=None,
    help="Check this many reached cells drawn at random [count] (default: all; ~2 us per cell).",
)
@click.option("--seed", type=SEED, default=0, help="Seed of the --sample draw.")
@standard_options
def verify(path, robot, arm, sample, seed, as_json, verbose, quiet):
    """Recompute stored values from their witnesses, bitwise; exit 1 if any differs (one line per arm)."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    check_root(Path(path), store.root)
    arms = [arm] if arm else list(store.root.get("arms") or [])
    store.close()
    out = {"path": str(path), "arms": {}}
    for a in arms:
        rmap = open_map(path, a, robot)
        with EtaBar(total=1, desc=f"verify {a}", unit="cell", unit_scale=True, disable=quiet, leave=False) as bar:

            def tick(done, total):
                bar.total = total
                bar.update(done - bar.n)

            out["arms"][a] = verify_witnesses(rmap.robot, rmap, sample=sample, seed=seed, progress=tick)
    emit(out, as_json, _render_verify)
    if any(r["mismatches"] for r in out["arms"].values()):
        raise SystemExit(1)


def _render_verify(d: dict) -> str:
    lines = []
    for a, r in d["arms"].items():
        head = (
            f"{d['path']} arm {a}: {r['cells_checked']} of {r['cells_reached']} reached cells recomputed "
            f"from their witnesses in {r['time_s']} s"
        )
        if not r["mismatches"]:
            lines.append(head + ": all equal (bitwise)")
        else:
            shown = "; ".join(
                f"cell {f['cell']} (witness {f['witness']}): stored {f['stored']}, recomputed {f['recomputed']}"
                for f in r["first"][:3]
            )
            lines.append(f"{head}: {r['mismatches']} MISMATCH, first: {shown}")
    return "\n".join(lines)


maps.add_command(maps_view)
