"""Per-stage planning time of `placement query` (like the paper's Table II), medians over runs.

Needs the default maps (`make maps`). Each run uses a fresh Planner (empty caches, warm JIT),
so every placement pays for its own IRMs, as in the paper.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

from placement.planning import Planner

ROOT = Path(__file__).resolve().parents[1]
PAPER = {"navigation": 1.39, "manipulation": 1053.94, "heuristic": 58.20, "combine": 4.93, "total": 1118.49}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scene", default=str(ROOT / "examples/table_clearing.yaml"))
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    Planner(args.scene).plan()  # JIT warm-up
    per_stage: dict[str, list[float]] = {}
    for _ in range(args.runs):
        for step in Planner(args.scene).plan().steps:
            for k, v in step.timings_ms.items():
                per_stage.setdefault(k, []).append(v)
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "placement.cli.main", "query", args.scene, "--json", "-q"],
                   check=True, capture_output=True)
    cold = time.perf_counter() - t
    rows = ["| stage (per placement) | median [ms] | paper [ms] | speed-up |", "|---|---|---|---|"]
    for k in ("navigation", "manipulation", "heuristic", "combine", "ik", "total"):
        med = statistics.median(per_stage.get(k, [0.0]))
        ref = PAPER.get(k)
        rows.append(f"| {k} | {med:.2f} | {ref if ref else '-'} | {f'{ref / med:.3g}x' if ref and med else '-'} |")
    rows.append(f"| cold `placement query` of the scene (imports, cached JIT, {len(per_stage['total']) // args.runs} placements) "
                f"| {cold * 1e3:.0f} | - | - |")
    text = "\n".join(rows)
    (ROOT / "docs").mkdir(exist_ok=True)
    (ROOT / "docs/bench_query.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    sys.exit(main())
