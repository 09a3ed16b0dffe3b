"""Robot presets and their kinematic chains."""

from placement.robots.preset import Arm, Robot, builtin_presets, load_robot, matrix_to_pose, pose_to_matrix
from placement.robots.spec import ArmSpec, PresetSpec, parse_preset

__all__ = [
    "Arm",
    "ArmSpec",
    "PresetSpec",
    "Robot",
    "builtin_presets",
    "load_robot",
    "matrix_to_pose",
    "parse_preset",
    "pose_to_matrix",
]
