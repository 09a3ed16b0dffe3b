"""How long this process has spent compiling numba kernels: on a cold cache (the first run after an
install or a kernel change) tens of seconds, which a task's time budget leaves out (paid once, not per
plan; :mod:`placement.warmup` says when it happens)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import cast

from numba.core import event


class CompileClock(event.Listener):
    """A ``numba:compile`` listener adding up the wall time [s] of the outermost compilations (a
    kernel's compilation compiles the kernels it calls within it)."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.depth = 0
        self.began = 0.0

    def on_start(self, ev: event.Event) -> None:
        if self.depth == 0:
            self.began = time.perf_counter()
        self.depth += 1

    def on_end(self, ev: event.Event) -> None:
        self.depth = max(self.depth - 1, 0)
        if self.depth == 0:
            self.seconds += time.perf_counter() - self.began


CLOCK = CompileClock()
_listening: list[bool] = []


def compile_seconds() -> float:
    """Seconds [s] this process has spent compiling kernels since it first asked."""
    if not _listening:
        _listening.append(True)
        # (numba leaves event.register unannotated)
        cast("Callable[[str, event.Listener], None]", event.register)("numba:compile", CLOCK)
    return CLOCK.seconds
