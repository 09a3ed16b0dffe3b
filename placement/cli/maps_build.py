"""`placement maps build`: the offline build of every arm's map, locally or on a Dask cluster."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import click

from placement.cli.options import arm_option, emit, robot_option, setup_logging, standard_options
from placement.cli.params import Checked, OneLineCommand
from placement.errors import ArmNotFound, PlacementError
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

if TYPE_CHECKING:
    from dask.distributed import Client

    from placement.storage.format import BuiltMap

log = logging.getLogger("placement")


def count_type(lo: int, hi: int) -> Checked:
    return Checked("count", lambda v, w: parse_count(v, w, lo, hi))


SEED = count_type(0, MAX_SEED)


@click.command(cls=OneLineCommand)
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
    robot: str | None,
    arm: str | None,
    spec_path: str | None,
    samples: int | None,
    seed: int | None,
    resolution: float | None,
    bins: tuple[int, int, int] | None,
    index: str | None,
    fmt: str | None,
    out: str,
    dask_address: str | None,
    self_collision: bool | None,
    self_distance: bool | None,
    completion: bool | None,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Sample each arm (every arm without --arm) and write its 6D reachability map atomically.

    Everything (spec, robot, arms, grid, output path) is checked before sampling starts. Arms already
    in a map of the same robot at --out are kept (also those another build saves meanwhile; a second
    build of an arm being built fails at once). --self-collision rejects samples where the arm hits
    the robot, --self-distance also penalises motion towards the body; --completion fills empty cells
    next to reached ones from their witnesses; --dask spreads the sampling over a Dask cluster (the
    same map as a local build).
    """
    setup_logging(verbose, quiet)
    # the sampler, the robot model and the compiler: loaded once the command runs, not for --help
    from placement.maps.build import build_grid, build_map
    from placement.maps.rmap import MapOutput
    from placement.maps.torso import check_torso
    from placement.maps.torso_builds import build_torso_maps, built_seconds
    from placement.robots import load_robot
    from placement.warmup import BUILD_COMPILE_S, announce_compilation

    spec = load_build_spec(spec_path) if spec_path else BuildSpec()
    options: dict[str, Any] = {
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
    loaded = load_robot(spec.robot)
    try:
        arms = spec.arms_of(loaded)
    except ArmNotFound as exc:
        if arm or not spec_path:
            raise
        raise PlacementError(f"build spec {spec_path}: arms: {exc}") from None
    for a in arms:
        build_grid(loaded, a, spec.resolution, spec.bins)
    arrays = {a: [a] for a in arms}  # arm -> the stored arrays its build writes (one per torso setting)
    if spec.torso is not None:
        where = f"build spec {spec_path}: torso"
        for a, t in check_torso(loaded, arms, spec.torso, where, spec.self_collision or spec.self_distance).items():
            arrays[a] += [name for name in t.arrays if name != a]
            if t.shift is None:
                n = len(t.allowed)
                log.warning(
                    "%s/%s: torso %s %s: %d builds, one per setting (%s): the build takes %d times as long",
                    loaded.name,
                    a,
                    t.label,
                    "has several joints" if t.joints else "is a revolute joint",
                    n,
                    "; ".join(t.describe(v) for v in t.allowed),
                    n,
                )
    out_path = Path(out)
    if spec.format == "hdf5" and out_path.suffix not in (".h5", ".hdf5"):
        out_path = out_path.with_suffix(".h5")
    reserved = [name for a in arms for name in arrays[a]]
    with MapOutput(out_path, loaded, spec.format, reserved, "--out") as output:  # proven writable, arms reserved
        client = dask_client(dask_address) if dask_address else None
        announce_compilation(BUILD_COMPILE_S)
        built: dict[str, BuiltMap] = {}
        summary_arms: dict[str, dict[str, Any]] = {}
        for a in arms:
            how: dict[str, Any] = {
                "samples": spec.samples,
                "seed": spec.seed,
                "resolution": spec.resolution,
                "bins": spec.bins,
                "index": spec.index,
                "progress": not quiet,
                "client": client,
                "self_collision": spec.self_collision,
                "self_distance": spec.self_distance,
                "completion": spec.completion,
            }
            if spec.torso is None:
                maps = {a: build_map(loaded, a, **how)}
            else:
                maps = build_torso_maps(loaded, a, torso=spec.torso, **how)
            built.update(maps)
            m = maps[a]
            log.info(
                "%s/%s: %d samples in %.1f s (%.0f samples/s), %d cells filled%s",
                loaded.name,
                a,
                spec.samples,
                built_seconds(maps),
                m.meta["samples_per_s"] or 0,
                m.meta["filled_cells"],
                f" at the reference; {len(maps)} builds, one per torso setting" if len(maps) > 1 else "",
            )
            keys = ("samples", "seed", "build_time_s", "samples_per_s", "filled_cells", "max_value")
            summary_arms[a] = {k: m.meta[k] for k in keys} | {
                "builds": len(maps),
                "build_time_s": round(built_seconds(maps), 3),
            }
        output.save(built)
    summary = {"path": str(out_path), "format": spec.format, "robot": loaded.name, "arms": summary_arms}
    emit(
        summary,
        as_json,
        lambda s: "\n".join(
            f"{s['path']}: {a} {v['samples']} samples, {v['build_time_s']} s, {v['filled_cells']} cells filled"
            + (f" ({v['builds']} builds, one per torso setting)" if v["builds"] > 1 else "")
            for a, v in s["arms"].items()
        ),
    )


def dask_client(address: str) -> Client:
    """A ``dask.distributed.Client`` of the scheduler at ``address``, or a one-line PlacementError."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise PlacementError("--dask needs dask.distributed: pip install 'placement[dask]'") from None
    try:
        return cast("Callable[..., Client]", Client)(address, timeout="10s")  # (Client.__init__ is unannotated)
    except Exception as exc:  # OSError / TimeoutError from the comm layer
        raise PlacementError(f"cannot reach Dask scheduler at {address}: {str(exc).splitlines()[0]}") from None
