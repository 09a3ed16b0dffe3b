"""Per-stage planning time of `placement query` (like the paper's Table II), against a baseline release.

For each robot (PR2, ARMAR-6) and scene (the example scene, a generated 6-object scene) it measures,
in fresh processes, with this checkout and with the baseline release (``--baseline REV``, checked
out into build/baseline with ``git worktree``; its maps are this checkout's maps relabelled with the
old format version, same values):

* per-stage medians per placement over ``--runs`` fresh planners (empty caches, warm JIT), so every
  placement pays for its own IRMs, as in the paper;
* the first step of a fresh process (cold map slices, warm JIT cache);
* an update (an object moved) plus the re-planned next placement, on a live planner;
* the default whole-task method ``global``: the whole task per placement on fresh planners, and an
  object moved plus the whole task re-planned, per placement, on a live planner (this checkout only;
  the certificate's bound excluded, it is computed once per scene).

Needs the maps (`make maps`, `make maps-armar6`). Prints a Markdown table and writes it to docs/bench/query.md
(atomically), which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
PAPER = {"navigation": 1.39, "manipulation": 1053.94, "heuristic": 58.20, "combine": 4.93, "total": 1118.49}
STAGES = ("navigation", "manipulation", "heuristic", "combine", "search", "ik", "collision", "total")
ROBOTS = {
    "pr2": ("examples/table_clearing.yaml", "maps/pr2"),
    "armar6": ("examples/table_clearing_armar6.yaml", "maps/armar6"),
}


# -- child: runs inside the measured code's process -------------------------------------------------


def _steps(result) -> list[dict]:
    """The steps of a plan as dicts (typed results and the first release's dicts alike)."""
    return result["steps"] if isinstance(result, dict) else [s.to_json() for s in result.steps]


def child(scene: str, maps: str, runs: int, mode: str) -> dict:
    from placement.planning.planner import Planner

    if mode == "first":  # a fresh process: the first step's own timer
        return {"first": _steps(Planner(scene, "sequential", maps=maps).plan())[0]["timings_ms"]["total"]}
    Planner(scene, "sequential", maps=maps).plan()  # JIT warm-up
    if mode == "stages":
        per: dict[str, list[float]] = {}
        for _ in range(runs):
            for s in _steps(Planner(scene, "sequential", maps=maps).plan()):
                for k, v in s["timings_ms"].items():
                    per.setdefault(k, []).append(v)
        out = {k: statistics.median(v) for k, v in per.items()}
        if "search" not in out:  # releases before the IK/collision split timed the whole search as "ik"
            out["search"] = out.pop("ik", None)
        return out
    if mode == "global":  # the default whole-task method: fresh planners, then updates on a live one
        import time

        per = []
        for _ in range(runs):
            planner = Planner(scene, "global", maps=maps)
            t = time.perf_counter()
            result = planner.plan()
            per.append(((time.perf_counter() - t) * 1e3 - result.certificate.ms) / len(result.steps))
        name = planner.scene.objects[0].name
        x, y, z = (float(v) for v in planner.scene.objects[0].position)
        ups = []
        for k in range(runs * 2):
            t = time.perf_counter()
            planner.update({"objects": [{"name": name, "position": [x + 0.02 * (k % 2 == 0), y, z]}]})
            result = planner.plan()
            ups.append(((time.perf_counter() - t) * 1e3 - result.certificate.ms) / len(result.steps))
        return {"global": statistics.median(per), "global_update": statistics.median(ups)}
    planner = Planner(scene, "sequential", maps=maps)
    first = _steps(planner.plan())[0]
    name = first["target"]
    obj = next(o for o in planner.scene.objects if o.name == name)
    import time

    x, y, z = (float(v) for v in obj.position)
    sx, sy, _ = planner.scene.start
    times: dict[str, list[float]] = {"update": [], "update_obstacle": []}
    for k in range(runs):
        moves = {
            "update": {"objects": [{"name": name, "position": [x + 0.02 * (k % 2), y, z]}]},
            # a crate 1.4 m from the start, moved back and forth by 10 cm
            "update_obstacle": {
                "obstacles": {
                    "add": [
                        {
                            "name": f"crate{k}",
                            "box": {"center": [sx + 1.0 + 0.1 * (k % 2), sy - 1.0, 0.3], "size": [0.4, 0.4, 0.6]},
                        }
                    ],
                    "remove": [f"crate{k - 1}"] if k else [],
                }
            },
        }
        for key, change in moves.items():
            t = time.perf_counter()
            planner.update(change)
            update_ms = (time.perf_counter() - t) * 1e3
            times[key].append(update_ms + _steps(planner.plan())[0]["timings_ms"]["total"])
    return {k: statistics.median(v) for k, v in times.items()}


# -- parent ------------------------------------------------------------------------------------------


def _run(code_dir: Path, scene: Path, maps: Path, runs: int, mode: str, cache: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(code_dir), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--child", str(scene), str(maps), str(runs), mode],
        capture_output=True,
        text=True,
        env=env,
        cwd=code_dir,
    )
    if out.returncode != 0:
        raise SystemExit(f"{code_dir}: {mode} on {scene.name} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _measure(code_dir: Path, scene: Path, maps: Path, runs: int, cache: Path) -> dict:
    res = _run(code_dir, scene, maps, runs, "stages", cache)
    if code_dir == ROOT:  # the baseline has no whole-task method
        res.update(_run(code_dir, scene, maps, runs, "global", cache))
    res["first"] = statistics.median(_run(code_dir, scene, maps, 0, "first", cache)["first"] for _ in range(3))
    res.update(_run(code_dir, scene, maps, runs * 2, "update", cache))
    return res


def _baseline(rev: str, build: Path) -> Path:
    """The baseline release's code in build/baseline (a git worktree at ``rev``)."""
    path = build / "baseline"
    if path.exists():
        subprocess.run(["git", "worktree", "remove", "--force", str(path)], cwd=ROOT, capture_output=True)
        shutil.rmtree(path, ignore_errors=True)
    subprocess.run(["git", "worktree", "add", "--detach", str(path), rev], cwd=ROOT, check=True, capture_output=True)
    return path


def _old_maps(maps: Path, dest: Path, version: int) -> Path:
    """A copy of ``maps`` labelled with an older format version (same arrays, same values)."""
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(maps, dest)
    meta = json.loads((dest / "zarr.json").read_text())
    meta["attributes"]["placement_map"]["format_version"] = version
    (dest / "zarr.json").write_text(json.dumps(meta))
    return dest


def _scenes(robot: str, example: str, build: Path, maps: Path) -> list[Path]:
    """The example scene and a generated 6-object scene for ``robot`` (maps keys point at ``maps``)."""
    import yaml

    from placement.evaluation.generate import generate_scene

    out = []
    doc = yaml.safe_load((ROOT / example).read_text())
    doc["maps"] = str(maps)
    if doc["robot"]["preset"].endswith(".yaml"):  # a preset file, relative to the example
        doc["robot"]["preset"] = str((ROOT / example).parent / doc["robot"]["preset"])
    path = build / f"{robot}_example.yaml"
    path.write_text(yaml.safe_dump(doc))
    out.append(path)
    preset = "pr2" if robot == "pr2" else str(ROOT / "examples/robots/armar6.yaml")
    gen = generate_scene(1, 0, objects=6, obstacles=False, preset=preset, maps=str(maps))
    path = build / f"{robot}_generated.yaml"
    path.write_text(yaml.safe_dump(gen))
    out.append(path)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="fresh planners per scene (medians over their placements)")
    ap.add_argument(
        "--baseline",
        default=os.environ.get("BASELINE", "d44e44e"),
        help="git revision of the baseline (default: the planner before its planning layer was restructured)",
    )
    ap.add_argument("--baseline-format", type=int, default=1, help="map format version the baseline reads")
    ap.add_argument("--robots", default="pr2,armar6")
    args = ap.parse_args(argv)
    build = ROOT / "build" / "bench-query"
    build.mkdir(parents=True, exist_ok=True)
    base_dir = _baseline(args.baseline, build)
    rows, lines = [], []
    for robot in args.robots.split(","):
        example, maps = ROBOTS[robot]
        maps = ROOT / maps
        if not (maps / "zarr.json").exists():
            raise SystemExit(f"{maps} is missing: run `make maps` (PR2) or `make maps-armar6`")
        old_maps = _old_maps(maps, build / f"{robot}-maps-v{args.baseline_format}", args.baseline_format)
        for scene in _scenes(robot, example, build, maps):
            now = _measure(ROOT, scene, maps, args.runs, ROOT / ".venv" / "numba-cache")
            old_scene = build / f"{scene.stem}_baseline.yaml"
            old_scene.write_text(scene.read_text().replace(str(maps), str(old_maps)))
            old = _measure(base_dir, old_scene, old_maps, args.runs, build / "baseline-numba-cache")
            rows.append((robot, scene.stem.split("_", 1)[1], old, now))
    lines.append(
        f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}; baseline {args.baseline}; medians per placement over {args.runs} fresh "
        "planners per scene [ms]"
    )
    lines.append("")
    lines.append("| robot | scene | stage | baseline | now | speed-up | paper |")
    lines.append("|---|---|---|---|---|---|---|")
    for robot, scene, old, now in rows:
        for k in (*STAGES, "first", "update", "update_obstacle", "global", "global_update"):
            label = {
                "first": "first step, fresh process",
                "update": "object moved + next placement",
                "update_obstacle": "obstacle moved + next placement",
                "global": "global (default): whole task, per placement",
                "global_update": "global: object moved + whole task re-planned, per placement",
            }.get(k, k)
            o, n = old.get(k), now.get(k)
            ratio = f"{o / n:.2f}x" if o and n else "-"
            fo, fn = (f"{v:.2f}" if v is not None else "-" for v in (o, n))
            lines.append(f"| {robot} | {scene} | {label} | {fo} | {fn} | {ratio} | {PAPER.get(k, '-')} |")
    text = "\n".join(lines)
    write_atomic(ROOT / "docs/bench/query.md", text + "\n")
    print(text)
    subprocess.run(["git", "worktree", "remove", "--force", str(base_dir)], cwd=ROOT, capture_output=True)
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        print(json.dumps(child(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])))
        sys.exit(0)
    sys.exit(main())
