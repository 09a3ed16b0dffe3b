"""Entry point: `placement maps ...` (offline maps), `placement query` (online placements), `placement view`."""

from __future__ import annotations

import click

from placement import __version__
from placement.cli.evaluate import evaluate
from placement.cli.maps import maps
from placement.cli.params import OneLineGroup
from placement.cli.query import query
from placement.cli.robots import robots
from placement.cli.scenes import scenes
from placement.cli.view import view


@click.group(cls=OneLineGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="placement")
def cli() -> None:
    """Robot base placement for mobile manipulation."""


cli.add_command(maps)
cli.add_command(query)
cli.add_command(scenes)
cli.add_command(evaluate)
cli.add_command(view)
cli.add_command(robots)


def main() -> None:
    cli(prog_name="placement")


if __name__ == "__main__":
    main()
