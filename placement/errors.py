"""Exceptions of the placement package.

Every error names the culprit and, where there is a closed set of valid
choices, the alternatives, so that the CLI can print it as one line.
"""

from __future__ import annotations


class PlacementError(Exception):
    """Base class of every error the package raises on bad input."""


class RobotError(PlacementError):
    """A robot preset or URDF that cannot be used."""


class FrameNotFound(RobotError):
    """A frame name that the robot model does not have."""

    def __init__(self, frame: str, robot: str, candidates: list[str] | None = None):
        hint = ""
        if candidates:
            hint = "; close names: " + ", ".join(candidates[:8])
        super().__init__(f"frame '{frame}' not found in robot '{robot}'{hint}")
        self.frame = frame


class JointNotFound(RobotError):
    """A joint name that the robot model does not have."""

    def __init__(self, joint: str, robot: str, candidates: list[str] | None = None):
        hint = ""
        if candidates:
            hint = "; close names: " + ", ".join(candidates[:8])
        super().__init__(f"joint '{joint}' not found in robot '{robot}'{hint}")
        self.joint = joint


class ArmNotFound(RobotError):
    """An arm name that the robot preset does not define."""

    def __init__(self, arm: str, robot: str, arms: list[str]):
        super().__init__(
            f"robot '{robot}' has no arm '{arm}'; its arms are: {', '.join(arms)}"
        )
        self.arm = arm


class PresetError(RobotError):
    """A robot preset YAML that is malformed (names the key path)."""


class MapError(PlacementError):
    """A reachability map that is missing, half-written, corrupt or for another robot."""


class GridError(PlacementError):
    """Grid parameters (bounds, resolution, bins) that make no sense."""
