"""Which torso heights serve which steps of a scene: a ground truth that uses no reachability map.

For each value of the torso joint (a fine sweep over its limits) and each step of the scene's task,
it decides whether SOME base placement does the step with SOME grasp the planner would try
(``placement.planning.problems.steps.step_candidates``) and arm: every TCP pose of the trajectory solved by
the planner's IK (``trajectory_ik``) on ``robot.with_fixed({joint: value})``, the arm (and a place's
held object) free of collisions (``SceneCollision`` on the same variant, with the planner's
collision arguments) and the base footprint clear of obstacles (the planner's footprint test).

Bases are taken from a grid around the target: the navigation grid's cell centres (5 cm) within the
arm's reach, 24 yaws (15 degrees); it stops at the first verified one. Two tests prune without
losing a placement the grid holds (see tools/torso_reach.py): a reach bound by the triangle
inequality, and a reduced IK showing that the pose's height and tilt are within the arm's reach at
all (a base on the floor supplies x, y and yaw); the reduced IK's solutions also order the grid, so a
reachable step is found in a few tries.

Run: ``.venv/bin/python tools/kitchen_torso.py examples/kitchen_torso.yaml [more scenes]
[--out docs/bench/kitchen_torso.md]``; progress on stderr. Each scene's section of the Markdown is
replaced (the others are kept); it asserts that every step is served by some torso value and that no
single value serves every step (exit status 1 otherwise).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from bench_output import write_atomic
from torso_reach import ReachBound, bases_of, floor_ik

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout, not an installed copy

from placement.collision import SceneCollision  # noqa: E402
from placement.planning.problems.grasps import Candidate  # noqa: E402
from placement.planning.problems.manipulation import base_yaws  # noqa: E402
from placement.planning.problems.steps import Step, step_candidates, task_steps  # noqa: E402
from placement.planning.problems.transfer import held_object  # noqa: E402
from placement.planning.settings import PlannerConfig  # noqa: E402
from placement.planning.verification.ik import trajectory_ik  # noqa: E402
from placement.planning.world.footprints import BaseShape  # noqa: E402
from placement.planning.world.layers import build_world  # noqa: E402
from placement.robots import Robot, load_robot  # noqa: E402
from placement.scene import Scene, load_scene  # noqa: E402

TORSO = "torso_lift_joint"
#: base yaws per turn (15 degrees apart) and reduced-IK seeds per pose
YAWS, SEEDS = 24, 32
#: [m] the torso sweep's step
STEP_M = 0.01
#: IK tries per step, arm and grasp before a search gives up: a reachable grasp verifies within a few
#: tries (the reduced IK orders the grid); the cap bounds the searches whose every base collides
CAP = 400


@dataclass(frozen=True)
class _Witness:
    """The IK's first start: a reduced-IK solution near this base (its height and tilt are right)."""

    q: np.ndarray

    def __call__(self, _target: np.ndarray) -> np.ndarray | None:
        return self.q


@dataclass(frozen=True)
class Found:
    """A verified placement: arm, grasp, base (x [m], y [m], yaw [rad]) and the IK tries it took."""

    arm: str
    grasp: str | None
    base: tuple[float, float, float]
    tries: int


