"""The parts of a scene file (shapes, obstacles, objects, place locations, trajectories, task steps), each
checked strictly as it is read; :func:`placement.scene.document.parse_scene` reads the document around them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from placement.scene.limits import MAX_COORD, MAX_POLYGON_VERTICES, MAX_TOTAL_VERTICES
from placement.scene.model import (
    Box,
    Cylinder,
    Obstacle,
    PlaceLocation,
    Polygon,
    SceneError,
    SceneObject,
    Shape,
    TaskStep,
    Trajectory,
)
from placement.scene.v2 import V2, PoseParser
from placement.simplicity import self_crossing
from placement.validation import describe

SCENE_VERSIONS = (1, V2)
SCENE_VERSION = V2  # the newest
SHAPES = ("box", "cylinder", "polygon")
OBSTACLE_KEYS = ("name", *SHAPES, "table")
BOX_KEYS = ("center", "size", "yaw")
CYLINDER_KEYS = ("center", "radius", "height")
OBJECT_KEYS_V1 = ("name", "position", "yaw", "size")
OBJECT_KEYS = (*OBJECT_KEYS_V1, "orientation", "grasps")
PLACE_KEYS_V1 = ("name", "position")
PLACE_KEYS = (*PLACE_KEYS_V1, "orientations")
TASK_KEYS = ("pick", "place")


class SceneParser(PoseParser):
    """The parts of a scene file; ``used_names`` collects the names used so far (they are unique).
    ``version``: the scene's format version (version 2 keys are refused below 2)."""

    def __init__(self, where: str, version: int = SCENE_VERSION) -> None:
        super().__init__(where, SceneError)
        self.used_names: dict[str, str] = {}
        self.version = version
        self.vertices = 0  # polygon points so far

    def coords(self, value: Any, path: str, n: int) -> tuple[float, ...]:
        return self.vector(value, path, n, maximum=MAX_COORD)

    def sizes(self, value: Any, path: str, n: int) -> tuple[float, ...]:
        return self.vector(value, path, n, positive=True, maximum=MAX_COORD)

    def unique(self, value: Any, path: str) -> str:
        n = self.string(value, path)
        if n in self.used_names:
            self.fail(path, f"duplicate name '{n}' (already used by {self.used_names[n]})")
        self.used_names[n] = path.rsplit(".", 1)[0]
        return n

    def shape(self, d: dict[str, Any], path: str) -> Shape:
        kinds = [k for k in SHAPES if k in d]
        if len(kinds) != 1:
            got = "none" if not kinds else " and ".join(kinds)
            self.fail(path, f"expected exactly one shape ({', '.join(SHAPES)}), got {got}")
        kind = kinds[0]
        p = f"{path}.{kind}"
        v = d[kind]
        if kind == "box":
            self.mapping(v, p, BOX_KEYS, ("center", "size"))
            return Box(
                np.array(self.coords(v["center"], f"{p}.center", 3)),
                np.array(self.sizes(v["size"], f"{p}.size", 3)),
                self.number(v.get("yaw", 0.0), f"{p}.yaw"),
            )
        if kind == "cylinder":
            self.mapping(v, p, CYLINDER_KEYS, CYLINDER_KEYS)
            return Cylinder(
                np.array(self.coords(v["center"], f"{p}.center", 3)),
                self.positive(v["radius"], f"{p}.radius", MAX_COORD),
                self.positive(v["height"], f"{p}.height", MAX_COORD),
            )
        if isinstance(v, list) and len(v) > MAX_POLYGON_VERTICES:
            self.fail(p, f"{len(v)} points, more than the {MAX_POLYGON_VERTICES} allowed in one polygon")
        pts = self.points(v, p, 3, MAX_COORD)
        self.vertices += len(pts)
        if self.vertices > MAX_TOTAL_VERTICES:
            self.fail(
                p,
                f"the polygons so far have {self.vertices} points, more than the {MAX_TOTAL_VERTICES} "
                "allowed in one scene",
            )
        for i in range(len(pts)):
            if np.array_equal(pts[i], pts[i - 1]):
                self.fail(f"{p}[{i}]", f"repeats the point before it {[float(c) for c in pts[i]]}")
        x, y = pts[:, 0], pts[:, 1]
        area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
        scale = max(float(np.ptp(x)), float(np.ptp(y)), 1.0)
        if area <= 1e-12 * scale * scale:
            self.fail(p, "the polygon has zero area (collinear or repeated points)")
        crossing = self_crossing(pts)
        if crossing is not None:
            i, j = crossing
            self.fail(
                p,
                f"the polygon crosses or touches itself (edge {i}-{(i + 1) % len(pts)} meets edge "
                f"{j}-{(j + 1) % len(pts)}); list the corners in order around it",
            )
        return Polygon(pts)

    def obstacle(self, item: Any, p: str) -> Obstacle:
        self.mapping(item, p, OBSTACLE_KEYS, ("name",))
        nm = self.unique(item["name"], f"{p}.name")
        shape = self.shape(item, p)
        table = self.boolean(item.get("table", False), f"{p}.table")
        if table and isinstance(shape, Polygon):
            self.fail(f"{p}.table", "a polygon has no height: a table must be a box or a cylinder")
        return Obstacle(nm, shape, table)

    def scene_object(self, item: Any, p: str) -> SceneObject:
        self.gate(item, p, "objects")
        self.mapping(item, p, OBJECT_KEYS if self.version >= V2 else OBJECT_KEYS_V1, ("name", "position", "size"))
        nm = self.unique(item["name"], f"{p}.name")
        position = np.array(self.coords(item["position"], f"{p}.position", 3))
        if "orientation" in item and "yaw" in item:
            self.fail(p, "give 'orientation' [x, y, z, w] or 'yaw' [rad], not both")
        yaw = self.number(item.get("yaw", 0.0), f"{p}.yaw")
        q = self.quaternion(item["orientation"], f"{p}.orientation") if "orientation" in item else None
        size = np.array(self.sizes(item["size"], f"{p}.size", 3))
        grasps = self.grasps(item["grasps"], f"{p}.grasps", MAX_COORD) if "grasps" in item else ()
        return SceneObject(nm, position, yaw, size, q, grasps)

    def place(self, item: Any, p: str) -> PlaceLocation:
        self.gate(item, p, "place_locations")
        self.mapping(item, p, PLACE_KEYS if self.version >= V2 else PLACE_KEYS_V1, PLACE_KEYS_V1)
        orientations = self.orientations(item["orientations"], f"{p}.orientations") if "orientations" in item else None
        name = self.unique(item["name"], f"{p}.name")
        return PlaceLocation(name, np.array(self.coords(item["position"], f"{p}.position", 3)), orientations)

    def trajectories(self, items: Any) -> list[Trajectory]:
        out: list[Trajectory] = []
        for i, item in enumerate(self.items(items, "trajectories")):
            t = self.trajectory(item, f"trajectories[{i}]", MAX_COORD)
            self.unique(t.name, f"trajectories[{i}].name")
            out.append(t)
        return out

    def task(
        self,
        items: Any,
        objects: Sequence[SceneObject],
        places: Sequence[PlaceLocation],
        trajectories: Sequence[Trajectory] = (),
    ) -> list[TaskStep]:
        kind = "{pick, place} or {reach} step" if self.version >= V2 else "{pick, place} step"
        if not isinstance(items, list):
            self.fail("task", f"expected a list of {kind}s, got {describe(items)}")
        if not items:
            self.fail("task", f"expected at least one {kind}, got an empty list")
        object_names = [o.name for o in objects]
        place_names = [p.name for p in places]
        picked: dict[str, str] = {}
        task: list[TaskStep] = []
        for i, item in enumerate(items):
            p = f"task[{i}]"
            self.gate(item, p, "task")
            if self.version >= V2 and isinstance(item, dict) and "reach" in item:
                if "pick" in item or "place" in item:
                    self.fail(p, "a step is {pick, place} or {reach}, not both")
                self.mapping(item, p, ("reach",), ("reach",))
                task.append(TaskStep(reach=self.reach(item["reach"], f"{p}.reach", trajectories)))
                continue
            self.mapping(item, p, (*TASK_KEYS, "reach") if self.version >= V2 else TASK_KEYS, TASK_KEYS)
            pick = self.string(item["pick"], f"{p}.pick")
            place = self.string(item["place"], f"{p}.place")
            if pick not in object_names:
                self.fail(f"{p}.pick", f"'{pick}' is not an object; objects: {', '.join(object_names) or '(none)'}")
            if pick in picked:
                self.fail(f"{p}.pick", f"object '{pick}' is already picked in {picked[pick]}")
            if place not in place_names:
                self.fail(
                    f"{p}.place",
                    f"'{place}' is not a place location; place locations: {', '.join(place_names) or '(none)'}",
                )
            picked[pick] = p
            task.append(TaskStep(pick, place))
        return task
