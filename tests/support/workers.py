"""Work the pytest-xdist workers of one run share: a directory built once per run, not once per worker.

``-n 2`` starts two worker processes; each has its own session, so a session fixture runs in both. The
PR2 planning maps (about 20 s of CPU) are built by the first worker that asks and read by the other.
(Module fixtures are set up once because ``--dist loadfile``, in pyproject.toml, keeps a file on one
worker.)
"""

from __future__ import annotations

import fcntl
import os
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest


def run_dir(tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> Path:
    """The temporary directory every worker of this run sees: the parent of a worker's own base
    directory (``<run>/popen-gw0``), or the session's when there are no workers."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if worker_id != "master" else base


@contextmanager
def locked(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on the file ``path`` (created if missing) across processes."""
    with open(path, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def built_once(root: Path, name: str, build: Callable[[Path], object]) -> Path:
    """The directory ``root/name``, filled by ``build(directory)`` in the first worker that asks; the
    others wait for it and reuse it. Filled under a temporary name and renamed when done, so a build that
    failed leaves nothing a later caller would take for a finished one."""
    done = root / name
    with locked(root / f"{name}.lock"):
        if not done.exists():
            partial = root / f"{name}.partial-{os.getpid()}"
            shutil.rmtree(partial, ignore_errors=True)
            partial.mkdir(parents=True)
            build(partial)
            os.rename(partial, done)
        return done
