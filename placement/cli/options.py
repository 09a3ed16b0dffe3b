"""Options shared by the commands, and the one-line error contract."""

from __future__ import annotations

import functools
import json
import logging
import sys
import tempfile
import warnings
from pathlib import Path

import click

from ..errors import PlacementError
from ..validation import one_line

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
    warnings.showwarning = _one_line_warning


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Python warnings (a robot without collision meshes, ...) as one ``warning:`` line on stderr,
    without the source line a user cannot act on."""
    print(one_line(f"warning: {message}"), file=sys.stderr)


def _json(data, indent) -> str:
    try:
        return json.dumps(data, indent=indent, sort_keys=False, allow_nan=False)
    except ValueError:  # NaN or inf: JSON has no such numbers, and they would mean a silent wrong answer
        raise PlacementError("the result holds a non-finite number (NaN or inf); refusing to print invalid "
                             "JSON") from None


def to_json_line(data) -> str:
    """``data`` as one line of strict JSON (PlacementError if it holds NaN or inf)."""
    return _json(data, None)


def emit(data, as_json: bool, render) -> None:
    """Strict JSON on stdout, or a human-readable rendering."""
    click.echo(_json(data, 2) if as_json else render(data))


def writable_dir(path, option: str) -> Path:
    """Create directory ``path`` (and parents) and prove it writable before any long work starts.

    PlacementError naming ``option`` if it is below a file, read-only or otherwise unusable.
    """
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=p):
            pass
    except OSError as exc:
        raise PlacementError(f"{option} {path}: cannot write there ({exc.strerror or exc})") from None
    return p


def one_line_errors(f):
    """Turn package errors into `error: ...` on stderr and exit code 2, never a traceback."""

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        verbose = kwargs.get("verbose", 0)
        try:
            return f(*args, **kwargs)
        except (PlacementError, OSError) as exc:  # OSError: a file system error after the up-front checks
            if verbose > 1:
                raise
            if isinstance(exc, OSError):
                exc = f"{exc.filename}: {exc.strerror or exc}" if exc.filename else (exc.strerror or str(exc))
            click.echo(f"error: {one_line(str(exc))}", err=True)
            sys.exit(2)
        except KeyboardInterrupt:
            click.echo("interrupted; nothing was written", err=True)
            sys.exit(130)
        except MemoryError:
            click.echo("error: out of memory; use a coarser --resolution or fewer --samples", err=True)
            sys.exit(2)

    return wrapper


def standard_options(f):
    """``--json``, ``-v``/``-q`` and the one-line error contract: what every command takes."""
    return json_option(verbosity(one_line_errors(f)))
