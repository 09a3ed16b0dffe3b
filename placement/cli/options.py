"""Options shared by the commands, and the one-line error contract."""

from __future__ import annotations

import functools
import logging
import re
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO, TypeVar

import click

from placement.errors import PlacementError
from placement.method_names import DEFAULT_METHOD
from placement.method_names import METHOD_NAMES as METHODS
from placement.validation import one_line, strict_json

log = logging.getLogger("placement")

#: a command function (or one already decorated)
F = TypeVar("F", bound=Callable[..., Any])


def robot_option(f: F) -> F:
    return click.option(
        "--robot", default=None, metavar="PRESET", help="Built-in preset name (pr2) or path to a robot YAML."
    )(f)


def arm_option(f: F) -> F:
    return click.option("--arm", default=None, metavar="ARM", help="One arm only (default: all arms).")(f)


def scene_argument(f: F) -> F:
    """SCENE: a scene file that exists (click names it when it does not)."""
    return click.argument("scene", type=click.Path(exists=True, dir_okay=False))(f)


def map_argument(f: F) -> F:
    """PATH: built maps that exist, a Zarr folder or an HDF5 file."""
    return click.argument("path", type=click.Path(exists=True))(f)


def maps_option(f: F) -> F:
    """``--maps PATH``: the built maps a scene is planned with, instead of the scene's own ``maps``."""
    return click.option(
        "--maps",
        "maps_path",
        default=None,
        metavar="PATH",
        type=click.Path(exists=True),
        help="Reachability maps, a Zarr folder or an HDF5 file (default: the scene's `maps`).",
    )(f)


def method_option(f: F) -> F:
    """``--method``: one planning method (the default's name shown)."""
    return click.option("--method", type=click.Choice(METHODS), default=DEFAULT_METHOD, show_default=True)(f)


def samples_option(kind: click.ParamType[Any, Any], default: int | None, what: str) -> Callable[[F], F]:
    """``--samples N``: how many random draws a command makes (``kind`` bounds it; ``what`` says of what)."""

    def decorate(f: F) -> F:
        return click.option("--samples", type=kind, default=default, help=what)(f)

    return decorate


def out_option(what: str, required: bool = False) -> Callable[[F], F]:
    """``--out PATH``: where a command writes (``what`` says what; created and checked before work)."""

    def decorate(f: F) -> F:
        return click.option("--out", "out", required=required, default=None, type=click.Path(), help=what)(f)

    return decorate


def json_option(f: F) -> F:
    return click.option("--json", "as_json", is_flag=True, help="Print one JSON document on stdout.")(f)


def verbosity(f: F) -> F:
    f = click.option("-v", "--verbose", count=True, help="More logging on stderr (-vv: tracebacks).")(f)
    f = click.option("-q", "--quiet", is_flag=True, help="No progress bars or logs.")(f)
    return f


def setup_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else (logging.DEBUG if verbose > 1 else logging.INFO)
    logging.basicConfig(stream=sys.stderr, level=level, format="%(message)s")
    warnings.showwarning = _one_line_warning


def _one_line_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """Python warnings (a robot without collision meshes, ...) as one ``warning:`` line on stderr,
    without the source line a user cannot act on."""
    print(one_line(f"warning: {message}"), file=sys.stderr)


def to_json_line(data: Any) -> str:
    """``data`` as one line of strict JSON (PlacementError if it holds NaN or inf)."""
    return strict_json(data, PlacementError, None)


def emit(data: Any, as_json: bool, render: Callable[[Any], str]) -> None:
    """Strict JSON on stdout, or a human-readable rendering."""
    click.echo(strict_json(data, PlacementError, 2) if as_json else render(data))


def writable_dir(path: str | Path, option: str) -> Path:
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


#: An echoed user value (a key, a name, a string) longer than this [characters] is cut in a message,
#: with its length said.
ECHO_CHARS = 80

#: No error message is longer than this [characters]: beyond it, runs without spaces longer than
#: :data:`ECHO_CHARS` are cut, then the message itself.
MESSAGE_CHARS = 2000

