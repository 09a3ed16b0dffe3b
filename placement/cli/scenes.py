"""`placement scenes generate`: seeded benchmark scenes."""

from __future__ import annotations

import click

from placement.cli.lazy import LazyGroup


@click.group(cls=LazyGroup, lazy={"generate": "placement.cli.scenes_generate:generate"})
def scenes() -> None:
    """Benchmark scenes."""
