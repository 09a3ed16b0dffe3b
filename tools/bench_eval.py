"""`make bench-eval`: the 45 free scenes of `make eval`, evaluated locally and on a Dask LocalCluster.

Generates the scenes of ``placement scenes generate --seed 1 --count 45`` (every method, as
``make eval`` runs them), then times, on this machine:

* serial: one process, numba on its default thread count (the reference for the efficiency
  per core),
* local: ``--workers`` processes (``placement evaluate --workers N``),
* dask: a LocalCluster of ``--workers`` processes with one thread each on loopback
  (``placement evaluate --dask ADDRESS``); the cluster's start is timed apart, since a
  real cluster is already running when ``--dask`` connects to it.

Then the same three for a map build (``--build-samples`` of the PR2's right arm on the grid of
``maps/pr2.yaml``; serial = numba on one thread, local = the normal build on every core, dask =
``build_map(client=)``, ``placement maps build --dask``).

Local and Dask runs alternate (local, dask, dask, local, ...) ``--repeat`` times each and the
best wall time of each counts: on a shared machine other work only ever slows a run down.
Prints the wall times, dask/local, the efficiency per core (serial / (workers * wall)), the
CPU time of each run (this process, its pool and the Dask workers: a measure of the work done
that other load hardly changes) and whether all results are identical (timings aside); exits 1
if they are not. Writes each comparison to docs/bench/dask_evaluate.md and docs/bench/dask_build.md
(atomically; ``--out`` elsewhere), which docs/benchmarks.md includes.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

from bench_output import write_atomic

from placement.evaluation import evaluate, write_scenes

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1.15  # the goal's bound on dask / local wall time


def numba_threads() -> int:
    import numba

    return numba.get_num_threads()


def shown(path: str) -> str:
    """``path`` relative to the checkout when it lies in it (the tables name maps/pr2, not /home/...)."""
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return path


def without_timings(doc: dict) -> dict:
    doc = json.loads(json.dumps(doc))
    for r in doc["methods"].values():
        del r["planning_ms_per_placement"]
    return doc


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def cpu_seconds(client) -> float:
    """CPU time [s] so far of this process, its finished child processes and the Dask workers:
    unlike wall time, hardly changed by other work on a shared machine."""
    own = time.process_time()
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own + children.ru_utime + children.ru_stime + sum(client.run(time.process_time).values())


def report(
    title: str, labels: tuple[str, str, str], runs: dict[str, list[float]], cpu: dict[str, list[float]], n: int
) -> list[str]:
    """The Markdown table of the best wall time of each run kind (``labels``: the row names of serial,
    local and dask; dask's gets the worker count), its efficiency per core and its median CPU time,
    and the dask / local ratio below it."""
    serial, local, dask = labels
    names = {"serial": serial, "local": local, "dask": dask.replace("Dask", f"Dask, {n} workers", 1)}
    walls = {name: min(times) for name, times in runs.items() if times}
    lines = [f"| {title} | wall [s], best (all runs) | efficiency per core | CPU [s], median |", "|---|---|---|---|"]
    for name, wall in walls.items():
        cores = 1 if name == "serial" else n
        eff = f"{walls['serial'] / (cores * wall):.2f}" if "serial" in walls else "-"
        every = f" ({', '.join(f'{w:.1f}' for w in runs[name])})" if len(runs[name]) > 1 else ""
        lines.append(f"| {names[name]} | {wall:.1f}{every} | {eff} | {statistics.median(cpu[name]):.1f} |")
    ratio = walls["dask"] / walls["local"]
    lines += [
        "",
        f"dask / local wall time: {ratio:.3f} ({'within' if ratio <= TARGET else 'NOT within'} "
        f"the {100 * (TARGET - 1):.0f} % target)",
    ]
    return lines


def write_report(args, name: str, head: str, table: tuple, same: str) -> None:
    """Print one comparison (``table``: ``report``'s arguments but ``n``) and write it to ``--out``/``name``
    (a table docs/benchmarks.md includes), atomically."""
    text = "\n".join([f"{head}; {args.machine}", "", *report(*table, args.workers), same]) + "\n"
    print("\n" + text, end="")
    write_atomic(Path(args.out) / name, text)


def alternate(repeat: int, run) -> None:
    """``run("local")`` and ``run("dask")`` ``repeat`` times each, in the order l d d l l d ..."""
    for k in range(repeat):
        for name in ("local", "dask") if k % 2 == 0 else ("dask", "local"):
            run(name)


def bench_evaluation(args, client) -> bool:
    """The scene evaluation: serial, local processes, Dask. True if every document is the same."""
    with tempfile.TemporaryDirectory() as tmp:
        files = write_scenes(Path(tmp) / "free", args.seed, args.count, maps=os.path.abspath(args.maps))
        docs, runs, cpu = [], {"serial": [], "local": [], "dask": []}, {"serial": [], "local": [], "dask": []}

        def run(name):
            kwargs = {"serial": {"workers": 1}, "local": {"workers": args.workers}, "dask": {"client": client}}
            c = cpu_seconds(client)
            doc, wall = timed(lambda: evaluate(files, **kwargs[name]))
            cpu[name].append(cpu_seconds(client) - c)
            docs.append(doc)
            runs[name].append(wall)
            print(f"evaluation {name}: {wall:.1f} s", file=sys.stderr)

        if not args.no_serial:
            run("serial")
        alternate(args.repeat, run)
    same = all(without_timings(d) == without_timings(docs[0]) for d in docs)
    write_report(
        args,
        "dask_evaluate.md",
        f"Evaluation: {args.count} scenes (seed {args.seed}), {len(docs[0]['methods'])} methods, maps {shown(args.maps)}",
        (
            f"evaluation, {args.count} scenes",
            (f"one process (numba on {numba_threads()} threads)", f"local, `--workers {args.workers}`", "Dask"),
            runs,
            cpu,
        ),
        f"results identical (timings aside): {'yes' if same else 'NO'}",
    )
    return same


def bench_build(args, client) -> bool:
    """The map build of maps/pr2.yaml's grid (PR2 right arm): numba on one thread, numba on
    ``workers`` threads (the local build), Dask. True if every map is the same."""
    import numba
    import numpy as np

    import placement

    robot = placement.load_robot("pr2")
    kwargs = dict(samples=args.build_samples, seed=0, resolution=0.1, bins=(20, 9, 20), progress=False)
    maps, runs, cpu = [], {"serial": [], "local": [], "dask": []}, {"serial": [], "local": [], "dask": []}
    threads = numba.get_num_threads()

    def run(name):
        numba.set_num_threads(1 if name == "serial" else threads)
        c = cpu_seconds(client)
        built, wall = timed(
            lambda: placement.build_map(robot, "right", client=client if name == "dask" else None, **kwargs)
        )
        cpu[name].append(cpu_seconds(client) - c)
        numba.set_num_threads(threads)
        maps.append(built.values)
        runs[name].append(wall)
        print(f"build {name}: {wall:.1f} s", file=sys.stderr)

    if not args.no_serial:
        run("serial")
    alternate(args.repeat, run)
    same = all(np.array_equal(m, maps[0]) for m in maps)
    write_report(
        args,
        "dask_build.md",
        f"Map build: PR2 right arm, {args.build_samples:,} samples at 0.1 m, bins 20,9,20 "
        f"(local: one process, {threads} numba threads)",
        (
            f"map build, {args.build_samples / 1e6:g} M samples",
            ("one thread", f"local, {threads} numba threads", "Dask (`build_map(client=)`)"),
            runs,
            cpu,
        ),
        f"maps identical: {'yes' if same else 'NO'}",
    )
    return same


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default=str(ROOT / "maps" / "pr2"), help="PR2 maps (default: maps/pr2)")
    ap.add_argument("--count", type=int, default=45, help="scenes (default 45, as make eval; 0: no evaluation)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--build-samples",
        type=int,
        default=10_000_000,
        help="samples of the map build comparison (default 10 M; 0: none)",
    )
    ap.add_argument("--workers", type=int, default=2, help="local processes = Dask workers (default 2)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of local and of dask each (default 3)")
    ap.add_argument("--no-serial", action="store_true", help="skip the serial runs (no efficiency then)")
    ap.add_argument(
        "--out",
        default=str(ROOT / "docs/bench"),
        help="folder of the tables docs/benchmarks.md includes (dask_evaluate.md, dask_build.md)",
    )
    args = ap.parse_args(argv)
    if args.count and not Path(args.maps, "zarr.json").is_file() and not Path(args.maps).is_file():
        print(f"error: --maps {args.maps}: no maps there (make maps)", file=sys.stderr)
        return 2
    from dask.distributed import Client, LocalCluster

    args.machine = (
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the start; best of {args.repeat} runs each"
    )
    print(args.machine)
    # one numba thread per worker process: the workers already use every core between them
    cluster, start = timed(
        lambda: LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            env={"NUMBA_NUM_THREADS": "1"},
        )
    )
    print(
        f"Dask LocalCluster: {args.workers} worker processes, 1 thread each; its start ({start:.1f} s) "
        f"is in no wall time below"
    )
    with cluster, Client(cluster) as client:
        same = bench_evaluation(args, client) if args.count else True
        same = (bench_build(args, client) if args.build_samples else True) and same
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
