"""`placement scenes generate`: seeded benchmark scenes."""

from __future__ import annotations

import click

from ..planning.generate import write_scenes
from .options import emit, json_option, one_line_errors, setup_logging, verbosity


@click.group()
def scenes():
    """Benchmark scenes."""


@scenes.command()
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--count", type=int, default=10, show_default=True)
@click.option("--objects", type=int, default=6, show_default=True, help="Objects per scene.")
@click.option("--obstacles", is_flag=True, help="Add crates beside the pick tables.")
@click.option("--robot", "preset", default="pr2", show_default=True, help="Preset (sets the table size).")
@click.option("--maps", default=None, help="Value of the scenes' `maps` key.")
@click.argument("out_dir", type=click.Path())
@json_option
@verbosity
@one_line_errors
def generate(seed, count, objects, obstacles, preset, maps, out_dir, as_json, verbose, quiet):
    """Write COUNT table-clearing scenes of SEED to OUT_DIR."""
    setup_logging(verbose, quiet)
    paths = write_scenes(out_dir, seed, count, objects=objects, obstacles=obstacles, preset=preset, maps=maps)
    emit({"scenes": [str(p) for p in paths]}, as_json, lambda d: "\n".join(d["scenes"]))