_LONG_RUN = re.compile(rf"\S{{{ECHO_CHARS + 1},}}")


def writable_file(path: str | Path, option: str) -> Path:
    """Prove that file ``path`` can be written (its folder exists and takes a file; a folder of that
    name is refused) before any long work starts; PlacementError naming ``option`` otherwise."""
    p = Path(path)
    if p.is_dir():
        raise PlacementError(f"{option} {path}: is a folder, expected a file name")
    folder = p.parent
    if not folder.is_dir():
        raise PlacementError(f"{option} {path}: the folder {folder} does not exist")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise PlacementError(f"{option} {path}: cannot write there ({exc.strerror or exc})") from None
    return p


def cut(text: str) -> str:
    """``text`` if it is at most :data:`ECHO_CHARS` long, else its start and its length in characters."""
    if len(text) <= ECHO_CHARS:
        return text
    return f"{text[: ECHO_CHARS - 20]}... ({len(text):,} characters)"


def long_strings(data: Any, limit: int = ECHO_CHARS) -> list[str]:
    """The distinct strings (mapping keys included) longer than ``limit`` anywhere in the parsed JSON or
    YAML ``data``, longest first (walked without recursion: any depth)."""
    found: set[str] = set()
    todo = [data]
    while todo:
        v = todo.pop()
        if isinstance(v, str):
            if len(v) > limit:
                found.add(v)
        elif isinstance(v, dict):
            todo.extend(v.keys())
            todo.extend(v.values())
        elif isinstance(v, (list, tuple)):
            todo.extend(v)
    return sorted(found, key=len, reverse=True)


def bounded(message: str, data: Any = None) -> str:
    """``message`` with what it echoes bounded: every long string of ``data`` (the input it is about:
    a key or value of 100 MB) quoted in it is cut to its start and its length (see :func:`cut`); then a
    message still over :data:`MESSAGE_CHARS` has its long runs without spaces cut, and is cut itself."""
    for v in long_strings(data) if data is not None else ():
        for form in dict.fromkeys((v, one_line(v))):
            if form in message:
                message = message.replace(form, cut(form))
    if len(message) > MESSAGE_CHARS:
        message = _LONG_RUN.sub(lambda m: cut(m.group()), message)
    if len(message) > MESSAGE_CHARS:
        message = f"{message[:MESSAGE_CHARS]}... (message cut: {len(message):,} characters)"
    return message


def out_of_memory_hint() -> str:
    """What to say when the running command ran out of memory: the options of its own that shrink
    the work, else that the input is too large for this machine."""
    ctx = click.get_current_context(silent=True)
    names = {p.name for p in ctx.command.params} if ctx is not None else set()
    command = ctx.command_path if ctx is not None else "the command"
    shrink = [
        opt for name, opt in (("resolution", "a coarser --resolution"), ("samples", "fewer --samples")) if name in names
    ]
    if shrink:
        return f"out of memory; use {' or '.join(shrink)}"
    return f"out of memory in {command}: the input is too large for this machine's memory"


def one_line_errors(f: Callable[..., Any]) -> Callable[..., Any]:
    """Turn package errors into `error: ...` on stderr and exit code 2, never a traceback."""

    @functools.wraps(f)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        verbose = kwargs.get("verbose", 0)
        try:
            return f(*args, **kwargs)
        except (PlacementError, OSError) as exc:  # OSError: a file system error after the up-front checks
            if verbose > 1:
                raise
            text = str(exc)
            if isinstance(exc, OSError):
                text = f"{exc.filename}: {exc.strerror or exc}" if exc.filename else (exc.strerror or str(exc))
            click.echo(f"error: {bounded(one_line(text))}", err=True)
            sys.exit(2)
        except KeyboardInterrupt:
            click.echo("interrupted; nothing was written", err=True)
            sys.exit(130)
        except MemoryError:
            click.echo(f"error: {out_of_memory_hint()}", err=True)
            sys.exit(2)

    return wrapper


def standard_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--json``, ``-v``/``-q`` and the one-line error contract: what every command takes."""
    return json_option(verbosity(one_line_errors(f)))
