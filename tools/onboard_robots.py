"""Onboard robots from their URDFs end to end and write the Markdown tables docs/robots.md includes.

For each robot: ``placement robots init`` -> ``examples/robots/<robot>.yaml`` (unedited), a build spec
``maps/<robot>.yaml`` (written when missing), ``placement maps build`` -> ``maps/<robot>`` (skipped when
the maps exist, unless --rebuild), a table-clearing scene sized for the robot from its top-down reach
band -> ``examples/table_clearing_<robot>.yaml``, planned with ``Planner`` and every planned step checked by
``PlanResult.verify`` (independent pinocchio FK); a step the planner calls infeasible is tried by an
independent randomized IK search over base poses (:func:`independent_search`).

    python tools/onboard_robots.py [ROBOT ...] [--samples N] [--rebuild] [--objects K] [--reach-only]
                                   [--root DIR]

ROBOT is a key of :data:`ROBOTS` or a path to a URDF/xacro file. Writes (atomically, see
bench_output.py) the table of the run to docs/bench/onboarding.md and the reach bands of the presets
(``placement robots check``: heights and distances per arm and approach, and its warnings) to
docs/bench/reach.md; ``--reach-only`` writes only the reach bands, from the presets as they are (no
init, build or planning: seconds). Rows of robots not in the run stay in both tables. Every path above
is under the repository root, or under ``--root DIR`` (a trial run whose presets, maps, scenes and
tables stay out of the repository).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml
from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from placement.errors import PlacementError  # noqa: E402
from placement.maps.buildspec import TorsoSpec  # noqa: E402
from placement.maps.torso import check_torso  # noqa: E402
from placement.robots import Robot, load_robot  # noqa: E402
from placement.robots.onboarding.check import band_warnings, held_words  # noqa: E402
from placement.robots.onboarding.propose import propose  # noqa: E402
from placement.robots.onboarding.reach import APPROACHES, reach_band  # noqa: E402
from placement.robots.onboarding.render import render  # noqa: E402
from placement.robots.spec import share_dir  # noqa: E402

ERD = "example-robot-data/robots/"
#: The robots onboarded: example-robot-data's (paths in its share folder) and the repository's own
#: (paths from the repository root; examples/robots/urdf holds their URDFs and how they were sized).
ROBOTS = {
    "tiago": ERD + "tiago_description/robots/tiago.urdf",
    "talos_reduced": ERD + "talos_data/robots/talos_reduced.urdf",
    "romeo": ERD + "romeo_description/urdf/romeo.urdf",
    # a wheeled centaur: four legs ending in wheels, a yaw torso and two 6-joint arms without fingers
    "centauro": ERD + "centauro_description/urdf/centauro.urdf",
    # example-robot-data's 5-joint SO-101 arm on a 0.65 m column: tables 0.45 m high
    "so_arm_base": "examples/robots/urdf/so_arm_base.urdf.xacro",
    # Stretch-like: a 1.1 m lift, four 0.13 m telescope joints and a yaw-pitch-roll wrist
    "lift_telescope": "examples/robots/urdf/lift_telescope.urdf",
}
ONBOARDING_MD = Path("docs/bench/onboarding.md")
REACH_MD = Path("docs/bench/reach.md")
#: Columns of the onboarding table (keys of :func:`onboard`'s rows).
KEYS = ["robot", "arms", "dof", "init s", "build s", "steps planned / verified", "result"]
#: Gap between the base's edge and the table edge [m], and the largest table depth used [m].
GAP, MAX_DEPTH = 0.05, 0.8
#: Share of an arm's largest sampled top-down reach a table is sized for: the outer part is the arm stretched
#: to its joint limits, reached exactly from few base poses, and its map values (joint-limit penalties) fall
#: below the planner's threshold (so_arm_base and lift_telescope, sized for their whole reach, planned nothing).
REACH_USE = 0.9
#: Height above the table top [m] a top-down pre-grasp needs (object centre ~5 cm up, 10-15 cm above it).
PRE_GRASP_TOP = 0.25
SPEC = """# Build spec of the {name} maps of the onboarding check (tools/onboard_robots.py). Units: m, rad.
# The preset is the unedited output of `placement robots init`; {millions:g} M samples per arm at 0.1 m keep
# the build to minutes on the 2-core machine.
robot: examples/robots/{name}.yaml
arms: [{arms}]
samples: {samples}
seed: 0
resolution: 0.1
bins: [20, 9, 20]
index: isotropy
format: zarr
"""


def lift_key(robot: Robot) -> str:
    """The build spec's ``torso`` line for the robot's lift: the first fixed joint that is a prismatic
    lift carrying every arm (:func:`~placement.maps.torso.check_torso`), at its lower limit, its held
    value (the middle of its range when that is a limit) and its upper limit [m]; "" when no fixed joint is one (every planned step holds the preset's)."""
    for joint, held in robot.fixed_joints.items():
        jm = robot.model.joints[robot.model.getJointId(joint)]
        lo, hi = float(robot.model.lowerPositionLimit[jm.idx_q]), float(robot.model.upperPositionLimit[jm.idx_q])
        chosen = {round(lo, 3), round(held, 3), round(hi, 3)}
        if len(chosen) == 2:  # held at a limit: the middle too
            chosen.add(round((lo + hi) / 2, 3))
        values = tuple(sorted(chosen))
        try:
            check_torso(robot, robot.arms, TorsoSpec(joint, values))
        except PlacementError:
            continue
        shown = ", ".join(f"{v:g}" for v in values)
        return f"# the lift {joint} at its limits and held value [m]: chosen per step, no extra samples\ntorso: {{joint: {joint}, values: [{shown}]}}\n"
    return ""


def robot_urdf(name: str) -> Path:
    """The URDF/xacro file of ``name``: a key of :data:`ROBOTS` or a path."""
    if name not in ROBOTS:
        return Path(name).resolve()
    where = ROBOTS[name]
    return share_dir() / where if where.startswith(ERD) else ROOT / where


def robot_name(name: str) -> str:
    """The preset name of ``name``: the key, or the file name up to its first dot."""
    return name if name in ROBOTS else Path(name).name.split(".")[0]


def shown_path(urdf: Path) -> str:
    """``urdf`` as the preset's comment shows it: package://..., repository-relative, or absolute."""
    if str(urdf).startswith(str(share_dir())):
        return f"package://{urdf.relative_to(share_dir())}"
    return str(urdf.relative_to(ROOT)) if urdf.is_relative_to(ROOT) else str(urdf)


def table_depth(robot, height: float) -> float:
    """Pick/place table depth [m] for tables ``height`` [m] high: twice what the best arm reaches top-down
    into a table from its grasp to its pre-grasp height (:data:`REACH_USE` of its largest sampled reach),
    beyond the base's circumscribed circle plus :data:`GAP` (objects are approached from both long sides)."""
    best = 0.0
    for arm in robot.arms:
        band = reach_band(robot, arm, "down")
        rows = [s["r_max"] for s in band.profile if height <= s["z"][0] < height + PRE_GRASP_TOP]
        if len(rows) >= 2:
            # the circumscribed radius: the arm's reach may point where the base sticks out most
            best = max(best, REACH_USE * min(rows) - robot.footprint_radius - GAP)
    return round(min(max(2 * best, 0.2), MAX_DEPTH), 2)


def table_height(robot) -> float:
    """Table height [m]: the generator's 0.75 m when every arm's top-down band reaches a pre-grasp
    :data:`PRE_GRASP_TOP` above it, else lowered in 5 cm steps until the best arm's does (a small robot)."""
    from placement.evaluation.generate import TABLE_HEIGHT

    top = max(reach_band(robot, arm, "down").z_max for arm in robot.arms)
    return round(min(TABLE_HEIGHT, math.floor((top - PRE_GRASP_TOP) / 0.05) * 0.05), 2)


def make_scene(name: str, robot, objects: int, root: Path = ROOT) -> Path:
    """``<root>/examples/table_clearing_<name>.yaml``: the seeded generator's scene with tables
    ``table_depth`` deep and ``table_height`` high."""
    from placement.evaluation.generate import TABLE_HEIGHT, generate_scene

    height = table_height(robot)
    depth = table_depth(robot, height)
    # absolute paths while the generator checks the scene (from any working directory), relative ones written
    preset, maps = root / "examples" / "robots" / f"{name}.yaml", root / "maps" / name
    doc = generate_scene(0, 0, objects=objects, preset=str(preset), table_size=(0.8, depth), maps=str(maps))
    for o in doc["obstacles"]:
        if o["name"].startswith("place_table"):
            o["box"]["size"][:2] = [depth, depth]
        if o.get("table"):
            o["box"]["center"][2], o["box"]["size"][2] = height / 2, height
    for o in doc["objects"] + doc["place_locations"]:
        o["position"][2] = round(o["position"][2] - TABLE_HEIGHT + height, 4)
    doc["robot"]["preset"] = f"robots/{name}.yaml"
    doc["maps"] = f"../maps/{name}"
    path = root / "examples" / f"table_clearing_{name}.yaml"
    head = (
        f"# Table clearing sized for {name} (tools/onboard_robots.py): tables {depth} m deep (twice its top-down "
        f"reach into a table) and {height} m high.\n# Units: metres, radians.\n"
    )
    path.write_text(head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path


def independent_search(robot, scene: Path, step, tries: int = 3000, seed: int = 0) -> str:
    """Whether a failed step is really infeasible: random base poses 0.1-0.9 m from the target, clear of
    every obstacle box by the base's circumscribed radius, each tried with IK (1 cm, 0.05 rad, 4 seeds)
    on every candidate trajectory and arm. Returns 'N of M base poses work'."""
    from placement.kinematics.ik import solve_ik
    from placement.planning.problems.grasps import place_candidates, top_grasps

    doc = yaml.safe_load(scene.read_text())
    if step.action == "pick":
        o = next(o for o in doc["objects"] if o["name"] == step.target)
        cands = top_grasps(o["position"], o["yaw"], o["size"])
        p = o["position"]
    else:
        p = next(x for x in doc["place_locations"] if x["name"] == step.target)["position"]
        cands = place_candidates(p)
    rng = np.random.default_rng(seed)
    found = tried = 0
    for _ in range(tries):
        ang, d, yaw = rng.uniform(-math.pi, math.pi), rng.uniform(0.1, 0.9), rng.uniform(-math.pi, math.pi)
        x, y = p[0] + d * math.cos(ang), p[1] + d * math.sin(ang)
        if any(
            math.hypot(
                max(abs(x - b["center"][0]) - b["size"][0] / 2, 0), max(abs(y - b["center"][1]) - b["size"][1] / 2, 0)
            )
            < robot.footprint_radius
            for b in (o["box"] for o in doc["obstacles"])
        ):
            continue
        tried += 1
        B = np.eye(4)
        B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
        B[:2, 3] = x, y
        Bi = np.linalg.inv(B)
        found += any(
            all(solve_ik(robot, arm, Bi @ P, seeds=4, pos_tol=0.01, rot_tol=0.05).success for P in c.poses)
            for c in cands
            for arm in robot.arms
        )
    return f"{found} of {tried} clear base poses work"


def onboard(
    name: str, urdf: Path, samples: int, rebuild: bool, objects: int, root: Path = ROOT, row: dict | None = None
) -> dict:
    """One row of the onboarding table for robot ``name`` from ``urdf``; files under ``root``. ``row`` is
    filled as the steps pass, so a caller catching an error keeps what was measured before it."""
    row = {} if row is None else row
    row["robot"] = name
    preset = root / "examples" / "robots" / f"{name}.yaml"
    preset.parent.mkdir(parents=True, exist_ok=True)
    (root / "maps").mkdir(exist_ok=True)
    t = time.perf_counter()
    p = propose(urdf, preset)
    preset.write_text(render(p, f"placement robots init {shown_path(urdf)} --out examples/robots/{name}.yaml"))
    row["init s"] = round(time.perf_counter() - t, 1)
    robot = load_robot(preset)
    row["arms"] = ", ".join(robot.arms)
    row["dof"] = ", ".join(str(len(robot.arm(a).joints)) for a in robot.arms)
    spec = root / "maps" / f"{name}.yaml"
    if not spec.exists():
        text = SPEC.format(name=name, arms=", ".join(robot.arms), samples=samples, millions=samples / 1e6)
        spec.write_text(text + lift_key(robot))
    out = root / "maps" / name
    row["build s"] = "-"
    if rebuild or not out.exists():
        t = time.perf_counter()
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "placement.cli.main",
                "maps",
                "build",
                "--spec",
                str(spec.relative_to(root)),
                "--out",
                str(out.relative_to(root)),
                "-q",
            ],
            cwd=root,
            capture_output=True,
            text=True,
        )
        if proc.returncode:
            row["result"] = f"build failed: {proc.stderr.strip()[:200]}"
            return row
        row["build s"] = round(time.perf_counter() - t, 1)
    from placement.planning import Planner

    scene = make_scene(name, robot, objects, root)
    result = Planner(scene, "sequential").plan()
    planned = [s for s in result.steps if s.ok]
    problems = result.verify(robot)
    row["steps planned / verified"] = f"{len(planned)}/{len(result.steps)} / {len(planned) - len(problems)}"
    bad = result.failed_step
    row["result"] = (
        "ok"
        if bad is None and not problems
        else (
            f"step {bad.step} ({bad.action} {bad.target}): {bad.reason}; independent IK search: "
            f"{independent_search(robot, scene, bad)}"
            if bad is not None
            else "; ".join(problems)
        )
    )
    return row


