"""`make bench-eval`: the 45 free scenes of `make eval`, evaluated locally and on a Dask LocalCluster.

Generates the scenes of ``placement scenes generate --seed 1 --count 45`` (every method, as
``make eval`` runs them), then times, on this machine:

* serial: one process (the reference for the efficiency per core),
* local: ``--workers`` processes (``placement evaluate --workers N``),
* dask: a LocalCluster of ``--workers`` processes with one thread each on loopback
  (``placement evaluate --dask ADDRESS``); the cluster's start is timed apart, since a
  real cluster is already running when ``--dask`` connects to it.

Prints the wall times, dask/local, the efficiency per core (serial / (workers * wall)) and
whether the three result documents are identical (timings aside); exits 1 if they are not.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from placement.evaluation import evaluate, write_scenes

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1.15  # the bound on dask / local wall time


def without_timings(doc: dict) -> dict:
    doc = json.loads(json.dumps(doc))
    for r in doc["methods"].values():
        del r["planning_ms_per_placement"]
    return doc


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default=str(ROOT / "maps" / "pr2"), help="PR2 maps (default: maps/pr2)")
    ap.add_argument("--count", type=int, default=45, help="scenes (default 45, as make eval)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2, help="local processes = Dask workers (default 2)")
    ap.add_argument("--no-serial", action="store_true", help="skip the serial run (no efficiency then)")
    args = ap.parse_args(argv)
    if not Path(args.maps, "zarr.json").is_file() and not Path(args.maps).is_file():
        print(f"error: --maps {args.maps}: no maps there (make maps)", file=sys.stderr)
        return 2
    from dask.distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        files = write_scenes(Path(tmp) / "free", args.seed, args.count, maps=os.path.abspath(args.maps))
        docs, walls = {}, {}
        if not args.no_serial:
            docs["serial"], walls["serial"] = timed(lambda: evaluate(files, workers=1))
        docs["local"], walls["local"] = timed(lambda: evaluate(files, workers=args.workers))
        cluster, start = timed(lambda: LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                                    host="127.0.0.1", dashboard_address=None))
        with cluster, Client(cluster) as client:
            docs["dask"], walls["dask"] = timed(lambda: evaluate(files, client=client))
    same = all(without_timings(d) == without_timings(docs["local"]) for d in docs.values())
    n = args.workers
    print(f"{args.count} scenes (seed {args.seed}), {len(docs['local']['methods'])} methods, "
          f"{n} workers, maps {args.maps}")
    print("| run | wall [s] | efficiency per core |")
    print("|---|---|---|")
    for run, wall in walls.items():
        cores = 1 if run == "serial" else n
        eff = f"{walls['serial'] / (cores * wall):.2f}" if "serial" in walls else "-"
        print(f"| {run} | {wall:.1f} | {eff} |")
    ratio = walls["dask"] / walls["local"]
    print(f"Dask cluster start (not in its wall time): {start:.1f} s")
    print(f"dask / local wall time: {ratio:.3f} ({'within' if ratio <= TARGET else 'NOT within'} "
          f"the {100 * (TARGET - 1):.0f} % target)")
    print(f"results identical (timings aside): {'yes' if same else 'NO'}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
