"""Click parameter types with bounds, and a command class that reports a bad option in one line."""

from __future__ import annotations

from collections.abc import Callable
from typing import IO, Any, NoReturn

import click

from placement.errors import PlacementError


class OneLineCommand(click.Command):
    """A command whose bad options and arguments give one line ``error: ...`` and exit code 2,
    like the package's own errors (click alone prints the usage and a hint around it)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        try:
            return super().parse_args(ctx, args)
        except click.UsageError as exc:
            _usage_error(ctx, exc)


class OneLineGroup(click.Group):
    """A group whose unknown subcommands and bad options give one line, like :class:`OneLineCommand`;
    its subcommands are :class:`OneLineCommand` unless they say otherwise."""

    command_class = OneLineCommand

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        try:
            return super().parse_args(ctx, args)
        except click.UsageError as exc:
            _usage_error(ctx, exc)

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        try:
            return super().resolve_command(ctx, args)
        except click.UsageError as exc:
            _usage_error(ctx, exc)


OneLineGroup.group_class = OneLineGroup


def _usage_error(ctx: click.Context, exc: click.UsageError) -> NoReturn:
    click.echo(f"error: {exc.format_message()} (see '{ctx.command_path} --help')", err=True)
    ctx.exit(2)


class Bounded(click.IntRange):
    """A whole number from ``min`` to ``max``; anything else is rejected naming both bounds."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        try:
            return super().convert(value, param, ctx)
        except click.BadParameter:
            self.fail(f"{value!r} is not a whole number from {self.min} to {self.max}", param, ctx)


class OneLineError(click.ClickException):
    """A bad option value: one `error: ...` line on stderr, exit code 2 (like every other bad input)."""

    exit_code = 2

    def show(self, file: IO[Any] | None = None) -> None:
        click.echo(f"error: {self.format_message()}", err=True)


class Checked(click.ParamType[Any, Any]):
    """An option type checked by a :mod:`placement.maps.buildspec` validator (same rules as in spec files)."""

    def __init__(self, name: str, check: Callable[[Any, str], Any]) -> None:
        self.name = name
        self.check = check

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        try:
            return self.check(value, param.opts[-1] if param else self.name)
        except PlacementError as exc:
            raise OneLineError(str(exc)) from None
