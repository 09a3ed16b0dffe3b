"""How far each method's plans are from the best possible: travel against the certified lower bound.

Generates held-out table-clearing scenes (``placement scenes generate``; seeds the evaluation does not
use, half of them with crates), plans each with every map-based method on one planner (shared IRMs,
collisions on), and prints, per scene, the lower bound on the travel time of any plan on the maps'
cells (the certificate), each method's travel and its ratio to the bound, and the planning time of
the whole task per placement (median of ``--runs`` fresh planners, IRMs included), and the time of
an update (an object moved) plus the whole task re-planned by the default method on a live planner. The last rows give the median and worst ratio per method.

    python tools/bench_optimum.py [--maps maps/pr2] [--scenes 6] [--runs 3]

Writes the table to docs/bench/optimum.md (atomically), which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

METHODS = ("sequential", "global", "optimal")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="maps/pr2")
    ap.add_argument("--scenes", type=int, default=6)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "docs/bench/optimum.md"))
    args = ap.parse_args()

    from placement.evaluation import write_scenes
    from placement.planning import Planner

    maps = str(Path(args.maps).resolve())
    work = Path(tempfile.mkdtemp(prefix="bench-optimum-"))
    free = write_scenes(work / "free", seed=101, count=(args.scenes + 1) // 2, maps=maps)
    crates = write_scenes(work / "crates", seed=102, count=args.scenes // 2, obstacles=True, maps=maps)
    rows = []
    ratios: dict[str, list[float]] = {m: [] for m in METHODS}
    fresh_all: dict[str, list[float]] = {m: [] for m in METHODS}
    update_all: list[float] = []
    Planner(free[0], METHODS[0], maps).plan()  # JIT warm-up
    for path in [*free, *crates]:
        row: dict[str, str | float | None] = {"scene": Path(path).stem}
        for m in METHODS:
            times, result = [], None
            for _ in range(args.runs):  # fresh planners: every placement pays for its own IRMs
                planner = Planner(path, m, maps)
                t = time.perf_counter()
                result = planner.plan()
                times.append((time.perf_counter() - t) * 1e3 - result.certificate.ms)
            assert result is not None
            cert = result.certificate.to_json()
            row["bound"] = cert["lower_bound_s"]
            steps = len(planner.problems.steps)
            if result.ok and cert["lower_bound_s"]:
                ratios[m].append(cert["travel_s"] / cert["lower_bound_s"])
                row[m] = f"{cert['travel_s']:.1f} ({ratios[m][-1]:.3f})"
            else:
                row[m] = "failed"
            fresh_all[m].append(statistics.median(times) / steps)
            row[f"{m} ms"] = f"{fresh_all[m][-1]:.1f}"
        # the default on a live planner: an object moved by 2 cm, the whole remaining task re-planned
        planner = Planner(path, "global", maps)
        planner.plan()
        obj = planner.scene.objects[0]
        x, y, z = (float(v) for v in obj.position)
        ups = []
        for k in range(args.runs * 2):
            t = time.perf_counter()
            planner.update({"objects": [{"name": obj.name, "position": [x + 0.02 * (k % 2 == 0), y, z]}]})
            result = planner.plan()
            ups.append((time.perf_counter() - t) * 1e3 - result.certificate.ms)
        update_all.append(statistics.median(ups) / len(planner.problems.steps))
        row["update"] = f"{update_all[-1]:.1f}"
        rows.append(row)
        print(row, file=sys.stderr, flush=True)
    head = ["scene", "bound [s]"] + [f"{m} [s] (x bound)" for m in METHODS]
    head += [f"{m} [ms/placement]" for m in METHODS] + ["global: update + re-plan [ms/placement]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [str(r["scene"]), f"{r['bound']:.1f}" if r["bound"] is not None else "-"]
        cells += [str(r[m]) for m in METHODS] + [str(r[f"{m} ms"]) for m in METHODS] + [str(r["update"])]
        lines.append("| " + " | ".join(cells) + " |")
    for name, f in (("median", statistics.median), ("worst", max)):
        cells = [f"**{name}**", ""] + [f"x {f(ratios[m]):.3f}" if ratios[m] else "-" for m in METHODS]
        cells += [f"{f(fresh_all[m]):.1f}" for m in METHODS] + [f"{f(update_all):.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    text = "\n".join(lines) + "\n"
    text += (
        f"\n{len(rows)} held-out scenes of {len(planner.problems.steps)} steps, maps `{Path(args.maps).name}` "
        f"({args.maps}); planning time per placement: median of {args.runs} fresh planners (every placement "
        "pays for its inverse maps, as in the paper), the certificate's bound excluded; update + re-plan: "
        "an object moved by 2 cm on a live planner, then the whole task planned again, per placement; "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}.\n"
    )
    print(text)
    write_atomic(Path(args.out), text)


if __name__ == "__main__":
    main()
