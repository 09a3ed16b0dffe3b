"""Batch evaluation of methods on many scenes (SPEC section 8): task times, success, reductions."""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import time
from pathlib import Path

import numpy as np

from ..errors import PlacementError
from .planner import METHODS, Planner
from .tasktime import task_time


def scene_files(paths) -> list[Path]:
    """Scene files from files and directories (``*.yaml`` inside, sorted)."""
    out = []
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


def evaluate_scene(path: str, methods: list[str], maps: str | None = None) -> dict:
    """All methods on one scene, sharing one planner (maps, world, IRMs). Failures are results."""
    planner = Planner(path, methods[0], maps)
    out = {}
    for m in methods:
        planner.set_method(m)
        t = time.perf_counter()
        try:
            result = planner.plan()
        except PlacementError as exc:
            result = {"status": "error", "reason": str(exc), "steps": []}
        ms = (time.perf_counter() - t) * 1e3
        tt = task_time(planner.robot, result, planner.scene.start)
        n = max(1, len(result["steps"]))
        out[m] = {"task_time_s": None if tt is None else tt["total_s"], "success": tt is not None,
                  "planning_ms_per_placement": ms / n,
                  "reason": None if tt is not None else _reason(result)}
    return out


def _reason(result: dict) -> str:
    bad = [s for s in result.get("steps", []) if s.get("status") == "infeasible"]
    if bad:
        return f"step {bad[0]['step']} ({bad[0]['action']} {bad[0]['target']}): {bad[0]['reason']}"
    return result.get("reason", "failed")


def _worker_init():
    import numba

    numba.set_num_threads(1)  # one scene per process: no oversubscription


def evaluate(paths, methods=METHODS, maps=None, workers: int = 2, progress=None) -> dict:
    """Evaluate ``methods`` on every scene; ``progress(done, total)`` after each scene.

    Returns the document of SPEC section 8: scenes, per-method lists, and ``reductions``:
    for method M and baseline B, ``1 - sum(T_M) / sum(T_B)`` over the scenes both solved.
    """
    methods = list(methods)
    for m in methods:
        if m not in METHODS:
            raise PlacementError(f"unknown method '{m}'; choose from {', '.join(METHODS)}")
    files = scene_files(paths)
    results: list[dict | None] = [None] * len(files)
    if workers <= 1 or len(files) == 1:
        for k, f in enumerate(files):
            results[k] = evaluate_scene(str(f), methods, maps)
            if progress:
                progress(k + 1, len(files))
    else:
        ctx = mp.get_context("spawn")
        with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init) as pool:
            futures = {pool.submit(evaluate_scene, str(f), methods, maps): k for k, f in enumerate(files)}
            for done, fut in enumerate(cf.as_completed(futures), 1):
                results[futures[fut]] = fut.result()
                if progress:
                    progress(done, len(files))
    doc = {"scenes": [f.stem for f in files], "methods": {}, "reductions": {}}
    for m in methods:
        doc["methods"][m] = {key: [r[m][key] for r in results]
                             for key in ("task_time_s", "success", "planning_ms_per_placement", "reason")}
    for m in methods:
        doc["reductions"][m] = {}
        for b in methods:
            if b == m:
                continue
            pairs = [(x, y) for x, y in zip(doc["methods"][m]["task_time_s"], doc["methods"][b]["task_time_s"])
                     if x is not None and y is not None]
            doc["reductions"][m][b] = (1.0 - sum(x for x, _ in pairs) / sum(y for _, y in pairs)) if pairs else None
    return doc


def summary_rows(doc: dict) -> list[dict]:
    """Per method: mean/median/std task time [s], success rate, mean planning ms per placement."""
    rows = []
    for m, r in doc["methods"].items():
        t = np.array([x for x in r["task_time_s"] if x is not None], dtype=float)
        rows.append({"method": m, "scenes": len(r["success"]), "success_rate": float(np.mean(r["success"])),
                     "mean_s": float(t.mean()) if t.size else None, "median_s": float(np.median(t)) if t.size else None,
                     "std_s": float(t.std()) if t.size else None,
                     "planning_ms_per_placement": float(np.mean(r["planning_ms_per_placement"])),
                     **{f"reduction_vs_{b}": v for b, v in doc["reductions"][m].items()}})
    return rows
