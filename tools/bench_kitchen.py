"""Plan the torso kitchens with every whole-task and step-by-step method and write the table.

    python tools/bench_kitchen.py [--out docs/bench/kitchen_plan.md] SCENE ...
    python tools/bench_kitchen.py examples/kitchen.yaml --out docs/bench/kitchen_example.md

(``make bench-kitchen`` runs both: the torso kitchens, and the version 2 kitchen example.)

Per scene and method: the steps planned, the independent check of the whole plan (pinocchio FK of
every pose with the step's lift value, the transfers, the step configuration: ``PlanResult.verify``),
the lift value of each step, the task time (docs/design.md's parallel model, the lift's time
included) and the planning time of a fresh planner (median of ``--runs``). Logs on stderr.
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

from placement.planning.planner import Planner
from placement.planning.task_time import task_time
from placement.planning.torso import torso_joint

METHODS = ("global", "optimal", "sequential")


def row(scene: Path, method: str, runs: int) -> str:
    times, result, planner = [], None, None
    for _ in range(runs):
        planner = Planner(scene, method)
        t = time.perf_counter()
        result = planner.plan()
        times.append((time.perf_counter() - t) * 1e3)
    assert result is not None and planner is not None
    ctx = planner.context
    joint = torso_joint(ctx.maps)
    planned = sum(s.ok for s in result.steps)
    problems = result.verify(ctx.robot)
    lifts = ", ".join(f"{s.joints[joint]:.2f}" for s in result.steps if s.ok and joint) or "-"
    tt = task_time(ctx.robot, result, ctx.scene.start)
    total = f"{tt['total_s']:.1f}" if tt else "-"
    lift_s = f"{sum(s['torso_s'] for s in tt['steps']):.1f}" if tt else "-"
    print(f"{scene.name} {method}: {planned}/{len(result.steps)} planned, {len(problems)} problems", file=sys.stderr)
    check = "clean" if not problems else f"{len(problems)} problems"
    return (
        f"| {scene.name} | {ctx.robot.name} | {method} | {planned}/{len(ctx.problems.steps)} | {check} | {lifts} "
        f"| {total} | {lift_s} | {statistics.median(times):.0f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, default=Path("docs/bench/kitchen_plan.md"))
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    lines = [
        "| scene | robot | method | steps planned | whole-plan check | lift per step [m] | task [s] "
        "| lift moving [s] | planning [ms] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for scene in args.scenes:
        lines += [row(scene, m, args.runs) for m in METHODS]
    lines += [
        "",
        f"Planning time: median of {args.runs} fresh planners (the certificate's bound included); task time: "
        "the base, the arm and the lift move in parallel within a step, steps add up (`torso_s`); "
        f"{platform.machine()}, {len(os.sched_getaffinity(0))} cores, Python {platform.python_version()}.",
    ]
    write_atomic(args.out, "\n".join(lines) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
