"""Robot presets and their kinematic chains."""

from .preset import Arm, Robot, builtin_presets, load_robot, matrix_to_pose, pose_to_matrix
from .spec import ArmSpec, PresetSpec, parse_preset

__all__ = ["Arm", "ArmSpec", "PresetSpec", "Robot", "builtin_presets", "load_robot", "matrix_to_pose", "parse_preset",
           "pose_to_matrix"]
