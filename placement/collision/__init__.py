"""Collision-free arms: the robot's URDF collision shapes against the scene and against itself.

``SceneCollision(robot, scene).check(arm, qs, base, grasped)`` -> :class:`CollisionResult`; see
:mod:`placement.collision.checker` for the pairs and rules, :mod:`.robot` and :mod:`.scene` for the geometry.
"""

from placement.collision.bounds import base_matrix
from placement.collision.checker import CLEARANCE_CAP, SceneCollision
from placement.collision.robot import (
    CollisionGeometryWarning,
    RobotGeometry,
    load_geometry,
    moved_joints,
    robot_geometry,
)
from placement.collision.scene import PRISM_HEIGHT, OccupancyCells, SceneShape, scene_shapes
from placement.collision.tables import CollisionResult

__all__ = [
    "CLEARANCE_CAP",
    "CollisionGeometryWarning",
    "CollisionResult",
    "OccupancyCells",
    "PRISM_HEIGHT",
    "RobotGeometry",
    "SceneCollision",
    "SceneShape",
    "base_matrix",
    "load_geometry",
    "moved_joints",
    "robot_geometry",
    "scene_shapes",
]
