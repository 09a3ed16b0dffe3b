"""Exceptions of the placement package.

Every error names the culprit and, where there is a closed set of valid
choices, the alternatives, so that the CLI can print it as one line.
"""

from __future__ import annotations


class PlacementError(Exception):
    """Base class of every error the package raises on bad input."""


class RobotError(PlacementError):
    """A robot preset or URDF that cannot be used."""


class _NameNotFound(RobotError):
    """A name the robot model does not have, with the closest names it does have."""

    kind = "name"

    def __init__(self, name: str, robot: str, candidates: list[str] | None = None) -> None:
        hint = "; close names: " + ", ".join(candidates[:8]) if candidates else ""
        super().__init__(f"{self.kind} '{name}' not found in robot '{robot}'{hint}")
        self.name = name


class FrameNotFound(_NameNotFound):
    """A frame name that the robot model does not have (``frame``: the name)."""

    kind = "frame"

    @property
    def frame(self) -> str:
        return self.name


class JointNotFound(_NameNotFound):
    """A joint name that the robot model does not have (``joint``: the name)."""

    kind = "joint"

    @property
    def joint(self) -> str:
        return self.name


class ArmNotFound(RobotError):
    """An arm name that the robot preset does not define."""

    def __init__(self, arm: str, robot: str, arms: list[str]) -> None:
        super().__init__(f"robot '{robot}' has no arm '{arm}'; its arms are: {', '.join(arms)}")
        self.arm = arm


class PresetError(RobotError):
    """A robot preset YAML that is malformed (names the key path)."""


class MapError(PlacementError):
    """A reachability map that is missing, half-written, corrupt or for another robot."""


class GridError(PlacementError):
    """Grid parameters (bounds, resolution, bins) that make no sense."""


class ViewerError(PlacementError):
    """The viewer cannot start (viser missing, a bad port, a plan file that does not fit)."""
