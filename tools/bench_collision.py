"""Cost of the arm collision check per placement (a 2-pose trajectory) on the PR2 in the example scene.

Two sets of placements, each checked ``--runs`` times: the median over the runs of the mean time per
placement (wall clock and CPU time), and the median time of a single check:

* real: the steps the planner chooses for examples/table_clearing.yaml (every method), with the IK
  solution of every pose of the chosen trajectory (each solved from the previous one, as the planner does);
* random: bases 0.40-0.75 m in front of a pick table, facing it, with random arm configurations whose
  TCP is within 0.4 m of the table top (pre-pose and pose 5 cm apart in joint space).

Run: ``.venv/bin/python tools/bench_collision.py [--maps maps/pr2] [--runs 5]``; prints a Markdown table and
writes it to docs/bench/collision.md (atomically; ``--out`` elsewhere), which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # measure this checkout, not an installed copy


def real_placements(scene_path: Path, maps: Path) -> list[tuple]:
    """(arm, qs (P, n), base, grasped) of the planned steps of every method."""
    from placement.kinematics.ik import solve_ik
    from placement.planning import Planner
    from placement.planning.verification.ik import base_matrix

    planner = Planner(scene_path, maps=maps)
    out = []
    for method in ("sequential", "single-step", "irm", "fixed"):
        planner.set_method(method)
        held = None
        for step in planner.plan().steps:
            if not step.ok:
                break
            grasped = step.target if step.action == "pick" else held
            held = grasped
            Binv = np.linalg.inv(base_matrix(*step.base))
            q, qs = planner.robot.arm(step.arm).home.copy(), []
            for pose in step.tcp:
                q = solve_ik(planner.robot, step.arm, Binv @ pose, q, seeds=4, pos_tol=2e-3, rot_tol=2e-2).q
                qs.append(q)
            qs[-1] = step.q
            out.append((step.arm, np.array(qs), step.base, grasped))
    return out


def random_placements(robot, scene, n: int, rng: np.random.Generator) -> list[tuple]:
    """(arm, qs (2, n), base, None) near the pick tables (see the module doc)."""
    tables = [o for o in scene.tables if o.shape.size[0] == 0.8]
    arm = robot.arm("right")
    out = []
    while len(out) < n:
        t = tables[rng.integers(len(tables))].shape
        x = t.center[0] + rng.uniform(-0.3, 0.3)
        y = t.center[1] - t.size[1] / 2 - rng.uniform(0.40, 0.75)
        base = (float(x), float(y), np.pi / 2)
        q = arm.lower + (arm.upper - arm.lower) * rng.random(arm.dof)
        tcp = robot.tcp_pose("right", q)[:3, 3]
        # the TCP in the base frame: table top at 0.75 m, table from (dist) ahead; keep those near it
        if abs(tcp[2] - 0.75) > 0.4 or tcp[0] < 0.2:
            continue
        out.append(("right", np.array([q, q + rng.normal(0, 0.05, arm.dof)]), base, None))
    return out


def timed(checker, placements, runs: int) -> tuple[float, float, float, int]:
    """(median over runs of the mean wall-clock ms per placement, the same in CPU time of this thread,
    median ms of single checks, placements found free). CPU time leaves out other processes' load."""
    wall, cpu, single = [], [], []
    free = 0
    for r in range(runs):
        t0, c0 = time.perf_counter(), time.thread_time()
        for arm, qs, base, grasped in placements:
            t = time.perf_counter()
            res = checker.check(arm, qs, base, grasped)
            single.append((time.perf_counter() - t) * 1e3)
            free += res.free if r == 0 else 0
        wall.append((time.perf_counter() - t0) * 1e3 / len(placements))
        cpu.append((time.thread_time() - c0) * 1e3 / len(placements))
    return statistics.median(wall), statistics.median(cpu), statistics.median(single), free


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default=str(ROOT / "maps/pr2"))
    ap.add_argument("--scene", default=str(ROOT / "examples/table_clearing.yaml"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--random", type=int, default=200, help="random placements near the tables")
    ap.add_argument(
        "--out", default=str(ROOT / "docs/bench/collision.md"), help="the table's file (the docs include it)"
    )
    args = ap.parse_args()

    import placement
    from placement.collision import SceneCollision
    from placement.planning import load_scene

    scene = load_scene(args.scene)
    robot = placement.load_robot(scene.robot_preset)
    checker = SceneCollision(robot, scene)
    sets = {
        "planned steps (4 methods)": real_placements(Path(args.scene), Path(args.maps)),
        "random arms near the tables": random_placements(robot, scene, args.random, np.random.default_rng(1)),
    }
    for placements in sets.values():  # warm-up: geometry, arm pairs
        timed(checker, placements[:3], 1)
    lines = [
        f"Collision check per placement (2-pose trajectory), PR2, {Path(args.scene).name}; "
        f"median of {args.runs} runs over each set",
        "",
        "| placements | count | free | mean per placement [ms] | CPU per placement [ms] | median check [ms] |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, placements in sets.items():
        mean, cpu, med, free = timed(checker, placements, args.runs)
        lines.append(f"| {name} | {len(placements)} | {free} | {mean:.2f} | {cpu:.2f} | {med:.2f} |")
    load = f", load average {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    lines += [
        "",
        f"Machine: {platform.machine()} {platform.processor() or ''}, {os.cpu_count()} CPUs{load}, "
        f"Python {platform.python_version()}",
    ]
    text = "\n".join(lines) + "\n"
    write_atomic(Path(args.out), text)
    print(text, end="")


if __name__ == "__main__":
    main()
