"""Pure numba kernels: arrays in, arrays out. Nothing here knows about robots or files.

Compiled kernels are cached on disk. numba invalidates a cached function only
when its own source file changes, not when a kernel it calls in another file
does, so the cache lives in a directory named after a hash of all kernel
sources: any change to any kernel starts a fresh cache.
"""

import hashlib
import os
import sys
from pathlib import Path

import numba


def _cache_base() -> str:
    """Where compiled kernels live: ``NUMBA_CACHE_DIR`` if set, else ``<venv>/numba-cache`` inside a
    virtual environment (where ``make install`` compiles them, so every entry point of the environment
    finds them), else ``~/.cache/placement/numba``. Read only: the environment is not changed."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    if sys.prefix != sys.base_prefix:
        return os.path.join(sys.prefix, "numba-cache")
    return str(Path.home() / ".cache" / "placement" / "numba")


def _cache_dir() -> str:
    digest = hashlib.sha256()
    for f in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(f.read_bytes())
    base = _cache_base()
    return str(Path(base) / f"kernels-{digest.hexdigest()[:12]}-numba{numba.__version__}")


numba.config.CACHE_DIR = _cache_dir()  # type: ignore[attr-defined]  # numba.config sets its names at run time
