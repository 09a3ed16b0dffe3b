"""Planning: from a scene to verified base placements (see planner.py for the stages)."""

from placement.planning.methods import DEFAULT_METHOD, METHODS
from placement.planning.planner import Planner, plan
from placement.planning.results import Certificate, InfeasibleStep, PlacedStep, PlanResult, StepResult
from placement.planning.settings import PLANNER_KEYS, PlannerConfig
from placement.scene import Scene, SceneError, load_scene, parse_scene, save_scene

__all__ = [
    "DEFAULT_METHOD",
    "METHODS",
    "Certificate",
    "InfeasibleStep",
    "PLANNER_KEYS",
    "PlacedStep",
    "PlanResult",
    "Planner",
    "PlannerConfig",
    "Scene",
    "SceneError",
    "StepResult",
    "load_scene",
    "parse_scene",
    "plan",
    "save_scene",
]
