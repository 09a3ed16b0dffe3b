"""Output directories checked before the work that fills them starts, and files written into them whole
(:func:`atomic_path`, :func:`write_text_atomic`)."""

from __future__ import annotations

import contextlib
import os
import secrets
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


@contextlib.contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """A fresh temporary file beside ``path`` for the block to write; moved onto ``path`` (``os.replace``) when
    the block succeeds, removed when it fails.

    So a reader never sees half a file, and a write that fails (an error, a full disk, an interrupt) leaves
    the previous ``path``, if any, as it was. The temporary file is in the same directory (``os.replace`` is
    atomic only within one file system) and ends in ``path``'s suffix, for writers that choose the format
    by the suffix (matplotlib's ``savefig``); it is created with the default permissions (the umask's), as
    ``open(path, "w")`` would.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp{path.suffix}")
    os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text_atomic(path: Path | str, text: str, newline: str | None = None) -> None:
    """Write ``text`` to ``path`` whole or not at all (see :func:`atomic_path`); ``newline`` as for
    :func:`open` ("" writes line ends untranslated, as the csv module wants)."""
    with atomic_path(path) as tmp, open(tmp, "w", newline=newline) as fh:
        fh.write(text)
