"""The scene: its model, the strict parser of scene files (versions 1 and 2), and reading and writing them."""

from placement.scene.document import SCENE_VERSION, SCENE_VERSIONS, SceneParser, check_scene, parse_scene
from placement.scene.io import load_scene, obstacle_to_dict, save_scene, scene_to_dict
from placement.scene.limits import MAX_GRID_CELLS
from placement.scene.model import (
    Box,
    Cylinder,
    Obstacle,
    PlaceLocation,
    Polygon,
    Scene,
    SceneError,
    SceneObject,
    Shape,
    TaskStep,
    Trajectory,
)
from placement.scene.occupancy import OccupancyMap, OccupancyMapError, load_occupancy_map

__all__ = [
    "Box",
    "Cylinder",
    "MAX_GRID_CELLS",
    "Obstacle",
    "OccupancyMap",
    "OccupancyMapError",
    "PlaceLocation",
    "Polygon",
    "SCENE_VERSION",
    "SCENE_VERSIONS",
    "Scene",
    "SceneError",
    "SceneObject",
    "SceneParser",
    "Shape",
    "TaskStep",
    "Trajectory",
    "check_scene",
    "load_occupancy_map",
    "load_scene",
    "obstacle_to_dict",
    "parse_scene",
    "save_scene",
    "scene_to_dict",
]
