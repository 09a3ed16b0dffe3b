"""Advisory locks beside a map (fcntl.flock on hidden files), so that concurrent writers cannot clobber it.

A lock file is created beside the map, locked, checked to still be the file at that path (a
holder that released it unlinks it first), and unlinked by its holder on release: no lock files
stay behind after a normal exit, and one left by a killed process is unlocked (the kernel drops
an flock with its holder) and taken over, which is said on the ``placement`` logger. A wait for a
live holder is said too: once after a second, naming the holder, then every :data:`WAIT_NOTE_S`.
"""

from __future__ import annotations

import errno
import fcntl
import logging
import os
import re
import time
from pathlib import Path

from placement.errors import MapError

log = logging.getLogger("placement")

#: [s] between the notes of a long wait for a lock
WAIT_NOTE_S = 30.0
#: [s] of waiting before the first note (a lock released at once is not worth a line)
FIRST_NOTE_S = 1.0


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
        """Take the lock, waiting up to ``wait_s`` seconds for another holder (said on the log, naming
        it); MapError naming it if still held."""
        start = time.monotonic()
        deadline = start + wait_s
        next_note = start + FIRST_NOTE_S
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                other = _text(fd)
                os.close(fd)
                if exc.errno not in (errno.EAGAIN, errno.EACCES):
                    raise
                now = time.monotonic()
                if now >= deadline:
                    waited = f" (waited {now - start:.0f} s)" if wait_s >= FIRST_NOTE_S else ""
                    raise MapError(f"{other or 'another process'} holds {self.path}{waited}") from None
                if now >= next_note:
                    log.info(
                        "waiting for %s to release %s (%.0f s so far, at most %.0f s)",
                        other or "another process",
                        self.path,
                        now - start,
                        wait_s,
                    )
                    next_note = now + WAIT_NOTE_S
                time.sleep(0.05)
                continue
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)  # the previous holder unlinked it after we opened it: take the new file
        left = _text(fd)
        if left:  # a holder that releases unlinks the file: text in it is a killed holder's
            log.warning("took over %s, left by %s, which ended without releasing it", self.path, left)
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


def holder_pid(text: str) -> int | None:
    """The process id a lock's holder text names (``... (pid 123)``), if any."""
    m = re.search(r"\(pid (\d+)\)", text)
    return int(m.group(1)) if m else None
