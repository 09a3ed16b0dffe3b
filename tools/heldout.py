"""Held-out scenes checked independently (issues 8 and 9, "How good"): a markdown table per robot.

For each robot: N generated table-clearing scenes (the PR2: the generator's own sizes, half of them
with crates; tiago / talos_reduced: ``examples/table_clearing_<robot>.yaml`` and N - 1 variants of it:
other seeds of the generator with that file's table sizes and heights), planned with ``Planner``
(collisions on) and every planned step checked by pinocchio FK (``PlanResult.verify``) and by the
independent collision check of ``tests/oracle_collision.py`` (the robot's URDF shapes and the scene
built there, coal on every pair, the carried object fixed to the TCP, the base footprint exactly in
2D), and every transfer from the plan JSON alone: hand changes between a pick and its place, and
objects set down tilted more than 6 degrees from how they were picked.

    python tools/heldout.py [--scenes N] [--objects K] [--robots pr2 tiago talos_reduced romeo]

Maps: maps/<robot> of this checkout (`make maps`, `make robots`; a robot without them is skipped).
Run from the repository root; prints the table on stdout, one line per scene on stderr.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from oracle_collision import IndependentCheck  # noqa: E402

from placement.evaluation.generate import TABLE_HEIGHT, generate_scene  # noqa: E402
from placement.planning import Planner  # noqa: E402
from placement.scene.poses import quaternion_matrix  # noqa: E402

MAPS = {"pr2": ROOT / "maps" / "pr2"}
ONBOARD_MAPS = ROOT / "maps"
KEYS = [
    "robot",
    "scenes",
    "steps planned",
    "infeasible",
    "FK-verified",
    "collision-free (independent)",
    "footprint clear",
    "smallest clearance [m]",
    "clearance = independent (1 mm)",
    "hand changes",
    "objects tilted > 6 deg",
]


def transfer_faults(doc: dict) -> tuple[int, int]:
    """(places by another arm or grasp than their pick, places whose object turns more than 6 degrees
    away from upright as picked), read from the plan JSON alone: the object is rigid in the hand, so
    its turn is the TCP's from the grasp pose to the place pose."""
    picks, changes, tilted = {}, 0, 0
    for s in doc["steps"]:
        if s.get("status", "ok") != "ok":
            continue
        if s["action"] == "pick":
            picks[s["target"]] = s
        elif s["action"] == "place":
            pick = picks[s["object"]]
            changes += (pick["arm"], pick["grasp"]) != (s["arm"], s["grasp"])
            R = quaternion_matrix(s["tcp"][-1][3:]) @ quaternion_matrix(pick["tcp"][-1][3:]).T
            tilted += int(R[2, 2] < math.cos(math.radians(6.0)))
    return changes, tilted


def pr2_scenes(n: int, objects: int) -> list[dict]:
    out = []
    for k in range(n):
        doc = generate_scene(100 + k, k, objects=objects, obstacles=bool(k % 2), maps=str(MAPS["pr2"]))
        out.append(doc)
    return out


def robot_scenes(robot: str, n: int, objects: int) -> list[dict]:
    """The robot's example scene and n - 1 generated variants with its tables (sizes, heights)."""
    example = ROOT / "examples" / f"table_clearing_{robot}.yaml"
    base = yaml.safe_load(example.read_text())
    preset = str((example.parent / base["robot"]["preset"]).resolve())
    maps = str(ONBOARD_MAPS / robot)
    base["robot"]["preset"], base["maps"] = preset, maps
    tables = {o["name"]: o["box"] for o in base["obstacles"] if o.get("table")}
    pick = tables["pick_table_1"]
    height = pick["size"][2]
    out = [base]
    for k in range(1, n):
        doc = generate_scene(
            200 + k,
            k,
            objects=objects,
            obstacles=bool(k % 2),
            preset=preset,
            table_size=tuple(pick["size"][:2]),
            maps=maps,
        )
        for o in doc["obstacles"]:
            if o.get("table"):
                o["box"]["size"][:2] = tables[o["name"]]["size"][:2]
                o["box"]["center"][2], o["box"]["size"][2] = height / 2, height
        for o in doc["objects"] + doc["place_locations"]:
            o["position"][2] = round(o["position"][2] - TABLE_HEIGHT + height, 4)
        out.append(doc)
    return out


