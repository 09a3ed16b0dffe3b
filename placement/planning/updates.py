"""Dynamic updates (paper Table III): apply scene changes to a live planner, redoing only what changed.

Changes use the scene-file vocabulary and are validated by the same parser:

* ``{"objects": [{"name": N, "position": [x, y, z], "yaw": a}, ...]}``: objects moved (the
  manipulation maps of the steps that pick them are recomputed);
* ``{"obstacles": {"add": [<scene obstacle>, ...], "remove": [name, ...]}}``: the distance map,
  feasibility and every cost map are recomputed (the reachability slices stay cached);
* ``{"start": [x, y, yaw]}``: a new start pose (nothing cached changes).
"""

from __future__ import annotations

import time

from ..errors import PlacementError
from .scene import SceneError, parse_scene
from .world import build_world

_KEYS = {"objects", "obstacles", "start"}


def apply_update(planner, change: dict) -> dict:
    """Apply ``change`` to ``planner`` in place; returns {"updated": [...], "timings_ms": {...}}."""
    if not isinstance(change, dict) or not change:
        raise PlacementError("an update must be a non-empty mapping")
    unknown = set(change) - _KEYS
    if unknown:
        raise PlacementError(f"unknown update key '{sorted(unknown)[0]}'; allowed: {', '.join(sorted(_KEYS))}")
    t0 = time.perf_counter()
    scene = planner.scene
    doc = scene.to_dict()
    moved: set[str] = set()
    for o in change.get("objects", []):
        if not isinstance(o, dict) or "name" not in o:
            raise PlacementError("objects updates need a 'name'")
        target = next((x for x in doc["objects"] if x["name"] == o["name"]), None)
        if target is None:
            raise PlacementError(f"update moves unknown object '{o['name']}'; objects: "
                                 f"{', '.join(x['name'] for x in doc['objects'])}")
        for key, value in o.items():
            if key not in ("name", "position", "yaw", "size"):
                raise PlacementError(f"unknown key 'objects.{key}' in update; allowed: name, position, yaw, size")
            target[key] = value
        moved.add(o["name"])
    obstacles_changed = False
    if "obstacles" in change:
        ch = change["obstacles"]
        if not isinstance(ch, dict) or set(ch) - {"add", "remove"}:
            raise PlacementError("obstacles update must be {add: [...], remove: [...]}")
        names = {x["name"] for x in doc["obstacles"]}
        for name in ch.get("remove", []):
            if name not in names:
                raise PlacementError(f"update removes unknown obstacle '{name}'")
        doc["obstacles"] = [x for x in doc["obstacles"] if x["name"] not in set(ch.get("remove", []))]
        doc["obstacles"] += list(ch.get("add", []))
        obstacles_changed = True
    if "start" in change:
        doc["robot"]["start"] = change["start"]
    try:
        new = parse_scene(doc, ".", scene.name, source=f"{scene.name} (update)")
    except SceneError as exc:
        raise PlacementError(str(exc)) from None
    timings = {}
    planner.scene = new
    if obstacles_changed:
        t = time.perf_counter()
        p = planner.params
        planner.world = build_world(new, planner.robot.footprint_radius, p["velocity_lambda"], p["velocity_k"],
                                    p["d_max"])
        timings["distance"] = (time.perf_counter() - t) * 1e3
        planner._options.clear()
        planner._heuristic.clear()
        planner._fixed = None
    elif moved:
        for i, (action, target) in enumerate(planner.steps()):
            if action == "pick" and target in moved:
                planner._options.pop(i, None)
        planner._heuristic.clear()  # region maps of changed steps; the others are cheap to redo
    timings["update"] = (time.perf_counter() - t0) * 1e3
    return {"updated": sorted(moved) + (["obstacles"] if obstacles_changed else []) +
            (["start"] if "start" in change else []), "timings_ms": timings}
