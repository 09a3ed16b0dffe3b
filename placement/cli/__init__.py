"""The `placement` command line (click). Nothing in the package imports this."""

import atexit
import os
import sys
import time
from collections.abc import Callable
from typing import Any, NoReturn

#: ``time.perf_counter()`` when the command line was first imported: a console script's query counts
#: its time budget from it (the imports, the scene, robot and maps too), see :func:`spent_s`
STARTED = time.perf_counter()
#: [s] of a query's time budget kept for what comes before :data:`STARTED` (the interpreter's start)
#: and after the plan (writing the answer): about what they took on the 2-core development machine
RESERVE_S = 0.25
#: the status a console script ends with once it has answered (see :func:`run_then_exit`)
_EXIT: list[int] = []
#: whether this process is a console script of the command line (:func:`run_then_exit` sets it)
_SCRIPT: list[bool] = []


def spent_s(began: float, compiled: float) -> float:
    """Seconds [s] of a task's time budget a query has spent so far: since the console script started
    (:data:`STARTED`; for a command run inside another program, since ``began``, its own
    ``time.perf_counter()`` at its start), less the kernels compiled on a cold cache since then (paid
    once per install, see :func:`placement.compile_clock.compile_seconds`, which was ``compiled`` at
    ``began``), plus :data:`RESERVE_S`: the answer is out within the budget."""
    from placement.compile_clock import compile_seconds

    start, before = (STARTED, 0.0) if _SCRIPT else (began, compiled)
    return time.perf_counter() - start - (compile_seconds() - before) + RESERVE_S


def run_then_exit(command: Callable[..., Any], **kwargs: Any) -> NoReturn:
    """Run a click ``command`` as its console script, then end the process without the interpreter's
    teardown (the exit handlers run, the output is flushed): tearing down the compiled libraries took
    0.4 s after every query, past the answer and past a task's time budget. For commands that write
    their files explicitly (closed, renamed into place), never for map builds."""
    _SCRIPT.append(True)
    try:
        command(**kwargs)
        code = 0
    except SystemExit as stop:
        if stop.code is None or isinstance(stop.code, int):
            code = stop.code or 0
        else:  # sys.exit("message"): the message on stderr, status 1, as Python does
            print(stop.code, file=sys.stderr)
            code = 1
    _EXIT.append(code)
    raise SystemExit(code)


def _end_now() -> None:
    # registered when the command line is first imported, before the libraries it loads register
    # theirs: exit handlers run last-registered first, so this one runs after them all
    if _EXIT:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe: nothing more to say
                pass
        os._exit(_EXIT[0])


atexit.register(_end_now)
