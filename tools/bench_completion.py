"""What map completion gains: one arm sampled, measured, completed from its witnesses, measured again.

    python tools/bench_completion.py --resolution 0.05 --samples 3e7 --check 100

Prints one JSON line per stage: sampling time (wall and CPU) and filled cells; pose-level precision
and recall (placement.maps.accuracy.pose_metrics, the same recall cells for both maps) before completion
(IK without witness seeds) and after it (seeded by the witnesses); completion time, candidates, filled
cells and the peak memory of the process (which also holds a copy of the map before completion).
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np

import placement
from placement.maps.accuracy import pose_metrics
from placement.maps.completion import complete

KEYS = ("precision", "precision_ci95", "recall", "recall_ci95", "recall_cells", "recall_draws")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="pr2")
    ap.add_argument("--arm", default="right")
    ap.add_argument("--resolution", type=float, default=0.05, help="position cell edge [m]")
    ap.add_argument("--samples", type=float, default=3e7)
    ap.add_argument("--check", type=int, default=100, help="poses / cells per pose-level metric")
    args = ap.parse_args(argv)
    robot = placement.load_robot(args.robot)
    n = int(args.samples)
    t0, c0 = time.time(), time.process_time()
    m = placement.build_map(
        robot, args.arm, samples=n, seed=0, resolution=args.resolution, bins=(20, 9, 20), progress=False
    )
    r = {
        "resolution_m": args.resolution,
        "samples": n,
        "grid": m.meta["grid"]["shape"],
        "sampling_wall_s": round(time.time() - t0, 1),
        "sampling_cpu_s": round(time.process_time() - c0, 1),
        "filled": m.meta["filled_cells"],
    }
    print(json.dumps(r), flush=True)
    before = placement.BuiltMap((m.values > 0).astype(np.float32), m.meta)
    r["before"] = {k: v for k, v in pose_metrics(robot, before, samples=args.check, seed=0).items() if k in KEYS}
    del before
    print(json.dumps(r), flush=True)
    t0, c0 = time.time(), time.process_time()
    cand = complete(
        robot, args.arm, m.grid, m.values.reshape(-1), m.witness.reshape(-1), seed=0, plain=n, index="isotropy"
    )
    r.update(
        completion_wall_s=round(time.time() - t0, 1),
        completion_cpu_s=round(time.process_time() - c0, 1),
        candidates=cand,
        filled_after=int(np.count_nonzero(m.values)),
        peak_rss_gib=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, 2),
    )
    m.meta["witness"]["completion"] = True
    r["after"] = {k: v for k, v in pose_metrics(robot, m, samples=args.check, seed=0).items() if k in KEYS}
    print(json.dumps(r), flush=True)


if __name__ == "__main__":
    main()
