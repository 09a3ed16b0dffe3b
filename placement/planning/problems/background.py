"""One background thread for the inverse-map kernel, so that a step's Python work overlaps the kernel.

Half the time of a step's options on a building map is Python (candidates, the gripper screen, the
kernel's arguments), which leaves a core idle; the kernel itself keeps both cores busy. A whole-task
program asks for every step's options before it solves: while the kernel runs for one step (released
from the GIL, in this thread), the next step's arguments are made (see
:meth:`~placement.planning.problems.StepProblems.prefetch`). The results are those of the same kernel
calls one after the other: each call writes only its own output arrays.

Only with a numba threading layer that takes parallel kernels from two threads at once (``omp``,
``tbb``); with ``workqueue``, or before numba has chosen a layer, every call runs where it is made.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numba

#: A call made in the background: wait for it (its exception, if any, is raised here).
Wait = Callable[[], None]

_POOL: list[ThreadPoolExecutor] = []
#: numba threading layers whose parallel kernels may be launched from two threads at once
_CONCURRENT_LAYERS = frozenset({"omp", "tbb"})


def concurrent() -> bool:
    """Whether kernel calls may run in the background (numba's threading layer allows it)."""
    try:
        return str(numba.threading_layer()) in _CONCURRENT_LAYERS  # type: ignore[attr-defined]
    except ValueError:  # no parallel kernel has run yet: no layer chosen
        return False


def behind(call: Callable[[], None], background: bool = True) -> Wait:
    """Start ``call`` in the background thread (when ``background`` and :func:`concurrent`), else run it
    now; returns the function that waits for it."""
    if not (background and concurrent()):
        call()
        return _done
    if not _POOL:
        _POOL.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="placement-kernel"))
    future = _POOL[0].submit(call)
    return lambda: future.result()


def _done() -> None:
    return None


# a forked child has none of the parent's threads: its pool is made anew (the parent's would wait forever)
if hasattr(os, "register_at_fork"):  # POSIX only; elsewhere nothing forks
    os.register_at_fork(after_in_child=_POOL.clear)


__all__ = ["Wait", "behind", "concurrent"]
