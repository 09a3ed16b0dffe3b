"""The scene drawn in a viser server: floor, obstacles and tables, the occupancy map as a floor layer,
the obstacle point cloud as its voxel boxes, objects, place locations and the start pose. Node names
start with ``/scene``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from placement.scene import Box, Cylinder, Polygon
from placement.viewer.colors import Scale, layer_image
from placement.viewer.geometry import (
    POLYGON_HEIGHT,
    boxes_mesh,
    circle,
    footprint_segments,
    label_offset,
    polyline_segments,
    prism,
    yaw_wxyz,
)

FLOOR = (222, 222, 216)
OBSTACLE = (130, 134, 142)
TABLE = (176, 124, 74)
OBJECT = (235, 140, 30)
PLACE = (40, 170, 80)
START = (60, 60, 60)
if TYPE_CHECKING:
    import viser

    from placement.scene import OccupancyMap, Scene, Shape
    from placement.scene.cloud import VoxelCloud

OCCUPIED = Scale("occupied", "", 0.0, 1.0, "Greys")


def draw_floor(server: viser.ViserServer, bounds: tuple[float, float, float, float]) -> None:
    """A floor slab under the scene ``bounds`` (xmin, ymin, xmax, ymax) [m] with a 1 m grid on it."""
    xmin, ymin, xmax, ymax = bounds
    w, h = xmax - xmin, ymax - ymin
    centre = ((xmin + xmax) / 2, (ymin + ymax) / 2)
    server.scene.add_box(
        "/scene/floor",
        color=FLOOR,
        dimensions=(w, h, 0.02),
        position=(*centre, -0.011),
        flat_shading=False,
        cast_shadow=False,
    )
    server.scene.add_grid(
        "/scene/grid", width=w, height=h, cell_size=0.5, section_size=1.0, position=(*centre, 0.001), shadow_opacity=0.0
    )


def draw_shape(
    server: viser.ViserServer, name: str, shape: Shape, color: tuple[int, int, int], opacity: float | None = None
) -> viser.BoxHandle | viser.MeshHandle:
    """One Box, Cylinder or Polygon of the scene model; returns its scene node."""
    if isinstance(shape, Box):
        return server.scene.add_box(
            name,
            color=color,
            dimensions=tuple(shape.size),
            position=tuple(shape.center),
            wxyz=yaw_wxyz(shape.yaw),
            opacity=opacity,
        )
    elif isinstance(shape, Cylinder):
        # a prism of many sides, so the axis is z whatever a library's cylinder convention is
        z0 = float(shape.center[2] - shape.height / 2)
        v, f = prism(circle(shape.radius) + shape.center[:2], z0, z0 + shape.height)
        return server.scene.add_mesh_simple(name, v, f, color=color, opacity=opacity, flat_shading=False)
    elif isinstance(shape, Polygon):
        v, f = prism(shape.points, 0.0, POLYGON_HEIGHT)
        return server.scene.add_mesh_simple(name, v, f, color=color, opacity=0.85 if opacity is None else opacity)
    raise TypeError(f"unknown shape {type(shape).__name__}")


def draw_occupancy(server: viser.ViserServer, occupancy: OccupancyMap) -> viser.ImageHandle:
    """The occupancy map's occupied cells as a dark floor layer (free cells transparent); its node."""
    occ = np.asarray(occupancy.occupied)
    rows, cols = occ.shape
    res = occupancy.resolution
    ox, oy = occupancy.origin[:2]
    img = layer_image(np.where(occ, 0.8, np.nan), OCCUPIED, alpha=200)
    return server.scene.add_image(
        "/scene/occupancy",
        img,
        cols * res,
        rows * res,
        format="png",
        position=(ox + cols * res / 2, oy + rows * res / 2, 0.003),
        cast_shadow=False,
    )


def draw_cloud(server: viser.ViserServer, cloud: VoxelCloud) -> viser.MeshHandle:
    """The obstacle point cloud as the arm's collision model sees it: its voxel boxes (runs of occupied
    voxels per column), one translucent mesh; its node."""
    v, f = boxes_mesh(cloud.boxes)
    return server.scene.add_mesh_simple("/scene/obstacle_cloud", v, f, color=OBSTACLE, opacity=0.6, flat_shading=True)


def draw_start(
    server: viser.ViserServer,
    start: tuple[float, float, float],
    footprint_radius: float,
    polygon: npt.ArrayLike | None = None,
) -> None:
    """The start pose: the footprint (``polygon`` (k, 2) [m] in the base frame, else the circle), a
    heading line and a label."""
    x, y, yaw = start
    server.scene.add_line_segments(
        "/scene/start/ring",
        footprint_segments(footprint_radius, polygon, 0.01),
        START,
        thickness=0.02,
        position=(x, y, 0.0),
        wxyz=yaw_wxyz(yaw),
    )
    head = np.array([[0, 0, 0.01], [footprint_radius, 0, 0.01]])
    server.scene.add_line_segments(
        "/scene/start/heading", polyline_segments(head), START, thickness=0.03, position=(x, y, 0.0), wxyz=yaw_wxyz(yaw)
    )
    server.scene.add_label("/scene/start/label", "start", position=(x, y, 0.3))


def draw_scene(
    server: viser.ViserServer, scene: Scene, footprint_radius: float, polygon: npt.ArrayLike | None = None
) -> dict[str, viser.SceneNodeHandle]:
    """Everything of ``scene`` (a :class:`placement.scene.Scene`) that does not change
    between steps. ``footprint_radius`` [m] of the robot, for the start pose. Returns the nodes of the
    obstacles, objects, occupancy map and obstacle cloud by node name."""
    draw_floor(server, scene.bounds)
    nodes: dict[str, viser.SceneNodeHandle] = {}
    for ob in scene.obstacles:
        name = f"/scene/{'tables' if ob.table else 'obstacles'}/{ob.name}"
        nodes[name] = draw_shape(server, name, ob.shape, TABLE if ob.table else OBSTACLE)
    if scene.occupancy is not None:
        nodes["/scene/occupancy"] = draw_occupancy(server, scene.occupancy)
    if scene.cloud is not None and len(scene.cloud.boxes):
        nodes["/scene/obstacle_cloud"] = draw_cloud(server, scene.cloud)
    for o in scene.objects:
        assert o.orientation is not None  # SceneObject sets it (from the yaw when the file has none)
        x, y, z, w = (float(v) for v in o.orientation)  # ROS order in the scene, wxyz in viser
        nodes[f"/scene/objects/{o.name}"] = server.scene.add_box(
            f"/scene/objects/{o.name}",
            color=OBJECT,
            dimensions=tuple(o.size),
            position=tuple(o.position),
            wxyz=(w, x, y, z),
        )
        # children of the object's node: positions in the object's frame
        server.scene.add_label(f"/scene/objects/{o.name}/label", o.name, position=label_offset(o.orientation, o.size))
    for p in scene.place_locations:
        server.scene.add_cylinder(
            f"/scene/places/{p.name}", radius=0.06, height=0.01, color=PLACE, position=tuple(p.position)
        )
        server.scene.add_label(f"/scene/places/{p.name}/label", p.name, position=(0.0, 0.0, 0.08))
    draw_start(server, scene.start, footprint_radius, polygon)
    return nodes
