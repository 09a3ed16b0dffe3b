"""`placement maps build | info | check`."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import click
import numpy as np
import yaml

from ..build import DEFAULT_BINS, build_map
from ..errors import MapError, PlacementError
from ..rmap import open_map, save_maps
from ..robots import load_robot
from ..storage import open_store
from .options import arm_option, emit, json_option, one_line_errors, robot_option, setup_logging, verbosity

log = logging.getLogger("placement")

_SPEC_KEYS = {"robot", "arms", "samples", "seed", "resolution", "bins", "index", "format", "self_collision",
              "self_distance"}


def _read_spec(path: str | None) -> dict:
    if not path:
        return {}
    try:
        spec = yaml.safe_load(Path(path).read_text()) or {}
    except FileNotFoundError:
        raise PlacementError(f"build spec {path} not found") from None
    except yaml.YAMLError as exc:
        raise PlacementError(f"build spec {path} is not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(spec, dict):
        raise PlacementError(f"build spec {path} must be a mapping")
    unknown = set(spec) - _SPEC_KEYS
    if unknown:
        raise PlacementError(f"build spec {path}: unknown key '{sorted(unknown)[0]}'; allowed: "
                             f"{', '.join(sorted(_SPEC_KEYS))}")
    return spec


@click.group()
def maps():
    """Build and inspect reachability maps (offline)."""


@maps.command()
@robot_option
@arm_option
@click.option("--spec", "spec_path", default=None, metavar="YAML", help="Build spec (maps/pr2.yaml); options override it.")
@click.option("--samples", type=int, default=None, help="Joint samples per arm [count].")
@click.option("--seed", type=int, default=None, help="Sampling seed (same seed + samples = same map).")
@click.option("--resolution", type=float, default=None, help="Position cell edge [m] (default 0.05).")
@click.option("--bins", default=None, metavar="YAW,PITCH,ROLL", help="Orientation bins (default 20,9,20).")
@click.option("--index", type=click.Choice(["isotropy", "volume"]), default=None, help="Manipulability index.")
@click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default=None, help="Storage backend.")
@click.option("--out", required=True, type=click.Path(), help="Map directory (zarr) or file (hdf5).")
@click.option("--dask", "dask_address", default=None, metavar="ADDRESS",
              help="Spread sampling over a Dask cluster (scheduler address, e.g. tcp://host:8786).")
@click.option("--self-collision/--no-self-collision", default=None,
              help="Reject samples where the arm hits the robot (URDF collision shapes; much slower).")
@click.option("--self-distance/--no-self-distance", default=None,
              help="Penalise motion towards the robot's own body (implies --self-collision; slow).")
@json_option
@verbosity
@one_line_errors
def build(robot, arm, spec_path, samples, seed, resolution, bins, index, fmt, out, dask_address, self_collision,
          self_distance, as_json, verbose, quiet):
    """Sample each arm and write its 6D reachability map atomically."""
    setup_logging(verbose, quiet)
    spec = _read_spec(spec_path)
    robot = load_robot(robot or spec.get("robot", "pr2"))
    arms = [arm] if arm else list(spec.get("arms") or robot.arms)
    for a in arms:
        robot.arm(a)
    samples = samples if samples is not None else int(spec.get("samples", 1_000_000))
    seed = seed if seed is not None else int(spec.get("seed", 0))
    resolution = resolution if resolution is not None else float(spec.get("resolution", 0.05))
    if bins is not None:
        try:
            bins = tuple(int(b) for b in bins.split(","))
        except ValueError:
            raise PlacementError(f"--bins must be three integers YAW,PITCH,ROLL, got '{bins}'") from None
    else:
        bins = tuple(spec.get("bins", DEFAULT_BINS))
    if len(bins) != 3:
        raise PlacementError(f"orientation bins must be three counts (yaw, pitch, roll), got {bins}")
    if samples < 1:
        raise PlacementError(f"--samples must be a positive count, got {samples}")
    if not (0.005 <= resolution <= 1.0):
        raise PlacementError(f"--resolution must be between 0.005 and 1.0 m, got {resolution}")
    index = index or spec.get("index", "isotropy")
    fmt = fmt or spec.get("format", "zarr")
    if self_collision is None:
        self_collision = spec.get("self_collision", False)
        if not isinstance(self_collision, bool):
            raise PlacementError(f"build spec: self_collision must be true or false, got {self_collision!r}")
    if self_distance is None:
        self_distance = spec.get("self_distance", False)
        if not isinstance(self_distance, bool):
            raise PlacementError(f"build spec: self_distance must be true or false, got {self_distance!r}")
    out_path = Path(out)
    if fmt == "hdf5" and out_path.suffix not in (".h5", ".hdf5"):
        out_path = out_path.with_suffix(".h5")
    _refuse_foreign(out_path)
    client = _dask_client(dask_address) if dask_address else None
    built = {}
    for a in arms:
        built[a] = m = build_map(robot, a, samples=samples, seed=seed, resolution=resolution, bins=bins,
                                 index=index, progress=not quiet, client=client, self_collision=self_collision,
                                 self_distance=self_distance)
        log.info("%s/%s: %d samples in %.1f s (%.0f samples/s), %d cells filled",
                 robot.name, a, samples, m.meta["build_time_s"], m.meta["samples_per_s"] or 0,
                 m.meta["filled_cells"])
    save_maps(out_path, robot, built, fmt)
    summary = {"path": str(out_path), "format": fmt, "robot": robot.name,
               "arms": {a: {k: m.meta[k] for k in ("samples", "seed", "build_time_s", "samples_per_s",
                                                   "filled_cells", "max_value")} for a, m in built.items()}}
    emit(summary, as_json, lambda s: "\n".join(
        f"{s['path']}: {a} {v['samples']} samples, {v['build_time_s']} s, {v['filled_cells']} cells filled"
        for a, v in s["arms"].items()))


def _dask_client(address: str):
    try:
        from dask.distributed import Client
    except ImportError:
        raise PlacementError("--dask needs dask.distributed: pip install 'placement[dask]'") from None
    try:
        return Client(address, timeout="10s")
    except Exception as exc:  # OSError / TimeoutError from the comm layer
        raise PlacementError(f"cannot reach Dask scheduler at {address}: {str(exc).splitlines()[0]}") from None


def _refuse_foreign(path: Path) -> None:
    """Fail before hours of sampling if the output path holds something that is not a map."""
    if not path.exists():
        return
    try:
        open_store(path).close()
    except MapError:
        raise MapError(f"{path} exists and is not a map; refusing to overwrite it") from None


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


@maps.command()
@click.argument("path", type=click.Path())
@robot_option
@arm_option
@json_option
@verbosity
@one_line_errors
def info(path, robot, arm, as_json, verbose, quiet):
    """Metadata, fill ratio and value histogram of a map."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    root = store.root
    arms = [arm] if arm else list(root.get("arms") or [])
    out = {"path": str(path), "size_bytes": _size(Path(path)), "root": root, "arms": {}}
    edges = [0.0, 0.01, 0.0235, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0]
    for a in arms:
        rmap = open_map(path, a, robot)
        values = rmap.values
        reached = values[values > 0]
        hist, _ = np.histogram(reached, bins=edges)
        out["arms"][a] = {
            "meta": rmap.meta,
            "cells": int(values.size),
            "filled_cells": int(reached.size),
            "fill_ratio": float(reached.size / values.size),
            "value": {"max": float(reached.max()) if reached.size else 0.0,
                      "mean": float(reached.mean()) if reached.size else 0.0,
                      "histogram": {"edges": edges, "counts": hist.tolist()}},
        }
    emit(out, as_json, _render_info)


