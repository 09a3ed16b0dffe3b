"""The cost of the largest inputs a scene may hold: each planned by `placement query` in its own process.

Every case is a scene at a documented limit (``placement/scene/limits.py``, ``docs/scenes.md``): 100
pick/place pairs on two generated rooms side by side, the same with 360 place yaws, with 2,000 grasps
per object, with the IK budget at its 60 s maximum on steps no placement verifies, and 100 reach steps
each choosing among trajectories of 100 poses. For each case and method: the exit code, the steps
planned, the wall time of the whole command (parsing, opening the maps, planning, certificate) and the
process's peak memory (``ru_maxrss``). A case passes when it ends within ``--limit`` seconds (60 by
default, the budget issue 34 sets) with a plan, a partial plan or one error line.

    python tools/bench_limits.py [--maps maps/pr2] [--cases pairs,yaws,...] [--limit 60]

Writes the table to docs/bench/limits.md (atomically), which docs/scenes.md cites.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from scipy.spatial.transform import Rotation  # noqa: E402

from placement.evaluation.generate import generate_scene  # noqa: E402

ROOM = 10.0  # [m] width of a generated room along x


def two_rooms(maps: str) -> dict[str, Any]:
    """100 pick/place pairs: two generated 50-object rooms with crates, side by side, the wall between
    them opened by a 2 m door."""
    a = generate_scene(11, 0, objects=50, obstacles=True, maps=maps)
    b = generate_scene(11, 1, objects=50, obstacles=True, maps=maps)

    def moved(entry: dict[str, Any], key: str, dx: float) -> dict[str, Any]:
        e = copy.deepcopy(entry)
        e["name"] = f"{e['name']}_b"
        if "box" in e:
            e["box"]["center"][0] += dx
        else:
            e[key][0] += dx
        return e

    doc = copy.deepcopy(a)
    doc["bounds"] = [0.0, 0.0, 2 * ROOM, a["bounds"][3]]
    walls = [o for o in doc["obstacles"] if o["name"] == "wall_east"]
    for w in walls:  # a door in the middle of the shared wall
        doc["obstacles"].remove(w)
        h = w["box"]["size"][1]
        for name, lo, hi in (("wall_mid_s", 0.0, h / 2 - 1.0), ("wall_mid_n", h / 2 + 1.0, h)):
            doc["obstacles"].append(
                {"name": name, "box": {"center": [ROOM, (lo + hi) / 2, 1.0], "size": [0.1, hi - lo, 2.0]}}
            )
    for o in b["obstacles"]:
        if o["name"] in ("wall_west", "wall_east"):
            if o["name"] == "wall_east":
                doc["obstacles"].append(moved(o, "box", ROOM))
            continue
        doc["obstacles"].append(moved(o, "box", ROOM))
    doc["objects"] += [moved(o, "position", ROOM) for o in b["objects"]]
    doc["place_locations"] += [moved(p, "position", ROOM) for p in b["place_locations"]]
    doc["task"] += [{"pick": f"{t['pick']}_b", "place": f"{t['place']}_b"} for t in b["task"]]
    return doc


def with_planner(doc: dict[str, Any], **keys: Any) -> dict[str, Any]:
    doc = copy.deepcopy(doc)
    doc.setdefault("planner", {}).update(keys)
    return doc


def many_grasps(doc: dict[str, Any], per_object: int) -> dict[str, Any]:
    """Version 2, every object with ``per_object`` top grasps (a pre-grasp 10 cm above, the gripper
    turned about the vertical), as many as the 2 MiB scene file holds (flow style, short numbers)."""
    doc = copy.deepcopy(doc)
    doc["version"] = 2
    for o in doc["objects"]:
        top = round(o["size"][2] / 2, 3)
        grasps = []
        for k in range(per_object):
            q = Rotation.from_euler("zy", [math.pi * k / per_object, math.pi / 2]).as_quat()  # x y z w, down
            q = [round(float(v), 8) for v in q]  # a unit quaternion within 1e-6
            grasps.append({"name": f"g{k}", "poses": [[0, 0, top + 0.1, *q], [0, 0, top, *q]]})
        o["grasps"] = grasps
    return doc


def dumped(doc: dict[str, Any]) -> str:
    return yaml.safe_dump(doc, default_flow_style=None, width=1 << 20)


def most_grasps(doc: dict[str, Any]) -> dict[str, Any]:
    """:func:`many_grasps` with the most grasps per object whose scene file is at most 2 MiB."""
    lo, hi = 1, 2000
    while lo < hi:
        mid = (lo + hi + 1) // 2
        lo, hi = (mid, hi) if len(dumped(many_grasps(doc, mid))) <= 2 * 2**20 else (lo, mid - 1)
    return many_grasps(doc, lo)


def reaches(doc: dict[str, Any], entries: int, choices: int, poses: int) -> dict[str, Any]:
    """Version 2, ``entries`` reach steps, each choosing among ``choices`` trajectories of ``poses``
    poses above a pick table (a straight line down, the gripper pointing down)."""
    doc = copy.deepcopy(doc)
    doc["version"] = 2
    tables = [o["box"] for o in doc["obstacles"] if o.get("table")]
    trajectories, task = [], []
    for e in range(entries):
        t = tables[e % len(tables)]
        x, y, top = t["center"][0], t["center"][1], t["center"][2] + t["size"][2] / 2
        names = []
        for c in range(choices):
            dx = (c % 10 - 4.5) * 0.02
            dy = (c // 10 % 10 - 4.5) * 0.02
            line = [
                [
                    round(x + dx, 3),
                    round(y + dy, 3),
                    round(top + 0.3 - 0.2 * i / max(poses - 1, 1), 4),
                    0,
                    0.70710678,
                    0,
                    0.70710678,
                ]
                for i in range(poses)
            ]
            names.append(f"r{e}_{c}")
            trajectories.append({"name": names[-1], "poses": line})
        task.append({"reach": names})
    doc["trajectories"] = trajectories
    doc["task"] = task
    doc["objects"] = []
    doc["place_locations"] = []
    return doc


def lidded(doc: dict[str, Any]) -> dict[str, Any]:
    """Every pick table under a low lid 5 cm above its objects: the maps allow placements, IK and the
    collision check reject them all, so each step's IK search runs to its budget."""
    doc = copy.deepcopy(doc)
    for o in list(doc["obstacles"]):
        if o.get("table"):
            b = o["box"]
            top = b["center"][2] + b["size"][2] / 2
            doc["obstacles"].append(
                {
                    "name": f"{o['name']}_lid",
                    "box": {
                        "center": [b["center"][0], b["center"][1], top + 0.35],
                        "size": [b["size"][0], b["size"][1], 0.02],
                    },
                }
            )
    return doc


