"""Time-efficient robot base placement for mobile manipulation.

Public API (see README and docs/): robots (:func:`load_robot`), the manipulability measure, reachability
maps (:func:`build_map`, :func:`open_map`, :func:`check_map`), IK, and planning (:func:`plan`,
:class:`Planner`, typed results). No viewer or plotting module is imported here.
"""

import os as _os
import sys as _sys
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
from placement.kinematics.ik import IKResult, solve_ik  # noqa: E402
from placement.kinematics.manipulability import extended_manipulability  # noqa: E402
from placement.maps.grid import Grid  # noqa: E402
from placement.maps.opening import open_map  # noqa: E402
from placement.maps.rmap import ReachabilityMap, save_maps  # noqa: E402
from placement.planning import PlannerConfig, PlanResult, StepResult  # noqa: E402
from placement.planning.planner import Planner, plan  # noqa: E402
from placement.robots import Arm, Robot, load_robot  # noqa: E402
from placement.storage.format import BuiltMap  # noqa: E402
from placement.version import __version__  # noqa: E402

# the map builder and the accuracy check pull in the sampler, tqdm and coal: loaded on first use, so
# that opening a map (the online path) does not pay for them
_LAZY = {"build_map": "placement.maps.build", "check_map": "placement.maps.accuracy", "view": "placement.viewer"}


def __getattr__(name: str) -> _Any:  # the lazy function, of its own type
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'placement' has no attribute '{name}'")


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
