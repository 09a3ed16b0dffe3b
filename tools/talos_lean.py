"""talos_reduced leaning over a low table: which torso pitch serves which step, without maps and with them.

The scene ``examples/talos_reduced_lean.yaml`` has a low table (top 0.42 m) and an ordinary one (0.75 m);
the maps ``maps/talos_reduced_torso`` (spec ``maps/talos_reduced_torso.yaml``) hold both arms at three
settings of ``torso_2_joint``, the revolute pitch that carries both arms (one build per setting).

1. Ground truth, no maps: for each value of a sweep of ``torso_2_joint`` (0.05 rad apart, plus the
   maps' settings) and each step, whether some base on the navigation grid, at one of 24 yaws, does the
   step with some grasp and arm: the planner's IK and collision check on ``robot.with_fixed({joint: v})``
   (:class:`kitchen_torso.Ground`, the search of ``tools/kitchen_torso.py``).
2. Plans: ``global``, ``sequential`` and ``optimal`` on the maps (a fresh planner each, planning time the
   median of ``--runs``), each checked by ``PlanResult.verify`` (pinocchio FK of every pose at the step's
   torso value, transfers, configurations), the torso value per step, the task time (base, arm and torso
   in parallel within a step).

It asserts that the upright setting (the preset's 0 rad) does not serve every low-table step, that a
leaning setting of the maps serves each of them, and that every plan plans every step, verifies with
no problem and holds each low-table step at a leaning setting that the ground truth says serves it
(exit status 1 otherwise, after writing the page).

Run: ``.venv/bin/python tools/talos_lean.py [--maps maps/talos_reduced_torso] [--out docs/bench/torso_pitch.md]``;
progress on stderr; the page is replaced atomically.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bench_output import write_atomic
from kitchen_torso import Found, Ground

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout, not an installed copy

from placement.maps.opening import open_map  # noqa: E402
from placement.planning.planner import Planner  # noqa: E402
from placement.planning.task_time import task_time  # noqa: E402
from placement.scene import Scene  # noqa: E402

SCENE = ROOT / "examples" / "talos_reduced_lean.yaml"
MAPS = ROOT / "maps" / "talos_reduced_torso"
JOINT = "torso_2_joint"
LOW_TABLE = "low_table"
METHODS = ("global", "sequential", "optimal")
#: [rad] the ground truth's sweep: -0.25 .. 0.75 rad in steps of 0.05 rad (the maps' settings added)
SWEEP = tuple(round(0.05 * k, 2) for k in range(-5, 16))


def low_steps(ground: Ground, table: str = LOW_TABLE) -> list[int]:
    """The steps whose object or place location stands on the obstacle ``table`` (its box's x, y
    extent, above its top)."""
    scene: Scene = ground.scene
    box = next(o.shape for o in scene.obstacles if o.name == table)
    lo = [box.center[k] - box.size[k] / 2 for k in range(3)]
    hi = [box.center[k] + box.size[k] / 2 for k in range(3)]
    out = []
    for s in ground.steps:
        p = scene.object(s.target).position if s.action == "pick" else scene.place_location(s.target).position
        if lo[0] <= p[0] <= hi[0] and lo[1] <= p[1] <= hi[1] and p[2] >= hi[2]:
            out.append(s.index)
    return out


@dataclass
class Truth:
    """The ground truth: per swept value (V,) and step (S,) the placement found (None: none)."""

    values: list[float]
    found: list[list[Found | None]]
    seconds: float

    def serves(self, value: float, step: int) -> bool:
        return self.found[self.values.index(value)][step] is not None


def ground_truth(ground: Ground, values: Sequence[float]) -> Truth:
    t0 = time.perf_counter()
    found = []
    for v in values:
        found.append([ground.placement(i, v) for i in range(len(ground.steps))])
        row = " ".join("y" if f else "-" for f in found[-1])
        print(f"ground truth {JOINT} {v:.2f}: {row}  {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return Truth(list(values), found, time.perf_counter() - t0)


@dataclass
class Builds:
    """The maps' settings [rad] (reference first) and per arm and setting the build time [s]."""

    settings: list[float]
    reference: float
    seconds: dict[tuple[str, float], float]
    samples: int
    resolution: float


