"""Time-efficient robot base placement for mobile manipulation.

Public API (see README): :func:`load_robot`, :func:`open_map`,
:func:`extended_manipulability`, :func:`build_map`.
"""

from .version import __version__

from .build import BuiltMap, build_map  # noqa: E402
from .errors import (  # noqa: E402
    ArmNotFound, FrameNotFound, GridError, JointNotFound, MapError, PlacementError, PresetError, RobotError,
)
from .grid import Grid  # noqa: E402
from .manipulability import extended_manipulability  # noqa: E402
from .robots import Arm, Robot, load_robot  # noqa: E402

__all__ = sorted([
    "Arm", "ArmNotFound", "BuiltMap", "FrameNotFound", "Grid", "GridError", "JointNotFound", "MapError",
    "PlacementError", "PresetError", "Robot", "RobotError", "__version__", "build_map",
    "extended_manipulability", "load_robot",
])

from .rmap import ReachabilityMap, open_map, save_maps  # noqa: E402

from .ik import IKResult, solve_ik  # noqa: E402
from .accuracy import check_map  # noqa: E402

from .planning.planner import Planner, plan  # noqa: E402

__all__ = sorted([*__all__, "IKResult", "Planner", "ReachabilityMap", "check_map", "open_map", "plan", "save_maps",
                  "solve_ik"])
