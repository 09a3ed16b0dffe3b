"""`placement scenes`: check a scene file, generate seeded benchmark scenes."""

from __future__ import annotations

import click

from placement.cli.lazy import LazyGroup


@click.group(
    cls=LazyGroup,
    lazy={"check": "placement.cli.scenes_check:check", "generate": "placement.cli.scenes_generate:generate"},
)
def scenes() -> None:
    """Scene files: check one, generate benchmark ones."""
