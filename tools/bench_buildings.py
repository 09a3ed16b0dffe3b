"""Planning on real building maps: every method on the tidy-up scenes of examples/buildings.

For each scene (a SLAM map as published, tables at its named locations; with the generated grasps,
``tidy_up.yaml``, and with a published grasp set, ``tidy_up_ycb.yaml``) and method: whether the whole
task planned (else the first failing step and its reason), the task time as `evaluate` counts it,
the planning time per placement (median of ``--runs`` fresh planners, the certificate's bound
excluded), the whole query (planner built, plan, certificate: the median of the same runs), how far
the target sits off the base's heading (median over the steps), and the plan's verification (FK,
limits, transfers). Then the same scenes with all 100 published grasps per object ("(ycb, 100)",
written next to the scene for the run and removed after), with ``--many-methods``: the time bound
on a large grasp set (the default 10 s task budget).

    python tools/bench_buildings.py [--maps maps/pr2] [--runs 3] [--methods global,sequential]

Writes the table to docs/bench/buildings.md (atomically), which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from placement.planning import facing  # noqa: E402

METHODS = ("global", "sequential", "single-step", "fixed")
BUILDINGS = ROOT / "examples/buildings"
#: the 100-grasp scene's name beside its tidy-up scene (hidden: written for the run only)
MANY = ".tidy_up_ycb100.yaml"


def off_heading(step) -> float:
    """The angle [deg] between a planned step's base heading and its last TCP position."""
    return facing.off_heading(step.base, (float(step.tcp[-1][0, 3]), float(step.tcp[-1][1, 3])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="maps/pr2")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--many-methods", default="global", help="methods of the 100-grasp rows ('' for none)")
    ap.add_argument("--out", default=str(ROOT / "docs/bench/buildings.md"))
    args = ap.parse_args()

    from placement.planning import Planner
    from placement.planning.task_time import task_time

    maps = str(Path(args.maps).resolve())
    methods = args.methods.split(",")
    scenes = [(p, methods, p.stem.removeprefix("tidy_up_")) for p in sorted(BUILDINGS.glob("*/tidy_up*.yaml"))]
    many = [m for m in args.many_methods.split(",") if m]
    if many:
        scenes += [(p.with_name(MANY), many, "ycb, 100") for p in sorted(BUILDINGS.glob("*/tidy_up.yaml"))]
    rows = []
    for path, scene_methods, label in scenes:
        with all_grasps(path):
            rows += [bench(Planner, task_time, path, m, maps, args.runs, label) for m in scene_methods]
    head = [
        "scene",
        "method",
        "grid (cells)",
        "planned",
        "task [s]",
        "ms/placement",
        "query [s]",
        "off heading [deg]",
        "verify",
        "first failure",
    ]
    keys = ["scene", "method", "cells", "planned", "task_s", "ms", "query_s", "off", "verify", "why"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(r[k]).replace("|", "/") for k in keys) + " |" for r in rows]
    text = "\n".join(lines) + "\n"
    text += (
        f'\nScenes: examples/buildings/*/tidy_up.yaml, and tidy_up_ycb.yaml ("(ycb)": the published DexYCB grasps, '
        f'20 per object, examples/buildings/README.md; "(ycb, 100)": all 100 per object); maps `{Path(args.maps).name}` '
        f"({args.maps}); task time as `evaluate` counts it; planning time per placement: median of {args.runs} fresh "
        "planners, the certificate's bound excluded; query: the same runs' median of the whole query (planner built, "
        "plan and certificate, within the default 10 s budget counted from the planner's construction, as "
        "`placement query` counts it); off heading: median over the planned steps of the angle "
        f"between the base's heading and its last TCP position; {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}.\n"
    )
    print(text)
    write_atomic(Path(args.out), text)


@contextlib.contextmanager
def all_grasps(path: Path) -> Iterator[None]:
    """For the 100-grasp scene ``path`` (named :data:`MANY`): written from the tidy-up scene beside it for
    the block's duration (its map and maps are relative to that folder); other scenes: nothing."""
    if path.name != MANY:
        yield
        return
    from ycb_grasp_scenes import GRASP_FILE, scene_text

    grasp_set = json.loads(GRASP_FILE.read_text())
    path.write_text(scene_text(path.with_name("tidy_up.yaml"), grasp_set, per_object=100))
    try:
        yield
    finally:
        path.unlink(missing_ok=True)


def bench(planner_of, task_time, path: Path, m: str, maps: str, runs: int, label: str) -> dict[str, str]:
    """One row: ``path`` planned by method ``m`` in ``runs`` fresh planners (see the module doc)."""
    times, queries, result, planner = [], [], None, None
    for _ in range(runs):
        t0 = time.perf_counter()
        planner = planner_of(path, m, maps)
        t = time.perf_counter()
        result = planner.plan(spent_s=planner.construction_s)  # as `placement query` plans
        end = time.perf_counter()
        # the certificate's bound excluded, as in bench_query and bench_optimum
        times.append((end - t) * 1e3 - result.certificate.ms)
        queries.append(end - t0)
    assert result is not None and planner is not None
    steps = result.steps
    placed = [s for s in steps if s.status == "ok"]
    failed = result.failed_step
    tt = task_time(planner.robot, result, planner.scene.start) if result.ok else None
    problems = result.verify(planner.robot) if result.ok else []
    row = {
        "scene": path.parent.name + ("" if label == "tidy_up" else f" ({label})"),
        "method": m,
        "cells": "x".join(str(v) for v in planner.world.nav.shape),
        "planned": f"{len(placed)}/{len(planner.problems.steps)}",
        "task_s": f"{tt['total_s']:.1f}" if tt else "-",
        "ms": f"{statistics.median(times) / len(planner.problems.steps):.0f}",
        "query_s": f"{statistics.median(queries):.1f}",
        "off": f"{statistics.median(off_heading(s) for s in placed):.0f}" if placed else "-",
        "verify": "ok" if result.ok and not problems else (problems[0][:60] if problems else "-"),
        "why": "" if failed is None else f"step {failed.step}: {(failed.reason or '')[:90]}",
    }
    print(row, file=sys.stderr, flush=True)
    return row


if __name__ == "__main__":
    main()