class Ground:
    """The map-free search of one scene (see the module docstring); ``joint`` is the swept fixed joint."""

    def __init__(
        self, scene: Scene | str | Path, joint: str = TORSO, yaws: int = YAWS, seeds: int = SEEDS, cap: int = CAP
    ):
        self.scene = scene if isinstance(scene, Scene) else load_scene(scene)
        self.config = PlannerConfig.from_overrides(self.scene.planner, "kitchen_torso")
        self.robot = load_robot(self.scene.robot_preset)
        self.joint, self.seeds, self.cap = joint, seeds, cap
        self.capped = 0  # searches that gave up at the cap
        if joint not in self.robot.fixed_joints:
            raise SystemExit(f"{self.robot.name}: '{joint}' is not a fixed joint of the preset")
        jm = self.robot.model.joints[self.robot.model.getJointId(joint)]
        self.limits = (
            float(self.robot.model.lowerPositionLimit[jm.idx_q]),
            float(self.robot.model.upperPositionLimit[jm.idx_q]),
        )
        self.steps: list[Step] = task_steps(self.scene)
        opening = self.robot.gripper.max_opening
        self.candidates = [step_candidates(self.scene, s, self.config, opening) for s in self.steps]
        shape = BaseShape.of(self.robot, self.config.footprint_padding, base_yaws(self.config.yaw_steps))
        self.world = build_world(self.scene, shape, self.config)
        self.yaws = base_yaws(yaws)
        self._variants: dict[float, tuple[Robot, SceneCollision]] = {}
        self._floor: dict[tuple[Any, ...], np.ndarray] = {}
        self._clear = np.full((*self.world.nav.shape, len(self.yaws)), -1, dtype=np.int8)  # -1: not known yet

    def clear(self, iy: np.ndarray, ix: np.ndarray, iw: np.ndarray) -> np.ndarray:
        """(N,) bool: the base footprint fits at cells (iy, ix) (N,) with yaws ``self.yaws[iw]`` (cached)."""
        known = self._clear[iy, ix, iw]
        xs, ys = self.world.nav.centres()
        for j in np.flatnonzero(known < 0):
            known[j] = self.world.pose_clear(float(xs[ix[j]]), float(ys[iy[j]]), float(self.yaws[iw[j]]))
            self._clear[iy[j], ix[j], iw[j]] = known[j]
        out: np.ndarray = known > 0
        return out

    def values(self, step_m: float = STEP_M) -> list[float]:
        """The sweep [m or rad]: the joint's limits in steps of ``step_m``, both ends included."""
        lo, hi = self.limits
        n = int(math.floor((hi - lo) / step_m + 1e-9))
        out = [round(lo + k * step_m, 6) for k in range(n + 1)]
        return out if out[-1] >= hi - 1e-9 else [*out, hi]

    def grasps(self, i: int) -> list[str | None]:
        """The grasps step ``i``'s candidates hold the object by, in the planner's order."""
        return list(dict.fromkeys(c.grasp for c in self.candidates[i]))

    def variant(self, value: float) -> tuple[Robot, SceneCollision]:
        if value not in self._variants:
            rv = self.robot.with_fixed({self.joint: value})
            self._variants[value] = (rv, SceneCollision(rv, self.scene, padding=self.config.collision_padding))
        return self._variants[value]

    def floor(self, rv: Robot, value: float, arm: str, pose: np.ndarray) -> np.ndarray:
        """(M, n) reduced-IK solutions of ``pose`` (cached by height and tilt)."""
        key = (value, arm, round(float(pose[2, 3]), 5), *np.round(pose[2, :3], 5))
        if key not in self._floor:
            a = rv.arm(arm)
            rng = np.random.default_rng(0)
            seeds = np.vstack([a.home, rng.uniform(a.lower, a.upper, (self.seeds - 1, a.dof))])
            self._floor[key] = floor_ik(a.chain, a.lower, a.upper, a.continuous, pose, seeds)
        return self._floor[key]

    def collision_args(self, step: Step, cand: Candidate) -> dict[str, Any]:
        """As the planner's search builds them (placement/planning/methods/search.py)."""
        gone = [s.target for s in self.steps[: step.index] if s.action == "pick"]
        if step.action == "pick":
            return {"grasped": step.target, "gone": [g for g in gone if g != step.target]}
        if step.action == "place" and step.carries is not None and cand.object_pose is not None:
            return {"grasped": None, "gone": gone, "held": held_object(self.scene.object(step.carries), cand)}
        return {"grasped": None, "gone": gone}

    def placement(self, i: int, value: float, grasps: Sequence[str | None] | None = None) -> Found | None:
        """A verified placement of step ``i`` with the joint at ``value``, holding one of ``grasps``
        (default any), or None when the grid holds none."""
        rv, checker = self.variant(value)
        cands = [c for c in self.candidates[i] if grasps is None or c.grasp in grasps]
        cands = list({c.poses.tobytes(): c for c in cands}.values())
        for arm in rv.arms:
            found = self._search(self.steps[i], cands, rv, value, arm, checker)
            if found is not None:
                return found
        return None

    def _search(
        self, step: Step, cands: list[Candidate], rv: Robot, value: float, arm: str, checker: SceneCollision
    ) -> Found | None:
        a = rv.arm(arm)
        bound = ReachBound.of(a.chain, a.lower, a.upper, a.continuous)
        xs, ys = self.world.nav.centres()
        queue: list[tuple[float, int, np.ndarray, np.ndarray]] = []
        for k, c in enumerate(cands):
            sols = [self.floor(rv, value, arm, p) for p in c.poses]
            if any(len(s) == 0 for s in sols):
                continue  # a pose no base on the floor reaches
            target = c.poses[-1, :3, 3]
            reach = bound.length + np.linalg.norm(bound.radial) + np.linalg.norm(bound.centre[:2])
            reach += np.linalg.norm(bound.w_tcp) + 0.05
            ix = np.flatnonzero(np.abs(xs - target[0]) <= reach)
            iy = np.flatnonzero(np.abs(ys - target[1]) <= reach)
            IX, IY, IW = (m.ravel() for m in np.meshgrid(ix, iy, np.arange(len(self.yaws)), indexing="ij"))
            bases = np.stack([xs[IX], ys[IY], self.yaws[IW]], axis=1)
            keep = bound.admits(c.poses, bases)
            keep[keep] = self.clear(IY[keep], IX[keep], IW[keep])
            bases = bases[keep]
            ideal = bases_of(a.chain, c.poses[-1], sols[-1])
            dyaw = (bases[:, None, 2] - ideal[None, :, 2] + math.pi) % (2 * math.pi) - math.pi
            score = ((bases[:, None, :2] - ideal[None, :, :2]) ** 2).sum(-1) + (0.2 * dyaw) ** 2
            near = score.argmin(axis=1)
            best = score[np.arange(len(bases)), near]
            queue += [(float(best[j]), k, bases[j], sols[-1][near[j]]) for j in range(len(bases))]
        queue.sort(key=lambda e: (e[0], e[1]))
        tries = 0
        for _, k, base, q_floor in queue:
            if tries >= self.cap:
                self.capped += 1
                return None
            tries += 1
            x, y, yaw = (float(v) for v in base)
            c = cands[k]
            ik = trajectory_ik(rv, arm, c.poses, (x, y, yaw), a.home, _Witness(q_floor), self.config)
            if not ik.ok:
                continue
            if checker.check(arm, ik.qs, (x, y, yaw), **self.collision_args(step, c)).free:
                return Found(arm, c.grasp, (x, y, yaw), tries)
        return None


