"""Batch evaluation of methods on many scenes (docs/evaluation.md): task times, success, reductions."""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from placement.errors import PlacementError
from placement.planning import METHODS, Planner, PlanResult
from placement.planning.problems import UPRIGHT_TOLERANCE
from placement.planning.results import transfer_problems
from placement.planning.task_time import task_time
from placement.scene import load_scene

if TYPE_CHECKING:
    from dask.distributed import Client, Future

#: ``progress(done, total)``: called with the number of scenes evaluated so far.
Progress = Callable[[int, int], object]
#: One scene's results: per method, its task time, success, planning time, reason and transfer faults.
SceneResults = dict[str, dict[str, Any]]

MAX_WORKERS = 64  # processes; each holds its own maps and world


def check_methods(methods: Iterable[str]) -> list[str]:
    """``methods`` as a list, or :class:`PlacementError` for an empty, blank, repeated or unknown name."""
    out = list(methods)
    choose = f"choose from {', '.join(METHODS)}"
    if not out:
        raise PlacementError(f"no method given; {choose}")
    for m in out:
        if not isinstance(m, str) or not m.strip():
            raise PlacementError(f"empty method name in {','.join(map(str, out))!r}; {choose}")
        if m not in METHODS:
            raise PlacementError(f"unknown method {m!r}; {choose}")
        if out.count(m) > 1:
            raise PlacementError(f"method {m!r} is given twice")
    return out


def scene_files(paths: Iterable[Path | str]) -> list[Path]:
    """Scene files from files and directories (``*.yaml`` inside, sorted)."""
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            out += sorted(p.glob("*.yaml"))
        elif p.is_file():
            out.append(p)
        else:
            raise PlacementError(f"{p}: no such scene file or directory")
    if not out:
        raise PlacementError("no scene files given")
    return out


def check_scenes(paths: Iterable[Path | str]) -> list[Path]:
    """:func:`scene_files`, each loaded and checked (PlacementError naming the file)."""
    files = scene_files(paths)
    for f in files:
        load_scene(f)
    return files


def evaluate_scene(path: str, methods: list[str], maps: str | None = None) -> SceneResults:
    """All methods on one scene, sharing one planner (maps, world, IRMs). Failures are results."""
    planner = Planner(path, methods[0], maps)
    out: SceneResults = {}
    for m in methods:
        planner.set_method(m)
        t = time.perf_counter()
        try:
            result, error = planner.plan(), None
        except PlacementError as exc:
            result, error = None, str(exc)
        ms = (time.perf_counter() - t) * 1e3
        cert = result.certificate.to_json() if result is not None and result.certificate is not None else {}
        ms -= float(cert.get("timings_ms", {}).get("bound", 0.0))  # the certificate is reported, not part of planning
        tt = task_time(planner.robot, result, planner.scene.start)
        steps, reason = plan_outcome(result, error)
        out[m] = {
            "task_time_s": None if tt is None else tt["total_s"],
            "success": tt is not None,
            "planning_ms_per_placement": ms / max(1, steps),
            "reason": None if tt is not None else reason,
            "transfer_faults": transfer_faults(result),
            "lower_bound_s": cert.get("lower_bound_s"),
            "travel_s": cert.get("travel_s"),
            "gap": cert.get("gap"),
        }
    return out


def transfer_faults(result: PlanResult | None) -> int:
    """Places of ``result`` that are no executable transfer: by another arm or grasp than their pick,
    or with the object tilted from how it was picked (see
    :func:`~placement.planning.results.transfer_problems`; 0 by construction, counted as a check)."""
    if result is None:
        return 0
    return sum(len(transfer_problems(s, result.steps, "", rot_tol=UPRIGHT_TOLERANCE)) for s in result.steps if s.ok)


def plan_outcome(result: PlanResult | None, error: str | None) -> tuple[int, str]:
    """(number of steps, why the plan failed) of a plan, or of the ``error`` that stopped it."""
    if result is None:
        return 0, error or "failed"
    bad = result.failed_step
    if bad is not None:
        return len(result.steps), f"step {bad.step} ({bad.action} {bad.target}): {bad.reason}"
    return len(result.steps), "failed"


def scene_task(path: str, methods: list[str], maps: str | None = None) -> SceneResults:
    """:func:`evaluate_scene` in a worker (process pool or Dask): numba on one thread, since the
    workers already run one scene per core and more threads would only compete for it."""
    import numba

    from placement.process_env import configure_process

    configure_process()  # a Dask worker is a process of its own (a pool's inherits the command's)
    numba.set_num_threads(1)
    return evaluate_scene(path, methods, maps)


def _in_process(
    files: list[Path], methods: list[str], maps: str | None, progress: Progress | None
) -> list[SceneResults]:
    out = []
    for k, f in enumerate(files):
        out.append(evaluate_scene(str(f), methods, maps))
        if progress:
            progress(k + 1, len(files))
    return out


