"""`placement scenes check SCENE`: a scene file read and checked as the planner reads it, summarised."""

from __future__ import annotations

from typing import Any

import click

from placement.cli.options import emit, scene_argument, setup_logging, standard_options
from placement.cli.params import OneLineCommand


def summary(path: str) -> dict[str, Any]:
    """The checked scene ``path`` in numbers: what its task asks, what stands in the way, which maps
    and robot it names (PlacementError naming the file and the key when it is invalid)."""
    from placement.scene import load_scene

    scene = load_scene(path)
    steps: list[dict[str, Any]] = []
    for t in scene.task:
        if t.reach:
            steps.append({"reach": list(t.reach)})
        else:
            steps.append({"pick": t.pick, "place": t.place})
    occupancy = None
    if scene.occupancy is not None:
        rows, cols = scene.occupancy.occupied.shape
        occupancy = {
            "path": str(scene.occupancy_map),
            "cells": [int(rows), int(cols)],
            "resolution_m": scene.occupancy.resolution,
            "unknown": scene.occupancy.unknown,
        }
    return {
        "scene": scene.name,
        "version": scene.version,
        "robot": scene.robot_preset,
        "maps": scene.maps,
        "start": list(scene.start),
        "bounds_m": list(scene.bounds),
        "resolution_m": scene.resolution,
        "objects": len(scene.objects),
        "obstacles": len(scene.obstacles),
        "place_locations": len(scene.place_locations),
        "trajectories": len(scene.trajectories),
        "task": steps,
        "occupancy_map": occupancy,
        "keepout_mask": None if scene.keepout_mask is None else str(scene.keepout_mask),
        "speed_mask": None if scene.speed_mask is None else str(scene.speed_mask),
        "planner": dict(scene.planner),
    }


#: task entries the table shows (--json gives all)
SHOWN = 8


def _render(d: dict[str, Any]) -> str:
    words = [f"reach {'|'.join(s['reach'])}" if "reach" in s else f"{s['pick']} -> {s['place']}" for s in d["task"]]
    task = ", ".join(words[:SHOWN]) + (
        f", ... ({len(words) - SHOWN} more: --json lists them)" if len(words) > SHOWN else ""
    )
    lines = [
        f"{d['scene']} (version {d['version']}): robot {d['robot']}, maps {d['maps'] or '(default)'}",
        f"  task: {len(d['task'])} entries: {task}",
        f"  {d['objects']} objects, {d['obstacles']} obstacles, {d['place_locations']} place locations",
        f"  area {d['bounds_m']} m at {d['resolution_m']} m cells",
    ]
    if d["occupancy_map"]:
        o = d["occupancy_map"]
        lines.append(f"  occupancy map {o['path']}: {o['cells'][0]} x {o['cells'][1]} cells of {o['resolution_m']} m")
    return "\n".join(lines)


@click.command(cls=OneLineCommand)
@scene_argument
@standard_options
def check(scene: str, as_json: bool, verbose: int, quiet: bool) -> None:
    """Read SCENE as the planner does (every key, unit and reference checked) and summarise it.

    Exit 2 with one line naming the file and the key when it is invalid; nothing is planned and no
    map is opened."""
    setup_logging(verbose, quiet)
    emit(summary(scene), as_json, _render)
