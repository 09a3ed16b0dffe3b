"""Bounded reads of map files: only regular files of a sane size are ever opened.

A map is a tree of files anyone may have replaced: a chunk by a FIFO (an open()
for reading blocks until a writer comes, forever), ``zarr.json`` by a link to
``/dev/zero`` (endless) or to a huge file. Every file of a map is therefore
``stat``-ed first (following links, so a link loop or a dangling link is an
error too) and opened only if it is a regular file no larger than the bound
its role allows; it is opened non-blocking, checked again on the descriptor
(a file swapped in between), and read at most to that bound.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

#: metadata documents (zarr.json of the group and of every array) [bytes]; a 5 cm PR2 arm's holds ~0.2 MB
META_LIMIT = 64 << 20

_KINDS = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


class FileRefused(OSError):
    """A map file that is not a regular file of a sane size (the message says which and why)."""


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def _check(st: os.stat_result, path: str | Path, limit: int) -> None:
    if not stat.S_ISREG(st.st_mode):
        raise FileRefused(f"{path} is {_kind(st.st_mode)}, not a regular file; refusing to read it")
    if st.st_size > limit:
        raise FileRefused(
            f"{path} has {st.st_size} bytes, more than the {limit} a map file of its kind can hold; refusing to read it"
        )


def regular_size(path: str | Path, limit: int) -> int:
    """The size of ``path`` [bytes] if it is a regular file (after links) of at most ``limit`` bytes.

    Raises FileNotFoundError if it does not exist, :class:`FileRefused` if it is anything else
    (FIFO, device, socket, directory, too large), OSError for a link loop and the like.
    """
    path = Path(path)
    st = os.stat(path)
    _check(st, path, limit)
    return st.st_size


def read_head(path: str | Path, n: int, limit: int) -> bytes:
    """The first ``n`` bytes of ``path``, a regular file of at most ``limit`` bytes (see :func:`regular_size`)."""
    return _read(path, limit, n)


def read_bounded(path: str | Path, limit: int) -> bytes:
    """The bytes of ``path``, a regular file of at most ``limit`` bytes (see :func:`regular_size`)."""
    data = _read(path, limit, limit + 1)
    if len(data) > limit:
        raise FileRefused(f"{path} grew beyond {limit} bytes while being read; refusing it")
    return data


def _read(path: str | Path, limit: int, n: int) -> bytes:
    _check(os.stat(path), path, limit)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)  # never blocks, even if swapped for a FIFO
    try:
        st = os.fstat(fd)
        _check(st, path, limit)
        want = min(n, st.st_size + 1)  # +1: sees a file that grew
        parts = []
        while want > 0:
            part = os.read(fd, want)
            if not part:
                break
            parts.append(part)
            want -= len(part)
        return parts[0] if len(parts) == 1 else b"".join(parts)
    finally:
        os.close(fd)
