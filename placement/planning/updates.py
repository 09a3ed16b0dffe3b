"""Dynamic updates (paper Table III): scene changes applied to a live planner, redoing only what changed.

Changes use the scene-file vocabulary and are validated by the same parser, with key paths:

* ``{"objects": [{"name": N, "position": [x, y, z], "yaw": a, "size": [sx, sy, sz]}, ...]}``:
  objects moved (only the given keys change; the manipulation maps of the steps that pick them
  are recomputed); in a version 2 scene ``orientation: [x, y, z, w]`` may replace ``yaw``;
* ``{"obstacles": {"add": [<scene obstacle>, ...], "remove": [name, ...]}}``: the distance map,
  feasibility and every cost map are recomputed (the reachability slices stay cached);
* ``{"start": [x, y, yaw]}``: a new start pose (nothing cached changes).

An update is all or nothing: :func:`apply_update` builds the new state (scene, world and cache in
a new :class:`~placement.planning.context.PlanningContext`) and the planner swaps it in only when
everything succeeded, so a failed update leaves the planner exactly as it was.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from placement.planning.context import PlanningContext
from placement.planning.problems import StepProblems
from placement.planning.world import (
    add_touched,
    build_world,
    changed_occupancy,
    windowed_world,
    world_from_occupancy,
    world_still_serves,
)
from placement.scene import Obstacle, Scene, SceneObject, SceneParser, check_scene
from placement.scene.document import OBJECT_KEYS_V1
from placement.validation import describe

UPDATE_KEYS = ("objects", "obstacles", "start")
WHERE = "update"

#: A name longer than this [characters] is cut where a message quotes it.
NAME_CHARS = 60


def _quoted(name: str) -> str:
    """``'name'``, cut to :data:`NAME_CHARS` with its length said (a message must not echo 100 MB)."""
    return f"'{name}'" if len(name) <= NAME_CHARS else f"'{name[: NAME_CHARS - 20]}...' ({len(name):,} characters)"


class ParsedUpdate(NamedTuple):
    """A checked update: the scene after it, the names of the moved objects, whether obstacles
    changed, and whether some were removed (additions alone only add occupied cells)."""

    scene: Scene
    moved: set[str]
    obstacles_changed: bool
    obstacles_removed: bool


def parse_update(change: Any, scene: Scene) -> ParsedUpdate:
    """The scene after ``change`` and what changed (see :class:`ParsedUpdate`).

    Raises :class:`~placement.scene.SceneError` (one line, ``update: KEY.PATH: problem``).
    """
    P = SceneParser(WHERE, scene.version)
    if not isinstance(change, dict) or not change:
        P.fail("", "an update must be a non-empty mapping with keys " + ", ".join(UPDATE_KEYS))
    P.mapping(change, "", UPDATE_KEYS)

    def items(value: Any, path: str) -> list[Any]:
        if not isinstance(value, list):
            P.fail(path, f"expected a list, got {describe(value)}")
        return value

    objects: dict[str, SceneObject] = {o.name: o for o in scene.objects}
    moved: set[str] = set()
    for i, item in enumerate(items(change.get("objects", []), "objects")):
        p = f"objects[{i}]"
        P.gate(item, p, "objects")
        if isinstance(item, dict) and "grasps" in item:
            P.fail(f"{p}.grasps", "an update moves objects; their grasps stay as the scene gives them")
        P.mapping(item, p, (*OBJECT_KEYS_V1, "orientation") if scene.version >= 2 else OBJECT_KEYS_V1, ("name",))
        name = P.string(item["name"], f"{p}.name")
        if name not in objects:
            P.fail(f"{p}.name", f"unknown object {_quoted(name)}; objects: {', '.join(objects) or '(none)'}")
        if name in moved:
            P.fail(f"{p}.name", f"object {_quoted(name)} is moved twice in one update")
        o = objects[name]
        if "orientation" in item and "yaw" in item:
            P.fail(p, "give 'orientation' [x, y, z, w] or 'yaw' [rad], not both")
        # a new yaw drops the old orientation (the object turns about z only)
        yaw, q = (P.number(item["yaw"], f"{p}.yaw"), None) if "yaw" in item else (o.yaw, o.orientation)
        if "orientation" in item:
            yaw, q = 0.0, P.quaternion(item["orientation"], f"{p}.orientation")
        objects[name] = replace(
            o,
            position=np.asarray(P.coords(item["position"], f"{p}.position", 3), dtype=np.float64)
            if "position" in item
            else o.position,
            yaw=yaw,
            orientation=q,
            size=np.asarray(P.sizes(item["size"], f"{p}.size", 3), dtype=np.float64) if "size" in item else o.size,
        )
        moved.add(name)
    obstacles = list(scene.obstacles)
    added: list[Obstacle] = []
    changed = "obstacles" in change
    if changed:
        ch = P.mapping(change["obstacles"], "obstacles", ("add", "remove"))
        removed: set[str] = set()
        for i, name in enumerate(items(ch.get("remove", []), "obstacles.remove")):
            p = f"obstacles.remove[{i}]"
            P.string(name, p)
            if name not in {o.name for o in obstacles} or name in removed:
                P.fail(
                    p,
                    f"unknown obstacle {_quoted(name)}; obstacles: {', '.join(o.name for o in obstacles) or '(none)'}",
                )
            removed.add(name)
        obstacles = [o for o in obstacles if o.name not in removed]
        for n in [*(o.name for o in obstacles), *objects, *(p.name for p in scene.place_locations)]:
            P.used_names[n] = "the scene"
        added = [
            P.obstacle(item, f"obstacles.add[{i}]") for i, item in enumerate(items(ch.get("add", []), "obstacles.add"))
        ]
        obstacles += added
    if "start" in change:
        x, y, yaw = P.coords(change["start"], "start", 3)
        start = (float(x), float(y), float(yaw))
    else:
        start = scene.start
    new = replace(scene, objects=tuple(objects[o.name] for o in scene.objects), obstacles=tuple(obstacles), start=start)
    removed_any = changed and len(obstacles) - len(added) < len(scene.obstacles)
    return ParsedUpdate(check_scene(new, WHERE, moved, {o.name for o in added}), moved, changed, removed_any)


def apply_update(ctx: PlanningContext, change: Any) -> tuple[PlanningContext, dict[str, Any]]:
    """``ctx`` after ``change`` (all or nothing: ``ctx`` is not modified, and on error the collision
    checker is back on ``ctx.scene``), and the report ``{"updated": [...], "timings_ms": {...}}``:
    the moved objects' names, then "obstacles" and "start" when those changed."""
    t0 = time.perf_counter()
    parsed = parse_update(change, ctx.scene)
    scene = parsed.scene
    timings: dict[str, float] = {}
    world = ctx.world
    windowed = ctx.world.window is not None or scene.occupancy is not None and not scene.bounds_given
    if windowed and (parsed.obstacles_changed or not world_still_serves(ctx.world, scene)):
        # the task's new routes need another window, or obstacles changed: the world is made again
        t = time.perf_counter()
        world = windowed_world(scene, world.base, ctx.config, ctx.robot.v_max)
        timings["distance"] = (time.perf_counter() - t) * 1e3
    elif parsed.obstacles_changed and not windowed:
        t = time.perf_counter()
        # ctx.config differs from the scene's configuration in the methods' weights only, which
        # the world does not read
        layers = (scene.occupancy, scene.keepout, scene.speed)
        if parsed.obstacles_removed and any(x is not None for x in layers):  # cleared cells need the 2D layers again
            world = build_world(scene, world.base, ctx.config, ctx.robot.v_max)
        else:
            # by identity: a name removed and added again in one change is a different obstacle
            old = {id(o) for o in ctx.scene.obstacles}
            new = {id(o) for o in scene.obstacles}
            diff = (
                [o for o in ctx.scene.obstacles if id(o) not in new],
                [o for o in scene.obstacles if id(o) in old],
                [o for o in scene.obstacles if id(o) not in old],
            )
            occupied = changed_occupancy(world.occupied, world.nav, *diff)
            touched = (
                None if world.touched is None else changed_occupancy(world.touched, world.nav, *diff, draw=add_touched)
            )
            world = world_from_occupancy(world.nav, occupied, world.base, ctx.config, touched, world)
        timings["distance"] = (time.perf_counter() - t) * 1e3
    if world.nav != ctx.world.nav:  # another window: nothing computed on the old grid holds
        p = ctx.problems
        problems = StepProblems(scene, world, p.maps, p.config, p.yaws, p.opening_m, p.thresholds, p.collisions)
    else:
        problems = ctx.problems.changed(scene, world, parsed.moved)
    if ctx.collisions is not None:
        checkers = [ctx.collisions, *ctx.torso_checks.values()]
        try:
            for c in checkers:
                c.update(scene)
        except BaseException:  # e.g. the collision checker refused the new scene: back to the old one
            for c in checkers:
                c.update(ctx.scene)
            raise
    timings["update"] = (time.perf_counter() - t0) * 1e3
    updated = sorted(parsed.moved)
    if parsed.obstacles_changed:
        updated.append("obstacles")
    if "start" in change:  # the update dict itself (never rebound: see tests/test_updates.py)
        updated.append("start")
    return replace(ctx, scene=scene, world=world, problems=problems), {"updated": updated, "timings_ms": timings}
