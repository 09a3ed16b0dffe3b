"""Time-efficient robot base placement for mobile manipulation.

Public API (see README and docs/): robots (:func:`load_robot`), the manipulability measure, reachability
maps (:func:`build_map`, :func:`open_map`, :func:`check_map`), IK, and planning (:func:`plan`,
:class:`Planner`, typed results). Importing the package loads only the errors and the version: each
other name loads its module on first use. No viewer or plotting module is imported here.
"""

import os as _os
import sys as _sys
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any as _Any


def _default_numba_cache_dir() -> "str | None":
    """Where the compiled kernels live when ``NUMBA_CACHE_DIR`` is unset: ``<venv>/numba-cache``.

    ``make install`` compiles every kernel there (``python -m placement.warmup``), so every entry
    point of the environment (``.venv/bin/placement``, ``python -m placement...``, pytest, a notebook)
    finds them. Outside a virtual environment (``sys.prefix`` is the system's) nothing is set and the
    kernels use ``~/.cache/placement/numba`` (:mod:`placement.kernels`).
    """
    if _sys.prefix == _sys.base_prefix:
        return None
    return _os.path.join(_sys.prefix, "numba-cache")


# before anything imports numba or placement.kernels (which reads the variable)
_cache_dir = _default_numba_cache_dir()
if not _os.environ.get("NUMBA_CACHE_DIR") and _cache_dir:
    _os.environ["NUMBA_CACHE_DIR"] = _cache_dir

from placement.errors import (  # noqa: E402
    ArmNotFound,
    FrameNotFound,
    GridError,
    JointNotFound,
    MapError,
    PlacementError,
    PresetError,
    RobotError,
)
from placement.version import __version__  # noqa: E402

if _TYPE_CHECKING:  # what the lazy names are, for type checkers and IDEs (never run)
    from placement.kinematics.ik import IKResult, solve_ik
    from placement.kinematics.manipulability import extended_manipulability
    from placement.maps.accuracy import check_map
    from placement.maps.build import build_map
    from placement.maps.grid import Grid
    from placement.maps.opening import open_map
    from placement.maps.rmap import ReachabilityMap, save_maps
    from placement.planning import PlannerConfig, PlanResult, StepResult
    from placement.planning.planner import Planner, plan
    from placement.robots import Arm, Robot, load_robot
    from placement.storage.format import BuiltMap

#: public name -> the module defining it, imported on first access: importing the package then costs
#: no numba, zarr or pinocchio (about 1.6 s), so a command's --help or a bad option answers at once,
#: and opening a map (the online path) does not pay for the builder (sampler, tqdm, coal)
_LAZY = {
    "Arm": "placement.robots",
    "BuiltMap": "placement.storage.format",
    "Grid": "placement.maps.grid",
    "IKResult": "placement.kinematics.ik",
    "PlanResult": "placement.planning",
    "Planner": "placement.planning.planner",
    "PlannerConfig": "placement.planning",
    "ReachabilityMap": "placement.maps.rmap",
    "Robot": "placement.robots",
    "StepResult": "placement.planning",
    "build_map": "placement.maps.build",
    "check_map": "placement.maps.accuracy",
    "extended_manipulability": "placement.kinematics.manipulability",
    "load_robot": "placement.robots",
    "open_map": "placement.maps.opening",
    "plan": "placement.planning.planner",
    "save_maps": "placement.maps.rmap",
    "solve_ik": "placement.kinematics.ik",
    "view": "placement.viewer",
}


def __getattr__(name: str) -> _Any:  # a lazy name, of its own type
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'placement' has no attribute '{name}'")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups find it without this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})


__all__ = [
    "Arm",
    "ArmNotFound",
    "BuiltMap",
    "FrameNotFound",
    "Grid",
    "GridError",
    "IKResult",
    "JointNotFound",
    "MapError",
    "PlacementError",
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
]
