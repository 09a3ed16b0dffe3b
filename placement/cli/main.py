"""Entry point: `placement maps ...` (offline maps), `placement query` (online placements), `placement view`."""

from __future__ import annotations

import sys

import click

from placement.cli import run_then_exit
from placement.cli.lazy import LazyGroup
from placement.process_env import configure_process
from placement.version import __version__

#: command -> where it is defined: imported only when it runs or shows its own help, so that
#: `placement --help` and a mistyped command answer without loading the planner or the map store
COMMANDS = {
    "evaluate": "placement.cli.evaluate:evaluate",
    "maps": "placement.cli.maps:maps",
    "query": "placement.cli.query:query",
    "robots": "placement.cli.robots:robots",
    "ros": "placement.cli.ros:ros",
    "scenes": "placement.cli.scenes:scenes",
    "view": "placement.cli.view:view",
}


@click.group(cls=LazyGroup, lazy=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="placement")
def cli() -> None:
    """Robot base placement for mobile manipulation."""


def main() -> None:
    configure_process()
    if _command(sys.argv[1:]) == "query":  # a query ends at once once it has answered
        run_then_exit(cli, prog_name="placement")
    cli(prog_name="placement")


def _command(args: list[str]) -> str | None:
    """The subcommand of the command line ``args`` (its first word that is not an option)."""
    return next((a for a in args if not a.startswith("-")), None)


if __name__ == "__main__":
    main()