def builds(maps: Path, ground: Ground) -> Builds:
    robot = ground.robot
    seconds: dict[tuple[str, float], float] = {}
    settings: list[float] = []
    reference, samples, resolution = 0.0, 0, 0.0
    for arm in robot.arms:
        rmap = open_map(maps, arm, robot)
        t = rmap.torso
        if t is None or t.joint != JOINT or t.shift is not None:
            raise SystemExit(f"{maps}: arm '{arm}' has no per-setting torso record of '{JOINT}'")
        reference, settings = t.reference, sorted({t.reference, *t.values})
        samples, resolution = int(rmap.meta["samples"]), float(rmap.meta["grid"]["resolution"])
        for v in settings:
            seconds[(arm, v)] = float(rmap.at_torso(v).meta["build_time_s"])
    return Builds(settings, reference, seconds, samples, resolution)


@dataclass
class Planned:
    """One method's plan: steps planned, verification problems, per step (torso [rad], arm, grasp, base),
    task time and torso moving time [s], planning time [ms] (median)."""

    method: str
    planned: int
    problems: list[str]
    steps: list[tuple[float | None, str | None, str | None, tuple[float, float, float] | None]]
    task_s: float | None
    torso_s: float | None
    plan_ms: float


def plan(scene: Path, maps: Path, method: str, runs: int) -> Planned:
    times, result, planner = [], None, None
    for _ in range(runs):
        planner = Planner(scene, method, maps=maps)
        t = time.perf_counter()
        result = planner.plan()
        times.append((time.perf_counter() - t) * 1e3)
    assert result is not None and planner is not None
    ctx = planner.context
    problems = [str(p) for p in result.verify(ctx.robot)]
    steps = [(s.joints.get(JOINT), s.arm, s.grasp, s.base) if s.ok else (None, None, None, None) for s in result.steps]
    tt = task_time(ctx.robot, result, ctx.scene.start)
    print(
        f"{method}: {sum(s.ok for s in result.steps)}/{len(result.steps)} planned, {len(problems)} problems",
        file=sys.stderr,
    )
    return Planned(
        method,
        sum(s.ok for s in result.steps),
        problems,
        steps,
        tt["total_s"] if tt else None,
        sum(s["torso_s"] for s in tt["steps"]) if tt else None,
        statistics.median(times),
    )


def failures(ground: Ground, truth: Truth, b: Builds, plans: list[Planned], low: list[int]) -> list[str]:
    """What the scene and the plans were to show and did not (empty: all shown)."""
    out = []
    leaning = [v for v in b.settings if v != b.reference]
    if all(truth.serves(b.reference, i) for i in low):
        out.append(f"the upright setting {b.reference:g} rad serves every low-table step")
    for i in low:
        if not any(truth.serves(v, i) for v in leaning):
            out.append(f"step {i}: no leaning setting of the maps serves it (ground truth)")
    for p in plans:
        if p.planned != len(ground.steps) or p.problems:
            out.append(f"{p.method}: {p.planned}/{len(ground.steps)} planned, {len(p.problems)} problems")
            continue
        for i in low:
            v = p.steps[i][0]
            if v is None or v == b.reference or not truth.serves(v, i):
                out.append(f"{p.method}: low-table step {i} planned at {JOINT} = {v} rad")
    return out


