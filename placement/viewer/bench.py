"""Viewer timings for docs/viewer.md, and its screenshots: ``python -m placement.viewer.bench``.

Measures, for the example scene: opening scene, robot and maps; the first step planned and drawn
after that; step switch latency (median and worst of every switch between steps); and for a map:
``maps view`` from opening the map to the point cloud sent. With ``--shots DIR`` it also writes
screenshots from headless Chromium.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from placement.viewer.api import view_map, view_scene
from placement.viewer.map_view import MapView
from placement.viewer.plan_view import PlanView

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "table_clearing.yaml"


def bench_scene(scene: Path | str, maps: Path | str | None, shots: Path | None = None) -> dict[str, Any]:
    v = view_scene(scene, maps=maps, port=0)
    try:
        pv = v.content
        assert isinstance(pv, PlanView)
        n = len(pv.steps)
        times = []
        for i in [j % n for j in range(1, 3 * n + 1)]:
            t = time.perf_counter()
            pv.show(i)
            times.append((time.perf_counter() - t) * 1e3)
        out = {
            "scene": str(scene),
            "steps": n,
            "load_s": round(v.timings["load_s"], 2),
            "first_step_s": round(v.timings["first_step_s"], 2),
            "step_switch_ms_median": round(statistics.median(times), 1),
            "step_switch_ms_max": round(max(times), 1),
        }
        if shots is not None:
            from placement.viewer.screenshot import screenshot

            pv.show(0)
            screenshot(v.url, shots / "viewer_scene.png")
            for key, box in pv.toggles.items():
                # viser's value has a setter of another type than its getter: mypy takes it as read-only
                box.value = key == "navigation"  # type: ignore[misc]
            pv.show(1)
            screenshot(v.url, shots / "viewer_scene_navigation.png")
    finally:
        v.stop()
    return out


def bench_map(path: Path | str, arm: str | None = None, shots: Path | None = None) -> dict[str, Any]:
    t = time.perf_counter()
    v = view_map(path, arm=arm, port=0)
    try:
        mv = v.content
        assert isinstance(mv, MapView)
        total = time.perf_counter() - t
        g = mv.rmap.grid
        out = {
            "map": str(path),
            "arm": mv.rmap.arm,
            "cells": g.size,
            "position_cells_reached": mv.reached,
            "points_shown": mv.shown,
            "render_s": round(total, 2),
        }
        t = time.perf_counter()
        mv.threshold.value = mv.scale.hi / 2  # type: ignore[misc]  # (viser's setter, as in bench_scene)
        out["threshold_update_ms"] = round((time.perf_counter() - t) * 1e3, 1)
        mv.threshold.value = 0.0  # type: ignore[misc]
        if shots is not None:
            from placement.viewer.screenshot import screenshot

            mv.section.value = float(np.median(mv.all_points[:, 1]))  # type: ignore[misc]  # cut open at the middle
            screenshot(v.url, shots / "viewer_map.png")
    finally:
        v.stop()
    return out


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m placement.viewer.bench", description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(EXAMPLE))
    ap.add_argument("--maps", default=None, help="maps for the scene (default: the scene's)")
    ap.add_argument("--map", default=None, help="map for `maps view` (default: --maps)")
    ap.add_argument("--shots", default=None, help="write screenshots into this folder")
    a = ap.parse_args(argv)
    shots = Path(a.shots) if a.shots else None
    if shots:
        shots.mkdir(parents=True, exist_ok=True)
    result = {"scene": bench_scene(a.scene, a.maps, shots)}
    if a.map or a.maps:
        result["map"] = bench_map(a.map or a.maps, shots=shots)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
