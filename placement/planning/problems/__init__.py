"""What each step asks of an arm: its TCP trajectories, options and manipulation maps.

A task's steps and their candidates (grasps, places as transfers of the picked grasp: :mod:`.steps`,
:mod:`.grasps`, :mod:`.transfer`); an :class:`Option` is one (arm, candidate, torso setting) with its
manipulation map (:mod:`.manipulation`, the paper's section IV-B), judged against its arm's threshold
(:mod:`.thresholds`) on the map of its torso setting (:mod:`.torso_maps`). :class:`StepProblems`
(:mod:`.cache`) keeps them per step for a live planner and says what a scene change invalidates.
"""

from placement.planning.problems.cache import THRESHOLD_PASS_FROM, StepProblems
from placement.planning.problems.manipulation import (
    base_yaws,
    distinct_slices,
    manipulation_map,
    manipulation_maps,
    pose_reach,
    pose_slices,
    yaw_values,
)
from placement.planning.problems.option import Option, height_range
from placement.planning.problems.screening import blocked_summary, step_objects
from placement.planning.problems.steps import Step, pose_role, step_candidates, task_steps
from placement.planning.problems.thresholds import (
    Thresholds,
    per_arm_values,
    resolve_thresholds,
    setting_thresholds,
    threshold_at,
    with_threshold,
)
from placement.planning.problems.torso_maps import map_variants, torso_record, torso_value
from placement.planning.problems.transfer import UPRIGHT_TOLERANCE, held_object, tilt_between

__all__ = [
    "THRESHOLD_PASS_FROM",
    "UPRIGHT_TOLERANCE",
    "Option",
    "Step",
    "StepProblems",
    "Thresholds",
    "base_yaws",
    "blocked_summary",
    "distinct_slices",
    "height_range",
    "held_object",
    "manipulation_map",
    "manipulation_maps",
    "map_variants",
    "per_arm_values",
    "pose_reach",
    "pose_role",
    "pose_slices",
    "resolve_thresholds",
    "setting_thresholds",
    "step_candidates",
    "step_objects",
    "task_steps",
    "threshold_at",
    "tilt_between",
    "torso_record",
    "torso_value",
    "with_threshold",
    "yaw_values",
]
