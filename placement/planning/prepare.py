"""Readying a planner before its first step: the kernels loaded, the map slices of every step read.

A fresh process pays once for loading each numba kernel from the disk cache and for starting the
thread pool (about 20 ms each), and every map slice is read and checked on first use. Doing that
when the planner is built keeps it out of the first step's time; the work is the same. Reading the
slices takes at most :data:`PREFETCH_SHARE` of the task's time budget (a task of hundreds of place
yaws per step reads for seconds; its later steps read their own slices).
"""

from __future__ import annotations

import math
import time

import numpy as np

from placement.kernels.footprint import pose_blocked
from placement.kernels.grid import zyx_angles
from placement.kernels.irm import column_maxima, farthest_reached, yaw_bits
from placement.kernels.navigation import component_of, components8
from placement.kinematics.ik import solve_ik
from placement.planning.context import PlanningContext
from placement.planning.methods import rank_by_cost
from placement.planning.problems import (
    THRESHOLD_PASS_FROM,
    Option,
    StepProblems,
    distinct_slices,
    manipulation_maps,
    step_candidates,
)
from placement.planning.settings import PlannerConfig
from placement.planning.torso import collisions_at, start_torso, torso_value
from placement.planning.world import costs_at, navigation_cost
from placement.robots import Robot
from placement.scene.navgrid import NavGrid, Window

_warm = False
#: Share of the task's ``time_budget_s`` the slices may be read for when a planner is built.
PREFETCH_SHARE = 0.2
#: A step's witness slices in one map are read when the planner is built if they are at most this many
#: (see :func:`prefetch_slices`)
WITNESS_SLICES = 16


def warm_kernels(problems: StepProblems, robot: Robot) -> None:
    """Run each planning kernel once on a tiny problem of the real types (once per process)."""
    global _warm
    if _warm:
        return
    nav = NavGrid((0.0, 0.0), 0.05, (3, 3))
    ones = np.ones(nav.shape)
    cost, _ = navigation_cost(ones, np.ones(nav.shape, bool), (1, 1), nav.resolution, targets=np.eye(3, dtype=bool))
    # a world's layers are read-only, a type of their own to numba (its search keeps their padded grid)
    frozen, free = ones.copy(), np.ones(nav.shape, bool)
    frozen.flags.writeable = free.flags.writeable = False
    costs_at(frozen, free, (1, 1), nav.resolution, np.array([0, 8]))
    _load_small_kernels()
    step = problems.steps[0]
    cand = step_candidates(problems.scene, step, problems.config, problems.opening_m)[0]
    for arm, rmap in problems.maps.items():
        window = Window(0, 3, 0, 3)
        value, yaw = manipulation_maps(
            rmap, [cand.poses], nav, problems.yaws[:1], np.array([4], dtype=np.int64), window
        )[0]
        option = Option(arm, cand, window, value, yaw)
        rank_by_cost([option], cost, np.zeros(nav.shape), PlannerConfig(), problems.yaws[:1])
        a = robot.arm(arm)
        solve_ik(robot, arm, robot.tcp_pose(arm, a.home), a.home, seeds=1, max_iter=1)
    _warm = True


def _load_small_kernels() -> None:
    """Call the small kernels a plan calls on the array types it passes them (map slices read-only
    where merged, writable as read; a world's read-only layers): loading each from numba's cache
    costs a few milliseconds in a fresh process, which the first plan should not pay."""
    writable = np.zeros((2, 2, 2), np.float32)
    frozen = writable.copy()
    frozen.flags.writeable = False
    for values in (writable, frozen):
        column_maxima(values)
        yaw_bits(values, 0.5)
        farthest_reached(values, 0.0, 0.0, 0.1)
    zyx_angles(np.eye(4))
    touched = np.zeros((3, 3), bool)
    square = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
    for read_only in (False, True):
        touched.flags.writeable = not read_only
        pose_blocked(touched, 0.0, 0.0, 0.05, square, 0.0)
        component_of(touched, 1, 1)
        components8(touched)


def prefetch_slices(problems: StepProblems, seconds: float = math.inf) -> bool:
    """Read (and check) every map slice the task's candidates will use, and the witnesses (the IK
    starts there) of a step's slices in a map where they are at most :data:`WITNESS_SLICES`, for at most
    about ``seconds`` [s] (checked between steps; the slices not read then are read on first use, the
    plans are the same); True when all were read.

    A step verifies a few placements, each reading the witness slice of its option's first pose: of
    a step's few slices it reads most, of its hundreds (published grasps, a place's yaws) a few, which
    are read when a verification needs them (the DexYCB lab read 608 witness slices here, of which its plan
    used 37)."""
    end = time.perf_counter() + seconds
    views = [m for maps in problems.variants.values() for m in maps]
    read: set[tuple[int, tuple[int, int, int]]] = set()
    witnessed: set[tuple[int, tuple[int, int, int]]] = set()
    for i in range(len(problems.steps)):
        if time.perf_counter() > end:
            return False
        candidates = problems.candidates(i)
        if not candidates:
            continue
        poses = np.concatenate([c.poses for c in candidates])
        for k, rmap in enumerate(views):
            keys = distinct_slices(rmap, poses)  # a place's hundreds of yaws share slices
            rmap.read_slices(key for key in keys if (k, key) not in read)
            read.update((k, key) for key in keys)
            if len(keys) <= WITNESS_SLICES:
                rmap.read_slices((key for key in keys if (k, key) not in witnessed), witness=True)
                witnessed.update((k, key) for key in keys)
    return True


def prefetch_polar(ctx: PlanningContext, seconds: float = math.inf) -> bool:
    """Make the polar bounds (:meth:`~placement.maps.rmap.ReachabilityMap.polar_bound`) of the slices of
    the steps with at least :data:`~placement.planning.problems.cache.THRESHOLD_PASS_FROM` candidates, in
    the maps at the torso value the robot starts with, for at most about ``seconds`` [s]: the kernel
    passes that read them (a published grasp set's places) start with them made, the bound skipping
    the base cells no base yaw serves. Any not made here are made on first use (the plans are the same).
    True when all were made."""
    end = time.perf_counter() + seconds
    problems = ctx.problems
    held = start_torso(ctx)
    views = [m for maps in problems.variants.values() for m in maps if torso_value(m) == held]
    for i in range(len(problems.steps)):
        candidates = problems.candidates(i)
        if len(candidates) < THRESHOLD_PASS_FROM:
            continue
        poses = np.concatenate([c.poses for c in candidates])
        for rmap in views:
            for key in distinct_slices(rmap, poses):
                if time.perf_counter() > end:
                    return False
                rmap.polar_bound((key[0],), key[1], key[2])
    return True


def warm_checks(ctx: PlanningContext) -> None:
    """One witness lookup and one collision check per arm (results unused): the first of each in a
    process loads kernels and builds caches (about 10 ms each), which the first step should not pay."""
    robot = ctx.robot
    for arm, rmap in ctx.maps.items():
        a = robot.arm(arm)
        rmap.witness_q(robot.tcp_pose(arm, a.home))
        for view in ctx.problems.variants[arm]:  # one collision check per torso setting
            checker = collisions_at(ctx, torso_value(view))
            if checker is not None:
                checker.check(arm, np.asarray(a.home, dtype=float)[None], ctx.scene.start)
