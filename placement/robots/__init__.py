"""Robot presets and their kinematic chains."""

from .preset import Arm, Robot, builtin_presets, load_robot, matrix_to_pose, pose_to_matrix

__all__ = ["Arm", "Robot", "builtin_presets", "load_robot", "matrix_to_pose", "pose_to_matrix"]
