"""`placement scenes generate`: seeded table-clearing scenes for the evaluation."""

from __future__ import annotations

from pathlib import Path

import click

from placement.cli.options import emit, log, out_option, setup_logging, standard_options
from placement.cli.params import Bounded, OneLineCommand
from placement.evaluation.generate import MAX_OBJECTS, MAX_SCENES, MAX_SEED, TABLE_DEPTH, TABLE_SIZES, write_scenes


@click.command(cls=OneLineCommand)
@click.option("--seed", type=Bounded(0, MAX_SEED), default=0, show_default=True, help="Seed, 0 to 2^63-1.")
@click.option("--count", type=Bounded(1, MAX_SCENES), default=10, show_default=True, help=f"Scenes, 1 to {MAX_SCENES}.")
@click.option(
    "--objects",
    type=Bounded(1, MAX_OBJECTS),
    default=6,
    show_default=True,
    help=f"Objects per scene, 1 to {MAX_OBJECTS}.",
)
@click.option("--obstacles", is_flag=True, help="Add crates beside the pick tables.")
@click.option(
    "--robot",
    "preset",
    default="pr2",
    show_default=True,
    help="Preset name or preset YAML path (sets the table size); a path is recorded relative to the scenes.",
)
@click.option(
    "--maps",
    default=None,
    type=click.Path(),
    help="Reachability maps the scenes record (relative to the scenes unless absolute) "
    "[default: maps/<robot name> in the current directory].",
)
@click.option(
    "--table-depth",
    type=float,
    default=None,
    help=f"Pick table depth [m], {TABLE_DEPTH[0]:g} to {TABLE_DEPTH[1]:g} [default: per robot, 0.6 for the PR2].",
)
@out_option("Folder the scenes are written to (created; checked before generating).", required=True)
@standard_options
def generate(
    seed: int,
    count: int,
    objects: int,
    obstacles: bool,
    preset: str,
    maps: str | None,
    table_depth: float | None,
    out: str,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Write --count seeded table-clearing scenes to the folder --out.

    The paper's layout (three pick tables, two place tables), the pick tables sized for the robot
    (0.8 x 0.6 m for the PR2); paths are recorded relative to the scenes, so they plan from any
    directory."""
    setup_logging(verbose, quiet)
    from placement.evaluation.outdir import output_dir
    from placement.robots import load_robot

    with output_dir(out, "--out"):
        if maps is None:
            # the planner's own default, seen from here: the scenes then plan from any directory
            maps = str(Path("maps") / load_robot(preset).name)
        size = None if table_depth is None else (TABLE_SIZES.get(preset, (0.8, 0.8))[0], table_depth)
        paths = write_scenes(
            out, seed, count, objects=objects, obstacles=obstacles, preset=preset, maps=maps, table_size=size
        )
    if not Path(maps).exists():
        log.warning("note: %s does not exist (yet); the scenes record it as their maps", maps)
    emit({"scenes": [str(p) for p in paths]}, as_json, lambda d: "\n".join(d["scenes"]))
