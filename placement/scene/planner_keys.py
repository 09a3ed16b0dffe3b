"""The planner settings a scene's ``planner:`` block may set: each one's default, help text (with its unit) and
bounds.

This table is the single source of those settings: the scene parser checks a block against it (it sits below
the planner, so the scene need not import the planner), and :class:`placement.planning.settings.PlannerConfig`
builds its scene-settable fields from it, so the parser, the docs and the defaults cannot drift apart.
"""

from __future__ import annotations

from typing import Any

#: Largest weight a scene may set [1/m]: far beyond any sensible trade-off, small enough that
#: ``weight / m`` and ``weight * cost`` stay finite for every map value and grid.
MAX_WEIGHT = 1e6

#: Default ``threshold_quantile``: the fraction of the default PR2 maps' reached cells below the
#: paper's threshold 0.0235, rounded down (right arm 0.3434, left 0.3433: 30 M samples, 5 cm cells, with
#: completion), so that the PR2 keeps its threshold (0.02346 and 0.02348) and every other arm gets the
#: same share of its own cells. See docs/planning.md, "The threshold".
DEFAULT_THRESHOLD_QUANTILE = 0.343

#: Planner keys of which a scene's block may give at most one (each replaces the other).
EXCLUSIVE = (("threshold", "threshold_quantile"),)

#: name -> default, help (with unit and default) and bounds (minimum, maximum, strict, integer, or_list).
PLANNER_SETTINGS: dict[str, dict[str, Any]] = {
    "lambda_n": dict(
        default=1 / 20,
        help="weight of the navigation cost [1/m], 0 .. 1e6 (default 1/20)",
        minimum=0.0,
        maximum=MAX_WEIGHT,
    ),
    "lambda_m": dict(
        default=0.002353,
        help="weight of the manipulation cost 1/m, 0 .. 1e6 (default 0.002353)",
        minimum=0.0,
        maximum=MAX_WEIGHT,
    ),
    "lambda_nh": dict(
        default=1 / 20,
        help="weight of the heuristic cost towards the next step [1/m], 0 .. 1e6 (default 1/20)",
        minimum=0.0,
        maximum=MAX_WEIGHT,
    ),
    "yaw_steps": dict(
        default=100,
        help="number of base yaws tried per cell, integer 1 .. 3600 (default 100)",
        integer=True,
        minimum=1,
        maximum=3600,
    ),
    "threshold": dict(
        default=0.0235,
        help="map value below which a placement is infeasible, the same on every arm, > 0 and <= 1 "
        "(default 0.0235; applies only when given, instead of threshold_quantile: not both)",
        minimum=0.0,
        strict=True,
        maximum=1.0,
    ),
    "threshold_quantile": dict(
        default=DEFAULT_THRESHOLD_QUANTILE,
        help="fraction of each arm's reached map cells, the lowest-valued, that are infeasible: the threshold is "
        "this quantile of the arm's non-zero map values, 0 .. 1 (default 0.343; 0.0235 on the PR2's maps)",
        minimum=0.0,
        maximum=1.0,
    ),
    "velocity_lambda": dict(
        default=1.3,
        help="lambda of the velocity model (Eq. 4), 0 .. 1e6 (default 1.3)",
        minimum=0.0,
        maximum=MAX_WEIGHT,
    ),
    "velocity_k": dict(
        default=4.0,
        help="exponent k of the velocity model (Eq. 4), > 0 and <= 100 (default 4)",
        minimum=0.0,
        strict=True,
        maximum=100.0,
    ),
    "d_max": dict(
        default=1.0,
        help="distance [m] beyond which obstacles do not slow the base, > 0 and <= 1000 (default 1)",
        minimum=0.0,
        strict=True,
        maximum=1000.0,
    ),
    "grasp_yaws": dict(
        default=8,
        help="gripper yaws of place steps: a count (integer 1 .. 360, evenly spaced) or a list of yaws [rad] "
        "(default 8)",
        integer=True,
        minimum=1,
        maximum=360,
        or_list=True,
    ),
    "collision_padding": dict(
        default=0.005,
        help="distance [m] below which the robot's collision shapes touch the scene's, 0 .. 0.5 (default 0.005)",
        minimum=0.0,
        maximum=0.5,
    ),
    "footprint_padding": dict(
        default=0.02,
        help="clearance [m] a polygon base footprint keeps from obstacles, 0 .. 1 (default 0.02; round bases "
        "ignore it)",
        minimum=0.0,
        maximum=1.0,
    ),
    "ik_budget_ms": dict(
        default=300.0,
        help="time the IK solves and collision checks of one step may take [ms], >= 1 and <= 60000 (default 300)",
        minimum=1.0,
        maximum=60000.0,
    ),
    "face_target": dict(
        default=0.0,
        help="share of a cell's best map value a base yaw facing the target may give up, 0 .. 1 (default 0; "
        "the best yaw)",
        minimum=0.0,
        maximum=1.0,
    ),
    "time_polish": dict(
        default=1,
        help="0 or 1 (default 1): 1 moves (global) and turns (global, optimal) the verified placements where "
        "that shortens the task time (the turn between placements counts); 0: the least travel, at each "
        "cell's best map yaw",
        minimum=0,
        maximum=1,
        integer=True,
    ),
    "time_budget_s": dict(
        default=10.0,
        help="time planning the whole task may take [s], 0.1 .. 3600 (default 10): a step not verified by "
        "then is infeasible, saying so",
        minimum=0.1,
        maximum=3600.0,
    ),
    "memory_budget_gib": dict(
        default=3.0,
        help="memory planning the whole task may add to the process [GiB], 0.01 .. 1024 (default 3): a step "
        "not verified by then is infeasible, saying so",
        minimum=0.01,
        maximum=1024.0,
    ),
}

#: Keys allowed in a scene's ``planner:`` block: name -> help text with unit and default.
PLANNER_KEYS: dict[str, str] = {name: s["help"] for name, s in PLANNER_SETTINGS.items()}

#: Their bounds, for the scene parser: name -> help and bounds (minimum, maximum, strict, integer, or_list).
PLANNER_BOUNDS: dict[str, dict[str, Any]] = {
    name: {k: v for k, v in s.items() if k != "default"} for name, s in PLANNER_SETTINGS.items()
}
