"""The process environment the compiled kernels want, set where a process starts, never on import.

Importing :mod:`placement` changes no environment variable. The entry points (the ``placement``
command, ``python -m placement.warmup``, the Dask tasks of a distributed build or evaluation, the
``make`` targets, the test suite) set it first; a library user may call :func:`configure_process`
too, before the first parallel kernel.
"""

from __future__ import annotations

import os

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