#: Runs the command as its only child and prints the child's peak memory [KiB] on stderr's last line.
_MEASURED = (
    "import resource, subprocess, sys\n"
    "r = subprocess.run(sys.argv[1:])\n"
    "sys.stderr.write(f'\\nmaxrss {resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}\\n')\n"
    "sys.exit(r.returncode)\n"
)


def run(scene: Path, maps: str, method: str, limit: float) -> dict[str, Any]:
    cmd = [str(ROOT / ".venv/bin/placement"), "query", str(scene), "--maps", maps, "--method", method, "--json", "-q"]
    t0 = time.perf_counter()
    p = subprocess.Popen(
        [sys.executable, "-c", _MEASURED, *cmd],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = p.communicate(timeout=limit * 3)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, 9)
        out, err = p.communicate()
    wall = time.perf_counter() - t0
    lines = [line for line in err.splitlines() if line.strip()]
    rss = int(lines.pop().split()[1]) / 2**20 if lines and lines[-1].startswith("maxrss") else None
    try:
        doc = json.loads(out)
        steps = doc.get("steps", [])
        planned = f"{sum(s.get('status', 'ok') == 'ok' for s in steps)}/{len(steps)}"
        first_bad = next((s.get("reason") or "" for s in steps if s.get("status", "ok") != "ok"), "")
    except (json.JSONDecodeError, AttributeError):
        planned, first_bad = "-", (lines or [""])[-1]
    return {"rc": p.returncode, "wall": wall, "planned": planned, "said": first_bad[:110], "rss": rss}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="maps/pr2")
    ap.add_argument("--cases", default="pairs,yaws,grasps,ik,reach")
    ap.add_argument("--limit", type=float, default=60.0)
    ap.add_argument("--out", default=str(ROOT / "docs/bench/limits.md"))
    args = ap.parse_args()
    maps = str(Path(args.maps).resolve())
    base = two_rooms(maps)
    cases: dict[str, tuple[str, Callable[[], dict[str, Any]], tuple[str, ...]]] = {
        "pairs": (
            "100 pick/place pairs (two rooms, crates)",
            lambda: base,
            ("global", "sequential", "single-step", "irm", "fixed", "optimal"),
        ),
        "yaws": ("100 pairs, `grasp_yaws: 360`", lambda: with_planner(base, grasp_yaws=360), ("global", "sequential")),
        "grasps": (
            "100 pairs, as many grasps per object as a 2 MiB file holds",
            lambda: most_grasps(base),
            ("global", "sequential"),
        ),
        "ik": (
            "100 pairs under lids, `ik_budget_ms: 60000`",
            lambda: with_planner(lidded(base), ik_budget_ms=60000),
            ("global", "sequential"),
        ),
        "reach": (
            "100 reaches of 3 trajectories x 100 poses",
            lambda: reaches(base, 100, 3, 100),
            ("global", "sequential"),
        ),
    }
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for key in args.cases.split(","):
            title, make, methods = cases[key]
            path = Path(tmp) / f"{key}.yaml"
            doc = make()
            path.write_text(dumped(doc))
            if key == "grasps":
                title = f"100 pairs, {len(doc['objects'][0]['grasps'])} grasps per object"
            size = path.stat().st_size
            for m in methods:
                r = run(path, maps, m, args.limit)
                rows.append((title, size, m, r))
                print(
                    f"{key:7s} {m:12s} rc={r['rc']} {r['wall']:6.1f} s {r['rss']} GiB {r['planned']:>8s} {r['said']}",
                    flush=True,
                )
    lines = [
        "| input | scene file | method | exit | steps planned | wall [s] | peak memory [GiB] | first unplanned step says |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for title, size, m, r in rows:
        lines.append(
            f"| {title} | {size / 2**20:.2f} MiB | `{m}` | {r['rc']} | {r['planned']} | {r['wall']:.1f} | "
            f"{'-' if r['rss'] is None else format(r['rss'], '.2f')} | {r['said']} |"
        )
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores"
    text = (
        "<!-- written by tools/bench_limits.py -->\n"
        f"The largest accepted scenes, each `placement query --json` in its own process ({machine}; wall time of "
        "the whole command: parsing, maps, planning and certificate).\n\n" + "\n".join(lines) + "\n"
    )
    write_atomic(Path(args.out), text)


if __name__ == "__main__":
    main()