def markdown(ground: Ground, truth: Truth, b: Builds, plans: list[Planned], low: list[int], runs: int) -> str:
    labels = [f"{s.index} {s.action} {s.target}" + (" (low)" if s.index in low else "") for s in ground.steps]
    total = sum(b.seconds.values())
    lines = [
        "Written by `tools/talos_lean.py`.",
        "",
        f"**Maps**: `maps/talos_reduced_torso.yaml`, both arms of talos_reduced at `{JOINT}` = "
        + ", ".join(f"{v:g}" for v in b.settings)
        + f" rad (0 upright, the preset's; positive leans forward), {b.samples / 1e6:g} M samples per arm "
        f"per setting at {b.resolution:g} m: {len(b.seconds)} builds, {total:.0f} s of sampling ("
        + ", ".join(f"{arm} {v:g}: {s:.0f} s" for (arm, v), s in b.seconds.items())
        + ").",
        "",
        f"**Ground truth** (no maps): a cell is `yes` when some base on the {ground.world.nav.resolution} m grid, "
        f"at one of {len(ground.yaws)} yaws, does the step with some grasp and arm at that `{JOINT}` value "
        f"(the planner's IK and collision check); {truth.seconds:.0f} s, {ground.capped} searches stopped at "
        f"{ground.cap} IK tries. Bold rows: the maps' settings.",
        "",
        f"| {JOINT} [rad] | " + " | ".join(labels) + " |",
        "|" + "---|" * (len(labels) + 1),
    ]
    for t, v in enumerate(truth.values):
        name = f"**{v:.2f}**" if v in b.settings else f"{v:.2f}"
        lines.append(f"| {name} | " + " | ".join("yes" if f else "-" for f in truth.found[t]) + " |")
    served = [v for v in truth.values if all(truth.serves(v, i) for i in low)]
    lines += [
        "",
        "Low-table steps served by: " + (", ".join(f"{v:.2f}" for v in served) or "no value") + " rad.",
        "",
        "**Plans** on the maps (`placement query --method M`), each checked by `PlanResult.verify`:",
        "",
        "| method | steps planned | verification | torso per step [rad] | task [s] | torso moving [s] | planning [ms] |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in plans:
        check = "clean" if not p.problems else f"{len(p.problems)} problems"
        torso = ", ".join("-" if s[0] is None else f"{s[0]:.2f}" for s in p.steps)
        task = "-" if p.task_s is None else f"{p.task_s:.1f}"
        moving = "-" if p.torso_s is None else f"{p.torso_s:.2f}"
        lines.append(
            f"| {p.method} | {p.planned}/{len(ground.steps)} | {check} | {torso} | {task} | {moving} | {p.plan_ms:.0f} |"
        )
    lines += [
        "",
        f"Steps of the `{plans[0].method}` plan:",
        "",
        f"| step | arm | grasp | base x, y [m], yaw [rad] | {JOINT} [rad] |",
        "|---|---|---|---|---|",
    ]
    for label, (v, arm, grasp, base) in zip(labels, plans[0].steps):
        where = "-" if base is None else f"{base[0]:.2f}, {base[1]:.2f}, {base[2]:.2f}"
        lines.append(f"| {label} | {arm or '-'} | {grasp or '-'} | {where} | {'-' if v is None else f'{v:.2f}'} |")
    lines += [
        "",
        f"Planning time: median of {runs} fresh planners; task time: base, arm and torso move in parallel "
        f"within a step, steps add up; {platform.machine()}, {len(os.sched_getaffinity(0))} cores, "
        f"Python {platform.python_version()}.",
    ]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", type=Path, default=SCENE)
    ap.add_argument("--maps", type=Path, default=MAPS)
    ap.add_argument("--out", type=Path, default=ROOT / "docs/bench/torso_pitch.md")
    ap.add_argument("--runs", type=int, default=3, help="fresh planners per method (planning time: the median)")
    args = ap.parse_args(argv)
    if not (args.maps / "zarr.json").is_file():
        raise SystemExit(
            f"{args.maps}: no maps; build them: placement maps build --spec "
            f"maps/talos_reduced_torso.yaml --out {args.maps}"
        )
    ground = Ground(args.scene, JOINT)
    b = builds(args.maps, ground)
    low = low_steps(ground)
    truth = ground_truth(ground, sorted({*SWEEP, *b.settings}))
    plans = [plan(args.scene, args.maps, m, args.runs) for m in METHODS]
    write_atomic(args.out, markdown(ground, truth, b, plans, low, args.runs))
    print(f"wrote {args.out}", file=sys.stderr)
    bad = failures(ground, truth, b, plans, low)
    for line in bad:
        print(line, file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