def run(robot: str, docs: list[dict], tmp: Path) -> dict:
    row = dict.fromkeys(KEYS, 0)
    row.update({"robot": robot, "scenes": len(docs), "smallest clearance [m]": math.inf})
    for i, doc in enumerate(docs):
        path = tmp / f"{robot}_{i}.yaml"
        path.write_text(yaml.safe_dump(doc))
        planner = Planner(path)
        result = planner.plan()
        planned = [s for s in result.steps if s.ok]
        problems = result.verify(planner.robot)
        checks = IndependentCheck(planner.robot, planner.scene).check_plan(result.to_json())
        pad = planner.base_config.collision_padding
        free = [c.free and c.scene_m >= pad and c.held_m >= pad and c.object_m >= pad for c in checks]
        fp = [c.footprint_m is None or c.footprint_m >= planner.base_config.footprint_padding - 1e-9 for c in checks]
        agree = [abs(s.clearance_m - c.clearance(0.2)) <= 1e-3 for s, c in zip(planned, checks)]
        row["steps planned"] += len(planned)
        row["infeasible"] += len(result.steps) - len(planned)
        row["FK-verified"] += len(planned) - len({p.split(":")[0] for p in problems})
        row["collision-free (independent)"] += sum(free)
        row["footprint clear"] += sum(fp)
        row["clearance = independent (1 mm)"] += sum(agree)
        row["smallest clearance [m]"] = min([row["smallest clearance [m]"]] + [c.clearance(0.2) for c in checks])
        changes, tilted = transfer_faults(result.to_json())
        row["hand changes"] += changes
        row["objects tilted > 6 deg"] += tilted
        bad = result.failed_step
        print(
            f"{robot} scene {i}: {len(planned)} planned, {sum(free)} free, problems {problems[:2]}"
            + (f"; step {bad.step} infeasible: {bad.reason[:300]}" if bad else ""),
            file=sys.stderr,
        )
        for s, c in zip(planned, checks):
            if c.scene_hits or c.self_hits or c.object_hits:
                print(f"  step {s.step}: {c.scene_hits[:3]} {c.self_hits[:3]} {c.object_hits[:3]}", file=sys.stderr)
    row["smallest clearance [m]"] = f"{row['smallest clearance [m]']:.4f}"
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=4, help="scenes per robot")
    ap.add_argument("--objects", type=int, default=4, help="objects per generated scene")
    ap.add_argument("--robots", nargs="*", default=["pr2", "tiago", "talos_reduced", "romeo"])
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for robot in args.robots:
            maps = MAPS.get(robot, ONBOARD_MAPS / robot)
            if not (maps / "zarr.json").exists() and not any(maps.glob("*/zarr.json")):
                print(f"{robot}: no maps at {maps}, skipped", file=sys.stderr)
                continue
            docs = (
                pr2_scenes(args.scenes, args.objects)
                if robot == "pr2"
                else robot_scenes(robot, args.scenes, args.objects)
            )
            rows.append(run(robot, docs, Path(tmp)))
    print("| " + " | ".join(KEYS) + " |\n|" + "---|" * len(KEYS))
    for r in rows:
        print("| " + " | ".join(str(r[k]) for k in KEYS) + " |")
    bad = [
        r
        for r in rows
        if r["collision-free (independent)"] != r["steps planned"]
        or r["FK-verified"] != r["steps planned"]
        or r["hand changes"]
        or r["objects tilted > 6 deg"]
    ]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
