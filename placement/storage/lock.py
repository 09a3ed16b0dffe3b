"""Advisory locks beside a map (fcntl.flock on hidden files), so that concurrent writers cannot clobber it.

A lock file is created beside the map, locked, checked to still be the file at that path (a
holder that released it unlinks it first), and unlinked by its holder on release: no lock files
stay behind after a normal exit, and one left by a killed process is unlocked (the kernel drops
an flock with its holder) and simply taken over.
"""

from __future__ import annotations

import errno
import fcntl
import os
import time
from pathlib import Path

from placement.errors import MapError


def lock_path(target: Path, what: str) -> Path:
    """The lock file ``what`` of the map at ``target``: a hidden sibling."""
    return target.with_name(f".{target.name}.{what}.lock")


class FileLock:
    """An exclusive flock on ``path``; ``holder`` is written into the file for the error of a second comer."""

    def __init__(self, path: Path | str, holder: str) -> None:
        self.path = Path(path)
        self.holder = holder
        self.fd: int | None = None

    def acquire(self, wait_s: float = 0.0) -> FileLock:
        """Take the lock, waiting up to ``wait_s`` seconds for another holder; MapError naming it if still held."""
        deadline = time.monotonic() + wait_s
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                other = _text(fd)
                os.close(fd)
                if exc.errno not in (errno.EAGAIN, errno.EACCES):
                    raise
                if time.monotonic() >= deadline:
                    raise MapError(f"{other or 'another process'} holds {self.path}") from None
                time.sleep(0.05)
                continue
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)  # the previous holder unlinked it after we opened it: take the new file
        os.ftruncate(fd, 0)
        os.write(fd, self.holder.encode())
        self.fd = fd
        return self

    def release(self) -> None:
        if self.fd is not None:
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
            os.close(self.fd)
            self.fd = None

    def __enter__(self) -> FileLock:
        return self if self.fd is not None else self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def _text(fd: int) -> str:
    try:
        return os.pread(fd, 200, 0).decode(errors="replace").strip()
    except OSError:
        return ""
