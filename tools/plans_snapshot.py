"""Snapshot the plans of every method on a set of scenes, and compare two snapshots.

A refactor of the planner should not change its plans. Take a snapshot with the code before it and
one with the code after it (same maps, same scenes, same command line), then compare::

    PYTHONPATH=<old checkout> python tools/plans_snapshot.py --maps DIR --out before.json SCENES...
    PYTHONPATH=<new checkout> python tools/plans_snapshot.py --maps DIR --out after.json SCENES...
    python tools/plans_snapshot.py --compare before.json after.json

SCENES are scene files or folders (their ``*.yaml``, sorted). Each scene is planned with a fresh
``Planner(scene, method, maps=DIR)`` for every method in ``placement.planning.METHODS``, with the
IK time budget raised to ``--ik-budget-ms`` (default 60000 ms, the largest a scene may set) so
that the machine's speed does not decide which placements the IK search gets to try. The plan
documents (``PlanResult.to_json()``) are stored without their wall-clock timings (keys starting
with ``timings`` or ending in ``_ms``); modelled quantities such as ``travel_time_s`` are kept. A
planner error is stored as ``{"error": "<class>: <message>"}``, so it is compared too.

``--compare A B`` prints every difference (scene, method, JSON path, both values; floats compared
exactly) and exits 1 if there is any, 0 if the snapshots hold identical plans.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

#: Most differences printed by --compare (the count of all is printed anyway).
MAX_SHOWN = 200


def is_timing(key: str) -> bool:
    """Whether a plan document's key holds wall-clock timings (which differ run to run)."""
    return key.startswith("timings") or key.endswith("_ms")


def without_timings(doc: Any) -> Any:
    """``doc`` (a JSON value) with every timing key removed, at any depth."""
    if isinstance(doc, dict):
        return {k: without_timings(v) for k, v in doc.items() if not is_timing(k)}
    if isinstance(doc, list):
        return [without_timings(v) for v in doc]
    return doc


def scene_files(args: list[str]) -> list[Path]:
    """The scene files named by ``args``: files as given, folders as their sorted ``*.yaml``."""
    out: list[Path] = []
    for arg in args:
        path = Path(arg)
        if path.is_dir():
            found = sorted(path.glob("*.yaml"))
            if not found:
                raise SystemExit(f"plans_snapshot: folder {path} holds no *.yaml scene")
            out += found
        elif path.is_file():
            out.append(path)
        else:
            raise SystemExit(f"plans_snapshot: scene {path} does not exist")
    return out


def plan_all(scenes: list[Path], maps: Path, ik_budget_ms: float) -> dict[str, Any]:
    """The snapshot document: ``plans[scene][method]`` -> timing-free plan (or error)."""
    import placement
    from placement.planning import METHODS, Planner, load_scene

    plans: dict[str, dict[str, Any]] = {}
    for path in scenes:
        scene = load_scene(path)
        # the budget through the scene's planner block, as a scene file would set it
        scene = dataclasses.replace(scene, planner={**scene.planner, "ik_budget_ms": float(ik_budget_ms)})
        plans[str(path)] = {}
        for method in METHODS:
            t0 = time.perf_counter()
            try:
                doc = without_timings(Planner(scene, method, maps=maps).plan().to_json())
            except Exception as exc:  # a planner error is part of the snapshot
                doc = {"error": f"{type(exc).__name__}: {exc}"}
            plans[str(path)][method] = doc
            status = doc.get("status", doc.get("error"))
            print(f"{path} {method}: {status} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr, flush=True)
    meta = {"placement": str(Path(placement.__file__).parent), "maps": str(maps), "ik_budget_ms": ik_budget_ms}
    return {"meta": meta, "methods": list(METHODS), "plans": plans}


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Every place where JSON values ``a`` and ``b`` differ, as ``path: a != b`` lines."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in list(a) + [k for k in b if k not in a]:
            if key not in b:
                out.append(f"{where}.{key}: only in A ({json.dumps(a[key])[:200]})")
            elif key not in a:
                out.append(f"{where}.{key}: only in B ({json.dumps(b[key])[:200]})")
            else:
                out += differences(a[key], b[key], f"{where}.{key}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        out = [f"{where}: length {len(a)} != {len(b)}"] if len(a) != len(b) else []
        for i, (x, y) in enumerate(zip(a, b)):
            out += differences(x, y, f"{where}[{i}]")
        return out
    if type(a) is not type(b) or a != b:
        return [f"{where}: {json.dumps(a)[:200]} != {json.dumps(b)[:200]}"]
    return []


def read_snapshot(path: Path) -> dict[str, Any]:
    """A snapshot file written by this tool (SystemExit naming the file if it is not one)."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise SystemExit(f"plans_snapshot: cannot read snapshot {path}: {exc}") from None
    if not isinstance(doc, dict) or not {"methods", "plans"} <= doc.keys():
        raise SystemExit(f"plans_snapshot: {path} is not a plans snapshot (no 'methods' and 'plans')")
    return doc


def compare(path_a: Path, path_b: Path) -> int:
    """Print the differences between two snapshots' plans; 1 if any, else 0."""
    a, b = (read_snapshot(p) for p in (path_a, path_b))
    diffs = []
    if a["methods"] != b["methods"]:
        diffs.append(f"methods: {a['methods']} != {b['methods']}")
    diffs += differences(a["plans"], b["plans"], "plans")
    count = sum(len(m) for m in a["plans"].values())
    for line in diffs[:MAX_SHOWN]:
        print(line)
    if len(diffs) > MAX_SHOWN:
        print(f"... and {len(diffs) - MAX_SHOWN} more")
    verdict = "identical" if not diffs else f"{len(diffs)} differences"
    print(f"{count} plans in A ({len(a['plans'])} scenes), {verdict}")
    return 1 if diffs else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", metavar="SCENES", help="scene files or folders of *.yaml scenes")
    ap.add_argument("--maps", type=Path, help="reachability maps every scene is planned with")
    ap.add_argument("--out", type=Path, help="snapshot file to write (JSON)")
    ap.add_argument(
        "--ik-budget-ms",
        type=float,
        default=60000.0,
        help="IK time budget of one step [ms], 1 to 60000 (default 60000)",
    )
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("A", "B"), help="compare two snapshots")
    args = ap.parse_args(argv)
    if args.compare:
        if args.scenes or args.out:
            ap.error("--compare takes no SCENES and no --out")
        return compare(*args.compare)
    if not (args.scenes and args.maps and args.out):
        ap.error("a snapshot needs --maps, --out and at least one scene (or use --compare A B)")
    if not args.maps.exists():
        ap.error(f"--maps {args.maps} does not exist")
    snapshot = plan_all(scene_files(args.scenes), args.maps, args.ik_budget_ms)
    args.out.write_text(json.dumps(snapshot, indent=1) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
