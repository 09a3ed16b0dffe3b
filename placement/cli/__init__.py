"""The `placement` command line (click). Nothing in the package imports this."""

import time
from collections.abc import Callable
from typing import Any, NoReturn

#: ``time.perf_counter()`` when the command line was first imported: a query's time budget counts from
#: it (the imports, the scene, robot and maps too), see :func:`spent_s`
STARTED = time.perf_counter()


#: [s] of a query's time budget kept for what comes before :data:`STARTED` (the interpreter's start)
#: and after the plan (writing the answer): about what they took on the 2-core development machine
RESERVE_S = 0.25


def spent_s() -> float:
    """Seconds [s] of a task's time budget this command has spent so far: since it started, less
    compiling kernels on a cold cache (paid once per install, see :func:`placement.process_env.compile_seconds`),
    plus :data:`RESERVE_S`: the answer is out within the budget."""
    from placement.process_env import compile_seconds

    return time.perf_counter() - STARTED - compile_seconds() + RESERVE_S


def run_then_exit(command: Callable[..., Any], **kwargs: Any) -> NoReturn:
    """Run a click ``command`` as a console script does, then end the process without the
    interpreter's teardown (its exit handlers run, its output is flushed): tearing down the compiled
    libraries took 0.4 s after every query, past the answer and past a task's time budget. For
    commands that write their files explicitly (closed, renamed into place), never for map builds."""
    import atexit
    import os
    import sys

    try:
        command(**kwargs)
        code = 0
    except SystemExit as stop:
        if stop.code is None or isinstance(stop.code, int):
            code = stop.code or 0
        else:  # sys.exit("message"): the message on stderr, status 1, as Python does
            print(stop.code, file=sys.stderr)
            code = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more to say
            pass
    os._exit(code)