@dataclass
class Sweep:
    """Per value (T,) and step (S,): the grasps that serve it (empty: the step is not reachable)."""

    robot: str
    scene: str
    joint: str
    values: list[float]
    labels: list[str]
    served: list[list[list[str | None]]]
    seconds: float

    def ok(self, t: int, s: int) -> bool:
        return bool(self.served[t][s])

    def intervals(self, s: int) -> list[tuple[float, float]]:
        """The runs of consecutive swept values that serve step ``s`` (first, last)."""
        out: list[tuple[float, float]] = []
        run: list[float] = []
        for t, v in enumerate(self.values):
            if self.ok(t, s):
                run.append(v)
            elif run:
                out.append((run[0], run[-1]))
                run = []
        return [*out, (run[0], run[-1])] if run else out

    def common(self) -> list[float]:
        """The values that serve every step."""
        return [v for t, v in enumerate(self.values) if all(self.ok(t, s) for s in range(len(self.labels)))]


def sweep(ground: Ground, step_m: float = STEP_M, log: Callable[[str], None] = lambda _m: None) -> Sweep:
    """Every swept value against every step and each of its grasps (a grasp stops at its first placement)."""
    t0 = time.perf_counter()
    values = ground.values(step_m)
    labels = [f"{s.index} {s.action} {s.target}" for s in ground.steps]
    served: list[list[list[str | None]]] = []
    for v in values:
        row = []
        for i in range(len(ground.steps)):
            row.append([g for g in ground.grasps(i) if ground.placement(i, v, [g]) is not None])
        served.append(row)
        log(
            f"{ground.robot.name} {ground.joint} {v:.3f}: "
            + " ".join("y" if r else "-" for r in row)
            + f"  {time.perf_counter() - t0:.0f} s"
        )
    return Sweep(
        ground.robot.name,
        str(ground.scene.source or ""),
        ground.joint,
        values,
        labels,
        served,
        time.perf_counter() - t0,
    )


