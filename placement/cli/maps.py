"""`placement maps build | info | check | verify | view`."""

from __future__ import annotations

import click

from placement.cli.lazy import LazyGroup

#: subcommand -> where it is defined (imported when it runs: `placement maps --help` loads no map code)
COMMANDS = {
    "build": "placement.cli.maps_build:build",
    "check": "placement.cli.maps_inspect:check",
    "info": "placement.cli.maps_inspect:info",
    "verify": "placement.cli.maps_inspect:verify",
    "view": "placement.cli.view:maps_view",
}


@click.group(cls=LazyGroup, lazy=COMMANDS)
def maps() -> None:
    """Build and inspect reachability maps (offline)."""
