"""Pure numba kernels: arrays in, arrays out. Nothing here knows about robots or files.

Compiled kernels are cached on disk. numba invalidates a cached function only
when its own source file changes, not when a kernel it calls in another file
does, so the cache lives in a directory named after a hash of all kernel
sources: any change to any kernel starts a fresh cache.
"""

import hashlib
import os
from pathlib import Path

import numba

# numba's OpenMP threading layer (GNU libgomp) spins while it waits for work by default. With another
# process on the cores (a map build, a test suite, a browser) a parallel inverse map then took 4-8x
# longer than on one thread; waiting passively costs a wake-up per parallel region and nothing under
# load. libgomp reads the variable when it loads, at the first parallel kernel; a value set by the
# user is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def _cache_dir() -> str:
    digest = hashlib.sha256()
    for f in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(f.read_bytes())
    base = os.environ.get("NUMBA_CACHE_DIR") or str(Path.home() / ".cache" / "placement" / "numba")
    return str(Path(base) / f"kernels-{digest.hexdigest()[:12]}-numba{numba.__version__}")


numba.config.CACHE_DIR = _cache_dir()  # type: ignore[attr-defined]  # numba.config sets its names at run time
