"""Planning on real building maps: every method on the tidy-up scenes of examples/buildings.

For each scene (a SLAM map as published, tables at its named locations; with the generated grasps,
``tidy_up.yaml``, and with a published grasp set, ``tidy_up_ycb.yaml``) and method: whether the whole
task planned (else the first failing step and its reason), the task time as `evaluate` counts it,
the planning time per placement (median of ``--runs`` fresh planners, the certificate's bound
excluded), how far the target sits off
the base's heading (median over the steps), and the plan's verification (FK, limits, transfers).

    python tools/bench_buildings.py [--maps maps/pr2] [--runs 3] [--methods global,sequential]

Writes the table to docs/bench/buildings.md (atomically), which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from placement.planning import facing  # noqa: E402

METHODS = ("global", "sequential", "single-step", "fixed")


def off_heading(step) -> float:
    """The angle [deg] between a planned step's base heading and its last TCP position."""
    return facing.off_heading(step.base, (float(step.tcp[-1][0, 3]), float(step.tcp[-1][1, 3])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="maps/pr2")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--out", default=str(ROOT / "docs/bench/buildings.md"))
    args = ap.parse_args()

    from placement.planning import Planner
    from placement.planning.task_time import task_time

    maps = str(Path(args.maps).resolve())
    methods = args.methods.split(",")
    scenes = sorted((ROOT / "examples/buildings").glob("*/tidy_up*.yaml"))
    rows = []
    for path in scenes:
        for m in methods:
            times, result, planner = [], None, None
            for _ in range(args.runs):
                planner = Planner(path, m, maps)
                t = time.perf_counter()
                result = planner.plan()
                # the certificate's bound excluded, as in bench_query and bench_optimum
                times.append((time.perf_counter() - t) * 1e3 - result.certificate.ms)
            assert result is not None and planner is not None
            steps = result.steps
            placed = [s for s in steps if s.status == "ok"]
            failed = result.failed_step
            tt = task_time(planner.robot, result, planner.scene.start) if result.ok else None
            problems = result.verify(planner.robot) if result.ok else []
            row = {
                "scene": path.parent.name
                + ("" if path.stem == "tidy_up" else f" ({path.stem.removeprefix('tidy_up_')})"),
                "method": m,
                "cells": "x".join(str(v) for v in planner.world.nav.shape),
                "planned": f"{len(placed)}/{len(planner.problems.steps)}",
                "task_s": f"{tt['total_s']:.1f}" if tt else "-",
                "ms": f"{statistics.median(times) / len(planner.problems.steps):.0f}",
                "off": f"{statistics.median(off_heading(s) for s in placed):.0f}" if placed else "-",
                "verify": "ok" if result.ok and not problems else (problems[0][:60] if problems else "-"),
                "why": "" if failed is None else f"step {failed.step}: {(failed.reason or '')[:90]}",
            }
            rows.append(row)
            print(row, file=sys.stderr, flush=True)
    head = [
        "scene",
        "method",
        "grid (cells)",
        "planned",
        "task [s]",
        "ms/placement",
        "off heading [deg]",
        "verify",
        "first failure",
    ]
    keys = ["scene", "method", "cells", "planned", "task_s", "ms", "off", "verify", "why"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(r[k]).replace("|", "/") for k in keys) + " |" for r in rows]
    text = "\n".join(lines) + "\n"
    text += (
        f'\nScenes: examples/buildings/*/tidy_up.yaml, and tidy_up_ycb.yaml ("(ycb)": the published DexYCB grasps, '
        f"20 per object, examples/buildings/README.md); maps `{Path(args.maps).name}` ({args.maps}); task time as "
        "`evaluate` counts it; planning time per placement: median of "
        f"{args.runs} fresh planners, the certificate's bound excluded; off heading: median over the planned steps of the angle between the base's "
        f"heading and its last TCP position; {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}.\n"
    )
    print(text)
    write_atomic(Path(args.out), text)


if __name__ == "__main__":
    main()