def _in_pool(
    files: list[Path], methods: list[str], maps: str | None, workers: int, progress: Progress | None
) -> list[SceneResults]:
    results: list[SceneResults | None] = [None] * len(files)
    ctx = mp.get_context("spawn")
    with cf.ProcessPoolExecutor(max_workers=min(workers, len(files)), mp_context=ctx) as pool:
        futures = {pool.submit(scene_task, str(f), methods, maps): k for k, f in enumerate(files)}
        try:
            for done, fut in enumerate(cf.as_completed(futures), 1):
                results[futures[fut]] = fut.result()
                if progress:
                    progress(done, len(files))
        except BaseException:
            pool.shutdown(cancel_futures=True)  # an error stops the run instead of waiting for every scene
            raise
    return [r for r in results if r is not None]  # every one, as every future completed


def _on_dask(
    client: Client, files: list[Path], methods: list[str], maps: str | None, progress: Progress | None
) -> list[SceneResults]:
    from dask.distributed import as_completed

    # absolute paths: a worker's working directory need not be ours
    maps = None if maps is None else str(Path(maps).resolve())
    futures = {client.submit(scene_task, str(f.resolve()), methods, maps, pure=False): k for k, f in enumerate(files)}
    results: list[SceneResults | None] = [None] * len(files)
    # (dask.distributed leaves as_completed and Client.cancel unannotated)
    completed = cast("Callable[[Iterable[Future[SceneResults]]], Iterator[Future[SceneResults]]]", as_completed)
    cancel = cast("Callable[[list[Future[SceneResults]]], None]", client.cancel)
    try:
        for done, fut in enumerate(completed(futures), 1):
            results[futures[fut]] = fut.result()
            if progress:
                progress(done, len(files))
    except BaseException:
        cancel(list(futures))  # an error stops the run instead of waiting for every scene
        raise
    return [r for r in results if r is not None]  # every one, as every future completed


def evaluate(
    paths: Iterable[Path | str],
    methods: Iterable[str] = METHODS,
    maps: str | None = None,
    workers: int = 2,
    progress: Progress | None = None,
    client: Client | None = None,
) -> dict[str, Any]:
    """Evaluate ``methods`` on every scene; ``progress(done, total)`` after each scene.

    Returns the evaluation document (docs/evaluation.md): scenes, per-method lists, and ``reductions``:
    for method M and baseline B, ``1 - sum(T_M) / sum(T_B)`` over the scenes both solved.
    Methods and every scene file are checked before the first scene is planned.

    Scenes run in ``workers`` local processes, or with ``client`` (a
    ``dask.distributed.Client``, whose workers must see the scene and map files
    at the same absolute paths) one task per scene on the cluster, ``workers``
    unused. Every path runs the same per-scene function, so the documents agree
    except for the planning times.
    """
    names = check_methods(methods)
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= MAX_WORKERS:
        raise PlacementError(f"workers must be a whole number from 1 to {MAX_WORKERS}, got {workers!r}")
    files = check_scenes(paths)
    if progress:
        progress(0, len(files))
    if client is not None:
        results = _on_dask(client, files, names, maps, progress)
    elif workers <= 1 or len(files) == 1:
        results = _in_process(files, names, maps, progress)
    else:
        results = _in_pool(files, names, maps, workers, progress)
    per_method: dict[str, dict[str, list[Any]]] = {}
    for m in names:
        per_method[m] = {
            key: [r[m][key] for r in results]
            for key in (
                "task_time_s",
                "success",
                "planning_ms_per_placement",
                "reason",
                "transfer_faults",
                "lower_bound_s",
                "travel_s",
                "gap",
            )
        }
    reductions: dict[str, dict[str, float | None]] = {}
    for m in names:
        reductions[m] = {}
        for b in names:
            if b == m:
                continue
            pairs = [
                (x, y)
                for x, y in zip(per_method[m]["task_time_s"], per_method[b]["task_time_s"])
                if x is not None and y is not None
            ]
            reductions[m][b] = (1.0 - sum(x for x, _ in pairs) / sum(y for _, y in pairs)) if pairs else None
    return {"scenes": [f.stem for f in files], "methods": per_method, "reductions": reductions}


def summary_rows(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """Per method: mean/median/std task time [s], success rate, mean planning ms per placement, and
    the mean and worst gap of its travel to the lower bound of its certificate (over its plans)."""
    rows = []
    for m, r in doc["methods"].items():
        t = np.array([x for x in r["task_time_s"] if x is not None], dtype=float)
        gaps = np.array([g for g in r.get("gap", []) if g is not None], dtype=float)
        rows.append(
            {
                "method": m,
                "scenes": len(r["success"]),
                "success_rate": float(np.mean(r["success"])),
                "mean_s": float(t.mean()) if t.size else None,
                "median_s": float(np.median(t)) if t.size else None,
                "std_s": float(t.std()) if t.size else None,
                "planning_ms_per_placement": float(np.mean(r["planning_ms_per_placement"])),
                "mean_gap": float(gaps.mean()) if gaps.size else None,
                "worst_gap": float(gaps.max()) if gaps.size else None,
                **{f"reduction_vs_{b}": v for b, v in doc["reductions"][m].items()},
            }
        )
    return rows
