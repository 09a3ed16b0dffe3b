"""Output directories checked before the work that fills them starts."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from placement.errors import PlacementError


def _missing(path: Path) -> list[Path]:
    """The directories ``path.mkdir(parents=True)`` would create, deepest first."""
    out: list[Path] = []
    p = Path(os.path.abspath(path))
    while not os.path.lexists(p) and p != p.parent:
        out.append(p)
        p = p.parent
    return out


def _remove_empty(dirs: list[Path]) -> None:
    for d in dirs:  # deepest first; a directory someone filled meanwhile stays
        with contextlib.suppress(OSError):
            d.rmdir()


def prepare_output_dir(path: Path | str, what: str) -> list[Path]:
    """Create ``path`` and write and delete a probe file in it; returns the directories created.

    ``what`` names the option or argument in the error ("--out", "OUT_DIR"). Raises
    :class:`PlacementError` (one line) when ``path`` is a file, lies below a file, or cannot be
    created or written; nothing is left behind then.
    """
    path = Path(path)
    created = _missing(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise PlacementError(f"{what} {path}: exists and is not a directory") from None
    except NotADirectoryError:
        blocker = next((p for p in reversed([path, *path.parents]) if p.is_file()), path)
        _remove_empty(created)
        raise PlacementError(f"{what} {path}: cannot create the directory, {blocker} is a file") from None
    except OSError as exc:
        _remove_empty(created)
        raise PlacementError(f"{what} {path}: cannot create the directory: {exc.strerror}") from None
    try:
        with tempfile.NamedTemporaryFile(dir=path, prefix=".placement-probe-"):
            pass
    except OSError as exc:
        _remove_empty(created)
        raise PlacementError(f"{what} {path}: cannot write there: {exc.strerror}") from None
    return created


@contextlib.contextmanager
def output_dir(path: Path | str, what: str) -> Iterator[Path]:
    """:func:`prepare_output_dir`, then run the block; if it fails, remove the directories created
    here that are still empty (so a failed run leaves no trace)."""
    created = prepare_output_dir(path, what)
    try:
        yield Path(path)
    except BaseException:
        _remove_empty(created)
        raise
