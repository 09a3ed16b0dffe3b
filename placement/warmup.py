"""Compiling the numba kernels ahead of use, and saying so when a command has to.

The kernels are cached on disk (see :mod:`placement.kernels`), but a cold cache
(a fresh install, or any kernel source changed) makes the first map build and the
first query compile for tens of seconds before they do anything visible.

* :func:`announce_compilation` logs "compiling kernels (first run only, about N s)"
  once, just before the first kernel compiles. It listens to numba's
  ``numba:compile`` event, which numba fires only after its disk cache missed; so it
  costs nothing and stays silent when every kernel comes from the cache (no guessing
  from the cache files' names).
* ``python -m placement.warmup`` (run by ``make install``) compiles every kernel the
  package calls from Python by running the real entry points on tiny inputs (a map
  build, with and without the self-collision options; zarr and HDF5 maps; every
  planning method on scenes with and without obstacles; the map accuracy check), and
  names any such kernel that still has no compiled version.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import cast

from numba.core import event
from numba.core.registry import CPUDispatcher

from placement.process_env import configure_process

log = logging.getLogger("placement")

# Cold-cache compile times [s] on the 2-core development machine: the stage times `python -m
# placement.warmup` printed with an empty NUMBA_CACHE_DIR while a test run shared the cores (103 s for
# the build kernels, 26 s for the query ones, each including a few seconds of tiny real work).
BUILD_COMPILE_S = 100
QUERY_COMPILE_S = 25


class CompileNotice(event.Listener):
    """Logs the notice at the start of the first compilation it hears of, then stays quiet."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.told = False
        self.listening = False

    def on_start(self, ev: event.Event) -> None:
        if not self.told:
            self.told = True
            log.info("compiling kernels (first run only, about %.0f s)", self.seconds)

    def on_end(self, ev: event.Event) -> None:
        pass


NOTICE = CompileNotice()


def announce_compilation(seconds: float) -> None:
    """Log the compile notice (with ``seconds`` [s] as its estimate) before the next kernel
    compilation in this process, at most once per process."""
    NOTICE.seconds = float(seconds)
    if not NOTICE.listening:
        NOTICE.listening = True
        # (numba leaves event.register unannotated)
        cast("Callable[[str, event.Listener], None]", event.register)("numba:compile", NOTICE)


def kernel_dispatchers() -> dict[str, CPUDispatcher]:
    """The numba kernels the rest of the package calls from Python, by qualified name.

    Only these compile (or load from the cache) on their own: a kernel called from another
    kernel is compiled into its caller and cached with it, so its own dispatcher stays empty
    when the caller comes from the cache.
    """
    import ast

    root = Path(__file__).resolve().parent
    names = set()
    for path in root.rglob("*.py"):
        rel = path.relative_to(root.parent).with_suffix("").parts
        if "kernels" in rel:
            continue
        package = rel if path.name == "__init__.py" else rel[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = list(package[: len(package) - node.level + 1]) if node.level else []
                module = ".".join(base + ([node.module] if node.module else []))
                if module.startswith("placement.kernels."):
                    names |= {f"{module}.{alias.name}" for alias in node.names}
    out = {}
    for name in sorted(names):
        module, attr = name.rsplit(".", 1)
        obj = getattr(importlib.import_module(module), attr, None)
        if isinstance(obj, CPUDispatcher):
            out[name] = obj
    return out


def uncompiled_kernels() -> list[str]:
    """Names of the kernels of :func:`kernel_dispatchers` with no compiled (or cache-loaded)
    version in this process."""
    return sorted(name for name, d in kernel_dispatchers().items() if not d.signatures)


def warm(work: Path, say: Callable[[str], object] = print) -> dict[str, float]:
    """Run every entry point that compiles kernels on tiny inputs in ``work`` (a directory);
    returns the seconds each stage took (its compile time when the cache is cold)."""
    import yaml

    from placement.evaluation.evaluate import evaluate_scene
    from placement.evaluation.generate import generate_scene
    from placement.kinematics.manipulability import extended_manipulability
    from placement.maps.accuracy import check_map
    from placement.maps.build import build_map
    from placement.maps.opening import open_map
    from placement.maps.rmap import save_maps
    from placement.planning import METHODS, Planner
    from placement.robots import load_robot

    robot = load_robot("pr2")
    times: dict[str, float] = {}
    t = time.perf_counter()
    # the maps of the test suite's planning tests: small, yet good enough that plans succeed
    maps = {
        arm: build_map(robot, arm, samples=200_000, seed=1, resolution=0.1, bins=(10, 5, 10), progress=False)
        for arm in robot.arms
    }
    build_map(robot, "right", samples=50, resolution=0.2, bins=(4, 3, 4), progress=False, self_collision=True)
    build_map(robot, "right", samples=5, resolution=0.2, bins=(4, 3, 4), progress=False, self_distance=True)
    times["maps build"] = time.perf_counter() - t
    say(f"maps build kernels: {times['maps build']:.1f} s")
    t = time.perf_counter()
    paths = {fmt: save_maps(work / f"pr2-{fmt}", robot, maps, fmt) for fmt in ("zarr", "hdf5")}
    scenes = []
    for k, obstacles in enumerate((False, True)):
        doc = generate_scene(1, k, objects=2, obstacles=obstacles, maps=str(paths["zarr"]))
        doc["planner"] = {"threshold": 0.01, "yaw_steps": 40}
        scenes.append(work / f"scene{k}.yaml")
        scenes[-1].write_text(yaml.safe_dump(doc))
        evaluate_scene(str(scenes[-1]), list(METHODS))
    Planner(scenes[0], "global", paths["hdf5"]).plan()
    rmap = open_map(paths["zarr"], "right", robot).load()
    check_map(robot, rmap, samples=3)
    rmap.polar_bound((0,), 0, 0)  # the kernel's skip table (made by the planner only for large steps)
    for index in ("isotropy", "volume"):
        extended_manipulability(robot, "right", robot.arm("right").home, index=index)
    rmap.value(robot.tcp_pose("right", robot.arm("right").home))
    rmap.yaw_bits((0,), 0, 0, 0.01)  # threshold passes of 32 candidates or more: none in the scenes above
    times["query"] = time.perf_counter() - t
    say(f"query kernels: {times['query']:.1f} s")
    return times


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m placement.warmup",
        description="Compile every numba kernel "
        "into the cache (NUMBA_CACHE_DIR), so that no command compiles on first use.",
    )
    ap.add_argument("-q", "--quiet", action="store_true", help="print nothing unless a kernel stays uncompiled")
    args = ap.parse_args(argv)
    configure_process()
    import numba

    import placement.kernels  # noqa: F401  (sets numba's cache directory)

    say: Callable[[str], None] = (lambda *a: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    # numba sets its config attributes at run time (from the environment): mypy cannot see them
    say(f"warming the numba cache in {numba.config.CACHE_DIR}")  # type: ignore[attr-defined]
    with tempfile.TemporaryDirectory() as tmp:
        warm(Path(tmp), say)
    missing = uncompiled_kernels()
    if missing:
        print(
            f"warning: not compiled by the warm-up (they will compile on first use): {', '.join(missing)}",
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
