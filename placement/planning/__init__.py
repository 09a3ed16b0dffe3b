"""Planning: from a scene to verified base placements (see planner.py for the stages)."""

from .config import METHODS, PLANNER_KEYS, PlannerConfig
from .planner import Planner, plan
from .results import PlanResult, StepResult
from .scene import Scene, SceneError, load_scene, parse_scene, save_scene

__all__ = sorted(["METHODS", "PLANNER_KEYS", "PlanResult", "Planner", "PlannerConfig", "Scene", "SceneError",
                  "StepResult", "load_scene", "parse_scene", "plan", "save_scene"])