def markdown_table(keys: list[str], rows: list[list]) -> str:
    """A Markdown table (header, separator, one line per row)."""
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    return "\n".join(lines + ["| " + " | ".join(str(v) for v in r) + " |" for r in rows]) + "\n"


def read_rows(path: Path) -> list[dict]:
    """The rows of an onboarding table written before (``{column: text}``; none when ``path`` is missing)."""
    if not path.exists():
        return []
    lines = [ln for ln in path.read_text().splitlines() if ln.startswith("|")]
    if len(lines) < 2:
        return []
    keys = [k.strip() for k in lines[0].strip("|").split("|")]
    return [dict(zip(keys, (v.strip() for v in ln.strip("|").split("|")))) for ln in lines[2:]]


def merge_rows(old: list[dict], new: list[dict]) -> list[dict]:
    """The rows of this run replace those of the same robots; the other robots' earlier rows stay (a run
    of a few robots does not drop the rows of the others' maps, which take long to build). Order: the
    earlier table's, then the robots new to it."""
    fresh = {str(r.get("robot")): r for r in new}
    kept = [fresh.pop(str(r.get("robot")), r) for r in old]
    return kept + [r for r in new if str(r.get("robot")) in fresh]


def reach_table(names: list[str], root: Path = ROOT) -> str:
    """The reach bands of ``examples/robots/<name>.yaml`` (as ``placement robots check`` computes them,
    seeded): per arm the 1 %-99 % TCP heights and distances from the base's axis [m] with a top-down and
    a horizontal approach, then the band warnings for a 0.75 m table."""
    rows, warnings = [], []
    span = lambda lo, hi: "-" if not math.isfinite(lo) else f"{lo:.2f} - {hi:.2f}"  # noqa: E731
    for name in names:
        robot = load_robot(root / "examples" / "robots" / f"{name}.yaml")
        held = held_words(robot).removeprefix("with ")
        for arm in robot.arms:
            bands = {ap: reach_band(robot, arm, ap) for ap in APPROACHES}
            down, side = bands["down"], bands["horizontal"]
            rows.append(
                [name, held, arm, span(down.z_min, down.z_max), span(down.r_min, down.r_max)]
                + [span(side.z_min, side.z_max), span(side.r_min, side.r_max)]
            )
            warnings += [f"{name}: {w}" for b in bands.values() for w in band_warnings(robot, b)]
    keys = ["robot", "held", "arm", "top-down heights [m]", "top-down distances [m]"]
    table = markdown_table(keys + ["horizontal heights [m]", "horizontal distances [m]"], rows)
    return table + "".join(f"\n* warning: {w}" for w in warnings) + ("\n" if warnings else "")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--samples", type=int, default=10_000_000, help="samples per arm for a new build spec")
    ap.add_argument("--rebuild", action="store_true", help="build the maps even when they exist")
    ap.add_argument("--objects", type=int, default=4, help="objects per scene")
    ap.add_argument("--reach-only", action="store_true", help="write only the reach bands of the presets as they are")
    ap.add_argument(
        "--root", type=Path, default=ROOT, metavar="DIR", help="write presets, maps, scenes and tables under DIR"
    )
    args = ap.parse_args(argv)
    root = args.root.resolve()
    (root / REACH_MD).parent.mkdir(parents=True, exist_ok=True)
    if args.reach_only:
        write_atomic(root / REACH_MD, reach_table([robot_name(n) for n in args.robots], root))
        print((root / REACH_MD).read_text())
        return 0
    rows: list[dict] = []
    for name in args.robots:
        rows.append({})
        try:
            onboard(robot_name(name), robot_urdf(name), args.samples, args.rebuild, args.objects, root, rows[-1])
        except PlacementError as exc:  # one robot's problem (a preset, a URDF, a scene) ends its row only
            rows[-1]["result"] = f"error: {exc}"
        print(rows[-1], file=sys.stderr)
    merged = merge_rows(read_rows(root / ONBOARDING_MD), rows)
    table = markdown_table(KEYS, [[r.get(k, "-") for k in KEYS] for r in merged])
    write_atomic(root / ONBOARDING_MD, table)
    write_atomic(root / REACH_MD, reach_table([str(r["robot"]) for r in merged], root))
    print(table)
    return 0 if all(r.get("result") == "ok" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
