"""The checks of a scene that need the whole of it: the grid size, everything inside ``bounds``, nothing
inside an obstacle's volume, objects apart, a grasp for every picked object, the place orientations."""

from __future__ import annotations

from placement.scene.checks import (
    TOLERANCE,
    Coords,
    object_penetrates,
    obstacles_near,
    overlapping_objects,
    point_inside,
)
from placement.scene.graspable import GRIPPER_OPENING, box_grasps
from placement.scene.limits import MAX_GRID_CELLS, MAX_OBSTACLES, MAX_TOTAL_VERTICES
from placement.scene.model import Polygon, Scene, SceneError, grid_shape
from placement.scene.places import check_place_orientations
from placement.scene.v2 import V2
from placement.scene.validate import Validator, fmt


def check_scene(
    scene: Scene, where: str, objects: set[str] | None = None, new_obstacles: set[str] | None = None
) -> Scene:
    """The checks that need the whole scene: the grid size, everything inside ``bounds``, nothing
    inside an obstacle's volume. Raises :class:`SceneError` naming the key path.

    For a change to a scene that passed: ``objects`` (the moved objects) and ``new_obstacles`` (the
    added ones) limit the volume checks to the pairs the change can affect; None checks them all.
    """

    def pair(name: str, obstacle: str) -> bool:
        if objects is None and new_obstacles is None:
            return True
        return name in (objects or ()) or obstacle in (new_obstacles or ())

    P = Validator(where, SceneError)
    if len(scene.obstacles) > MAX_OBSTACLES:
        P.fail("obstacles", f"{len(scene.obstacles)} obstacles, more than the {MAX_OBSTACLES} allowed")
    vertices = sum(len(o.shape.points) for o in scene.obstacles if isinstance(o.shape, Polygon))
    if vertices > MAX_TOTAL_VERTICES:
        P.fail("obstacles", f"the polygons have {vertices} points, more than the {MAX_TOTAL_VERTICES} allowed")
    bounds, resolution = scene.bounds, scene.resolution
    ny, nx = grid_shape(bounds, resolution)
    if nx * ny > MAX_GRID_CELLS:
        P.fail(
            "resolution",
            f"bounds [{', '.join(fmt(b) for b in bounds)}] at {resolution} m give a {nx} x {ny} "
            f"grid ({nx * ny:.3g} cells); at most {MAX_GRID_CELLS:.3g}: coarsen the resolution or "
            "set smaller bounds",
        )

    def inside(xy: Coords, path: str, what: str) -> None:
        x, y = float(xy[0]), float(xy[1])
        if not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
            P.fail(path, f"{what} at ({fmt(x)}, {fmt(y)}) is outside bounds [{', '.join(fmt(b) for b in bounds)}]")

    inside(scene.start, "robot.start", "the start position")
    near = obstacles_near(scene.obstacles)
    for i, o in enumerate(scene.objects):
        inside(o.position, f"objects[{i}].position", f"object '{o.name}'")
        for ob in near(o.bounds_xy()):
            if pair(o.name, ob.name) and object_penetrates(o, ob.shape):
                P.fail(
                    f"objects[{i}]",
                    f"object '{o.name}' is inside obstacle '{ob.name}' (its bounding box enters "
                    "the obstacle's volume; objects may only touch, e.g. stand on a table)",
                )
    hit = overlapping_objects(scene.objects, objects)
    if hit is not None:
        a, b = (scene.objects[k].name for k in hit)
        P.fail(
            f"objects[{hit[1]}]",
            f"object '{b}' overlaps object '{a}' (their bounding boxes share more than "
            f"{TOLERANCE * 1000:g} mm; objects may touch, e.g. stand on each other)",
        )
    for i, t in enumerate(scene.trajectories):
        inside(t.poses[-1], f"trajectories[{i}].poses[{len(t.poses) - 1}]", f"the end of trajectory '{t.name}'")
    if scene.version >= V2:
        picked = {t.pick for t in scene.task if t.pick is not None}
        for i, o in enumerate(scene.objects):
            if (
                o.name in picked
                and not o.grasps
                and (objects is None or o.name in objects)
                and not box_grasps(o.pose, o.size)
            ):
                P.fail(
                    f"objects[{i}].size",
                    f"object '{o.name}' is wider than the gripper opening "
                    f"({GRIPPER_OPENING} m) across every side: no grasp can be generated; "
                    "give its 'grasps'",
                )
    for i, pl in enumerate(scene.place_locations):
        inside(pl.position, f"place_locations[{i}].position", f"place location '{pl.name}'")
        for ob in near((pl.position[0], pl.position[1]) * 2):
            if pair(pl.name, ob.name) and point_inside(pl.position, ob.shape):
                P.fail(f"place_locations[{i}].position", f"place location '{pl.name}' is inside obstacle '{ob.name}'")
    check_place_orientations(scene, P)
    return scene
