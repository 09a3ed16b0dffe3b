"""Time-efficient robot base placement for mobile manipulation.

Public API (see README): robots (:func:`load_robot`), the manipulability measure, reachability
maps (:func:`build_map`, :func:`open_map`, :func:`check_map`), IK, and planning (:func:`plan`,
:class:`Planner`, typed results). No viewer or plotting module is imported here.
"""

from .errors import (
    ArmNotFound, FrameNotFound, GridError, JointNotFound, MapError, PlacementError, PresetError, RobotError,
)
from .grid import Grid
from .ik import IKResult, solve_ik
from .manipulability import extended_manipulability
from .planning import PlannerConfig, PlanResult, StepResult
from .planning.planner import Planner, plan
from .rmap import ReachabilityMap, open_map, save_maps
from .robots import Arm, Robot, load_robot
from .storage.format import BuiltMap
from .version import __version__

# the map builder and the accuracy check pull in the sampler, tqdm and coal: loaded on first use, so
# that opening a map (the online path) does not pay for them
_LAZY = {"build_map": "build", "check_map": "accuracy", "view": "viewer"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'placement' has no attribute '{name}'")


__all__ = sorted([
    "Arm", "ArmNotFound", "BuiltMap", "FrameNotFound", "Grid", "GridError", "IKResult", "JointNotFound",
    "MapError", "PlacementError", "PlanResult", "Planner", "PlannerConfig", "PresetError", "ReachabilityMap",
    "Robot", "RobotError", "StepResult", "__version__", "build_map", "check_map", "extended_manipulability",
    "load_robot", "open_map", "plan", "save_maps", "solve_ik",
])
