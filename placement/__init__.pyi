# The public names of `placement`: the one list that the lazy loader (placement/__init__.py, through
# lazy_loader.attach_stub) and type checkers both read. Add a public name here and nowhere else.

from .errors import (
    ArmNotFound,
    FrameNotFound,
    GridError,
    JointNotFound,
    MapError,
    PlacementError,
    PresetError,
    RobotError,
)
from .kinematics.ik import IKResult, solve_ik
from .kinematics.manipulability import extended_manipulability
from .maps.accuracy import check_map
from .maps.build import build_map
from .maps.grid import Grid
from .maps.opening import open_map
from .maps.rmap import ReachabilityMap, save_maps
from .planning import Certificate, InfeasibleStep, PlacedStep, PlannerConfig, PlanResult, StepResult
from .planning.planner import Planner, plan
from .robots import Arm, Robot, load_robot
from .storage.format import BuiltMap
from .version import __version__
from .viewer import view

__all__ = [
    "Arm",
    "ArmNotFound",
    "BuiltMap",
    "Certificate",
    "FrameNotFound",
    "Grid",
    "GridError",
    "IKResult",
    "InfeasibleStep",
    "JointNotFound",
    "MapError",
    "PlacementError",
    "PlacedStep",
    "PlanResult",
    "Planner",
    "PlannerConfig",
    "PresetError",
    "ReachabilityMap",
    "Robot",
    "RobotError",
    "StepResult",
    "__version__",
    "build_map",
    "check_map",
    "extended_manipulability",
    "load_robot",
    "open_map",
    "plan",
    "save_maps",
    "solve_ik",
    "view",
]
