"""Onboard robots from their URDFs end to end and print a markdown table (issue 9, generality).

For each robot: ``placement robots init`` -> ``examples/robots/<robot>.yaml`` (unedited), a build spec
``maps/<robot>.yaml`` (written when missing), ``placement maps build`` -> ``maps/<robot>`` (skipped when
the maps exist, unless --rebuild), a table-clearing scene sized for the robot from its top-down reach
band -> ``examples/table_clearing_<robot>.yaml``, planned with ``Planner`` and every planned step checked by
``PlanResult.verify`` (independent pinocchio FK).

    python tools/onboard_robots.py [ROBOT ...] [--samples N] [--rebuild] [--objects K]

ROBOT is a key of :data:`ROBOTS` or a path to a URDF/xacro file. Run from the repository root.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from placement.robots import load_robot  # noqa: E402
from placement.robots.init import propose  # noqa: E402
from placement.robots.init_render import render  # noqa: E402
from placement.robots.reach import base_clearance, reach_band  # noqa: E402
from placement.robots.spec import share_dir  # noqa: E402

ERD = "example-robot-data/robots/"
ROBOTS = {"tiago": ERD + "tiago_description/robots/tiago.urdf",
          "talos_reduced": ERD + "talos_data/robots/talos_reduced.urdf",
          "romeo": ERD + "romeo_description/urdf/romeo.urdf"}
#: Heights [m] of the objects' grasp poses and their pre-grasps on 0.75 m tables.
GRASP_BAND = (0.80, 0.95)
#: Gap between the base's edge and the table edge [m], and the largest table depth used [m].
GAP, MAX_DEPTH = 0.05, 0.8
SPEC = """# Build spec of the {name} maps of the onboarding check (issue 9, tools/onboard_robots.py). Units: m, rad.
# The preset is the unedited output of `placement robots init`; 10 M samples per arm at 0.1 m keep the
# build to minutes on the 2-core machine.
robot: examples/robots/{name}.yaml
arms: [{arms}]
samples: {samples}
seed: 0
resolution: 0.1
bins: [20, 9, 20]
index: isotropy
format: zarr
"""


def table_depth(robot) -> float:
    """Pick/place table depth [m]: twice what the best arm reaches top-down into a table at the grasp
    heights, from the base's edge plus :data:`GAP` (objects are approached from both long sides)."""
    best = 0.0
    for arm in robot.arms:
        band = reach_band(robot, arm, "down")
        rows = [s["r_max"] for s in band.profile if GRASP_BAND[0] - 0.05 <= s["z"][0] < GRASP_BAND[1]]
        if len(rows) >= 2:
            best = max(best, min(rows) - base_clearance(robot) - GAP)
    return round(min(max(2 * best, 0.2), MAX_DEPTH), 2)


def make_scene(name: str, robot, objects: int) -> Path:
    """``examples/table_clearing_<name>.yaml``: the seeded generator's scene with tables ``table_depth`` deep."""
    from placement.evaluation.generate import generate_scene

    depth = table_depth(robot)
    doc = generate_scene(0, 0, objects=objects, preset=f"examples/robots/{name}.yaml", table_size=(0.8, depth),
                         maps=f"maps/{name}")
    for o in doc["obstacles"]:
        if o["name"].startswith("place_table"):
            o["box"]["size"][:2] = [depth, depth]
    doc["robot"]["preset"] = f"robots/{name}.yaml"
    doc["maps"] = f"../maps/{name}"
    path = ROOT / "examples" / f"table_clearing_{name}.yaml"
    head = (f"# Table clearing sized for {name} (tools/onboard_robots.py): tables {depth} m deep, twice its top-down "
            "reach into a table.\n# Units: metres, radians.\n")
    path.write_text(head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path


def onboard(name: str, urdf: Path, samples: int, rebuild: bool, objects: int) -> dict:
    row = {"robot": name}
    preset = ROOT / "examples" / "robots" / f"{name}.yaml"
    t = time.perf_counter()
    p = propose(urdf, preset)
    rel = f"package://{urdf.relative_to(share_dir())}" if str(urdf).startswith(str(share_dir())) else str(urdf)
    preset.write_text(render(p, f"placement robots init {rel} --out examples/robots/{name}.yaml"))
    row["init s"] = round(time.perf_counter() - t, 1)
    robot = load_robot(preset)
    row["arms"] = ", ".join(robot.arms)
    row["dof"] = ", ".join(str(len(robot.arm(a).joints)) for a in robot.arms)
    spec = ROOT / "maps" / f"{name}.yaml"
    if not spec.exists():
        spec.write_text(SPEC.format(name=name, arms=", ".join(robot.arms), samples=samples))
    out = ROOT / "maps" / name
    row["build s"] = "-"
    if rebuild or not out.exists():
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "placement.cli.main", "maps", "build", "--spec",
                               str(spec.relative_to(ROOT)), "--out", str(out.relative_to(ROOT)), "-q"], cwd=ROOT,
                              capture_output=True, text=True)
        if proc.returncode:
            row["result"] = f"build failed: {proc.stderr.strip()[:200]}"
            return row
        row["build s"] = round(time.perf_counter() - t, 1)
    from placement.planning import Planner

    scene = make_scene(name, robot, objects)
    result = Planner(scene, "sequential").plan()
    planned = [s for s in result.steps if s.ok]
    problems = result.verify(robot)
    row["steps planned / verified"] = f"{len(planned)}/{len(result.steps)} / {len(planned) - len(problems)}"
    bad = result.failed_step
    row["result"] = "ok" if bad is None and not problems else (
        f"step {bad.step} ({bad.action} {bad.target}): {bad.reason}" if bad is not None else "; ".join(problems))
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--samples", type=int, default=10_000_000, help="samples per arm for a new build spec")
    ap.add_argument("--rebuild", action="store_true", help="build the maps even when they exist")
    ap.add_argument("--objects", type=int, default=4, help="objects per scene")
    args = ap.parse_args(argv)
    rows = []
    for name in args.robots:
        urdf = share_dir() / ROBOTS[name] if name in ROBOTS else Path(name)
        rows.append(onboard(name if name in ROBOTS else urdf.stem.split(".")[0], urdf, args.samples, args.rebuild,
                            args.objects))
        print(rows[-1], file=sys.stderr)
    keys = ["robot", "arms", "dof", "init s", "build s", "steps planned / verified", "result"]
    print("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(str(r.get(k, "-")) for k in keys) + " |")
    return 0 if all(r.get("result") == "ok" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
