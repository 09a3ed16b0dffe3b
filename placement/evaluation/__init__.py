"""Evaluation (docs/design.md, How it is measured): generated benchmark scenes, the task time model, batch
evaluation of the planning methods against each other, and its figures."""

from placement.evaluation.evaluate import (
    check_methods,
    check_scenes,
    evaluate,
    evaluate_scene,
    scene_files,
    scene_task,
    summary_rows,
)
from placement.evaluation.generate import generate_scene, write_scenes
from placement.evaluation.outdir import output_dir, prepare_output_dir
from placement.evaluation.plots import plot_task_times
from placement.planning.task_time import task_time

__all__ = [
    "check_methods",
    "check_scenes",
    "evaluate",
    "evaluate_scene",
    "generate_scene",
    "output_dir",
    "plot_task_times",
    "prepare_output_dir",
    "scene_files",
    "scene_task",
    "summary_rows",
    "task_time",
    "write_scenes",
]
