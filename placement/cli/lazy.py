"""A command group that imports a subcommand's module only when that subcommand is used.

A command's module may import numba, zarr or pinocchio (about 1.5 s together), which ``placement
--help`` and a group's listing do not need: they show each command's summary from the docstring of its
function, read from the source without running it.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import click

from placement.cli.params import OneLineGroup


def load(target: str) -> click.Command:
    """The command at ``target`` ("module:attribute"), its module imported."""
    module, _, attribute = target.partition(":")
    command = getattr(importlib.import_module(module), attribute)
    assert isinstance(command, click.Command), f"{target} is no click command"
    return command


def summary(name: str, target: str) -> click.Command:
    """The command at ``target`` if its module is loaded, else a stand-in named ``name`` that holds only
    its help: the docstring of the function ``target`` names (imported after all if there is none)."""
    module, _, attribute = target.partition(":")
    if module in sys.modules:
        return load(target)
    spec = importlib.util.find_spec(module)  # imports the parent packages only (placement, placement.cli)
    if spec is not None and spec.origin is not None:
        for node in ast.parse(Path(spec.origin).read_text(encoding="utf-8")).body:
            if isinstance(node, ast.FunctionDef) and node.name == attribute:
                return click.Command(name, help=ast.get_docstring(node))
    return load(target)


class LazyGroup(OneLineGroup):
    """A :class:`OneLineGroup` whose ``lazy`` subcommands (name -> "module:attribute") are imported when
    run or asked for help, and listed from their docstrings."""

    def __init__(self, *args: Any, lazy: Mapping[str, str] | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lazy = dict(lazy or {})

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self.lazy and cmd_name not in self.commands:
            self.add_command(load(self.lazy[cmd_name]), cmd_name)
        return super().get_command(ctx, cmd_name)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The "Commands" section as click writes it, without importing the commands not yet loaded."""
        shown = []
        for name in self.list_commands(ctx):
            command = self.commands.get(name) or summary(name, self.lazy[name])
            if not command.hidden:
                shown.append((name, command))
        if shown:
            limit = formatter.width - 6 - max(len(name) for name, _ in shown)
            with formatter.section("Commands"):
                formatter.write_dl([(name, command.get_short_help_str(limit)) for name, command in shown])