def transfers(ground: Ground, result: Sweep) -> list[str]:
    """Per pick/place pair: the grasps that serve both the pick and the place at some swept values
    (the planner holds the object by the grasp it picked it with)."""
    out = []
    for s in ground.steps:
        if s.action != "place" or s.pick is None:
            continue
        held = [{g for row in result.served for g in row[i]} for i in (s.pick, s.index)]
        both = [g for g in ground.grasps(s.pick) if g in held[0] and g in held[1]]
        out.append(
            f"- {s.carries} (steps {s.pick}, {s.index}): grasps serving both: {', '.join(map(str, both)) or 'none'}"
        )
    return out


def markdown(ground: Ground, result: Sweep, every: int = 2) -> str:
    """The scene's section: the table (every ``every``-th swept value), the intervals and the verdict."""
    unit = (
        "m"
        if ground.robot.model.joints[ground.robot.model.getJointId(ground.joint)].shortname().startswith("JointModelP")
        else "rad"
    )
    head = [f"{ground.joint} [{unit}]", *result.labels]
    rows = [
        [f"{v:.2f}", *("yes" if result.ok(t, s) else "-" for s in range(len(result.labels)))]
        for t, v in enumerate(result.values)
        if t % every == 0 or t == len(result.values) - 1
    ]
    lines = [
        f"## {result.robot}: {result.scene}",
        "",
        f"`{ground.joint}` swept over {result.values[0]:.2f} .. {result.values[-1]:.2f} {unit} by {STEP_M} {unit} "
        f"({len(result.values)} values; the table shows one in {every}); a cell is `yes` when some base on the "
        f"{ground.world.nav.resolution} m grid, at one of {len(ground.yaws)} yaws, does the step with some grasp "
        f"and arm (IK and collision check verified; no maps). {result.seconds:.0f} s; "
        f"{ground.capped} searches stopped at {ground.cap} IK tries.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
        *("| " + " | ".join(r) + " |" for r in rows),
        "",
        "Values that serve each step (on the fine sweep):",
        "",
    ]
    for s, label in enumerate(result.labels):
        spans = ", ".join(f"{a:.2f} .. {b:.2f}" for a, b in result.intervals(s)) or "none"
        lines.append(f"- {label}: {spans} {unit}")
    lines += ["", "Transfers:", "", *transfers(ground, result), ""]
    common = result.common()
    if common:
        lines.append(f"**values that serve every step: {', '.join(f'{v:.2f}' for v in common)} {unit}**")
    else:
        lines.append("**no single torso value serves every step**")
    return "\n".join(lines) + "\n"


def merged(old: str, section: str) -> str:
    """``old`` (the whole Markdown) with the section of the same heading replaced (or appended)."""
    title = "# Torso height per step (map-free ground truth)\n\nWritten by `tools/kitchen_torso.py`.\n"
    parts = [p for p in old.split("\n## ")[1:]]
    heading = section.split("\n", 1)[0][3:]
    parts = [p for p in parts if p.split("\n", 1)[0] != heading] + [section[3:]]
    return title + "".join("\n## " + p.rstrip("\n") + "\n" for p in parts)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, default=ROOT / "docs/bench/kitchen_torso.md")
    ap.add_argument("--joint", default=TORSO)
    ap.add_argument("--every", type=int, default=2, help="table rows: every n-th swept value")
    args = ap.parse_args(argv)
    bad = []
    for path in args.scenes:
        ground = Ground(path, args.joint)
        result = sweep(ground, log=lambda m: print(m, file=sys.stderr, flush=True))
        text = args.out.read_text() if args.out.exists() else ""
        write_atomic(args.out, merged(text, markdown(ground, result, args.every)))
        print(f"{path}: {result.seconds:.0f} s, written to {args.out}", file=sys.stderr)
        missing = [result.labels[s] for s in range(len(result.labels)) if not result.intervals(s)]
        if missing or result.common():
            bad.append(f"{path}: steps no value serves: {missing}; values serving every step: {result.common()}")
    for line in bad:
        print(line, file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