def _render_info(d: dict) -> str:
    r = d["root"]
    lines = [f"{d['path']}  ({d['size_bytes'] / 1e6:.1f} MB)  robot {r.get('robot')}  base {r.get('base_frame')}"]
    for a, v in d["arms"].items():
        m = v["meta"]
        g = m["grid"]
        lines.append(f"  arm {a}: tip {m['tip_frame']}, grid {g['shape']} at {g['resolution']} m, "
                     f"{m['measure']['index']}, {m['samples']} samples (seed {m['seed']}), "
                     f"built in {m['build_time_s']} s")
        lines.append(f"    filled {v['filled_cells']} of {v['cells']} cells ({100 * v['fill_ratio']:.2f} %), "
                     f"max {v['value']['max']:.4f}, mean {v['value']['mean']:.4f}")
        h = v["value"]["histogram"]
        lines.append("    histogram: " + ", ".join(
            f"[{lo:g}, {hi:g}): {c}" for lo, hi, c in zip(h["edges"], h["edges"][1:], h["counts"])))
    return "\n".join(lines)


@maps.command()
@click.argument("path", type=click.Path())
@robot_option
@arm_option
@click.option("--samples", type=int, default=200, help="IK checks per class (reachable / unreachable).")
@click.option("--seed", type=int, default=0)
@json_option
@verbosity
@one_line_errors
def check(path, robot, arm, samples, seed, as_json, verbose, quiet):
    """Accuracy of a map against inverse kinematics on random poses."""
    from ..accuracy import check_map

    setup_logging(verbose, quiet)
    if samples < 1:
        raise PlacementError(f"--samples must be a positive count, got {samples}")
    store = open_store(path)
    arms = [arm] if arm else list(store.root.get("arms") or [])
    out = {"path": str(path), "arms": {}}
    for a in arms:
        rmap = open_map(path, a, robot)
        rmap.verify()
        out["arms"][a] = check_map(load_robot(robot or store.root.get("preset") or store.root["robot"]),
                                   rmap, samples=samples, seed=seed)
    emit(out, as_json, lambda d: "\n".join(
        f"{d['path']} arm {a}: " + ", ".join(f"{k} {v}" for k, v in r.items() if not isinstance(v, (dict, list)))
        for a, r in d["arms"].items()))


