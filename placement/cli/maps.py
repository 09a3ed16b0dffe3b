"""`placement maps build | info | check | verify | view`."""

from __future__ import annotations

import click

from placement.cli.maps_build import build
from placement.cli.maps_inspect import check, info, verify
from placement.cli.params import OneLineGroup
from placement.cli.view import maps_view


@click.group(cls=OneLineGroup)
def maps() -> None:
    """Build and inspect reachability maps (offline)."""


for command in (build, info, check, verify, maps_view):
    maps.add_command(command)
