"""The process environment the compiled kernels want, set where a process starts, never on import.

Importing :mod:`placement` changes no environment variable. The entry points (the ``placement``
command, ``python -m placement.warmup``, the Dask tasks of a distributed build or evaluation, the
``make`` targets, the test suite) set it first; a library user may call :func:`configure_process`
too, before the first parallel kernel.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any, cast

#: variable -> value set when the user has not set one
DEFAULTS = {
    # numba's OpenMP threading layer (GNU libgomp) spins while it waits for work by default. With
    # another process on the cores (a map build, a test suite, a browser) a parallel inverse map then
    # took 4-8x longer than on one thread; waiting passively costs a wake-up per parallel region and
    # nothing under load. libgomp reads it once, when it loads (at the first parallel kernel).
    "OMP_WAIT_POLICY": "PASSIVE"
}


def configure_process() -> None:
    """Set :data:`DEFAULTS` in ``os.environ`` where the user has not set them (idempotent)."""
    for name, value in DEFAULTS.items():
        os.environ.setdefault(name, value)


class _CompileClock:
    """Adds up the wall time [s] numba spends compiling (outermost compilations only: a kernel's
    compilation compiles the kernels it calls within it); a ``numba:compile`` event listener."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.depth = 0
        self.began = 0.0
        self.listener: Any = None

    def start(self) -> None:
        if self.listener is not None:
            return
        from numba.core import event

        clock = self

        class Listener(event.Listener):
            def on_start(self, ev: event.Event) -> None:
                if clock.depth == 0:
                    clock.began = time.perf_counter()
                clock.depth += 1

            def on_end(self, ev: event.Event) -> None:
                clock.depth = max(clock.depth - 1, 0)
                if clock.depth == 0:
                    clock.seconds += time.perf_counter() - clock.began

        self.listener = Listener()
        # (numba leaves event.register unannotated)
        cast("Callable[[str, event.Listener], None]", event.register)("numba:compile", self.listener)


_CLOCK = _CompileClock()


def compile_seconds() -> float:
    """Seconds [s] this process has spent compiling kernels since it first asked (a cold cache: the
    first run after an install or a kernel change). A task's time budget leaves them out: they are
    paid once, not per plan."""
    _CLOCK.start()
    return _CLOCK.seconds
