"""How the benchmark tools write the tables the documentation includes (docs/bench/*.md).

The pages include these files verbatim (pymdownx.snippets), so a file is replaced whole: written to a
temporary file in the same directory, then renamed over the old one with os.replace. A reader, or a
docs build running meanwhile, sees the old table or the new one, never half of one; an interrupted
benchmark leaves the old table.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path


def write_atomic(path: Path, text: str) -> None:
    """Replace ``path`` by a file holding ``text`` (UTF-8), atomically."""
    write_file_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_file_atomic(path: Path, write: Callable[[Path], object]) -> None:
    """Call ``write(tmp)`` on a temporary path beside ``path``, then rename it to ``path``.

    For writers that take a path (matplotlib's ``savefig``); the temporary file is removed if
    ``write`` fails.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        write(tmp)
        os.chmod(tmp, 0o644)  # mkstemp's 0600 would make the table private to this user
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
