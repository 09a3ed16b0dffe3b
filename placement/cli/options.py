"""Options shared by the commands, and the one-line error contract."""

from __future__ import annotations

import functools
import json
import logging
import sys

import click

from ..errors import PlacementError

log = logging.getLogger("placement")


def robot_option(f):
    return click.option("--robot", default=None, metavar="PRESET",
                        help="Built-in preset name (pr2) or path to a robot YAML.")(f)


def arm_option(f):
    return click.option("--arm", default=None, metavar="ARM", help="One arm only (default: all arms).")(f)


def json_option(f):
    return click.option("--json", "as_json", is_flag=True, help="Print one JSON document on stdout.")(f)


def verbosity(f):
    f = click.option("-v", "--verbose", count=True, help="More logging on stderr (-vv: tracebacks).")(f)
    f = click.option("-q", "--quiet", is_flag=True, help="No progress bars or logs.")(f)
    return f


def setup_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else (logging.DEBUG if verbose > 1 else logging.INFO)
    logging.basicConfig(stream=sys.stderr, level=level, format="%(message)s")


def emit(data, as_json: bool, render) -> None:
    """JSON on stdout, or a human-readable rendering."""
    if as_json:
        click.echo(json.dumps(data, indent=2, sort_keys=False))
    else:
        click.echo(render(data))


def one_line_errors(f):
    """Turn package errors into `error: ...` on stderr and exit code 2, never a traceback."""

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        verbose = kwargs.get("verbose", 0)
        try:
            return f(*args, **kwargs)
        except PlacementError as exc:
            if verbose > 1:
                raise
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
        except KeyboardInterrupt:
            click.echo("interrupted; nothing was written", err=True)
            sys.exit(130)
        except MemoryError:
            click.echo("error: out of memory; use a coarser --resolution or fewer --samples", err=True)
            sys.exit(2)

    return wrapper
