"""Why ``global`` (and ``optimal``) call a step infeasible when IK and the collision check reject the
placements the maps allow: every one of them, or every one the base can drive to (the others lie in a
pocket of floor it cannot reach). IK is real and held to a tolerance no solution meets, so every
placement verification tries is rejected."""

from __future__ import annotations

import time
from dataclasses import replace

import pytest

from placement.planning import Planner
from placement.planning.methods.optimal import DynamicProgram, solve_verified
from placement.scene import parse_scene

WALL = 0.1
#: a pocket of floor north of the table (x 4.4 .. 6.0, y 2.35 .. 4.0), closed by knee-high walls: the
#: arm reaches over them, the base cannot get in
POCKET = [
    ((5.2, 4.0 + WALL / 2), (1.6 + 2 * WALL, WALL)),
    ((4.4 - WALL / 2, 3.2), (WALL, 1.7)),
    ((6.0 + WALL / 2, 3.2), (WALL, 1.7)),
]


def reach_scene(walls):
    """One reach step: a top-down TCP trajectory over the middle of a table 0.7 m deep, within reach
    from both of its long sides."""
    down = [1.0, 0.0, 0.0, 0.0]  # the TCP's z (approach) pointing down
    return parse_scene(
        {
            "version": 2,
            "bounds": [-1.0, -1.0, 8.0, 6.0],
            "robot": {"preset": "pr2", "start": [1.0, 1.0, 0.0]},
            "obstacles": [
                {"name": "table", "box": {"center": [5.2, 2.0, 0.36], "size": [1.6, 0.7, 0.72]}, "table": True}
            ]
            + [
                {"name": f"wall_{i}", "box": {"center": [x, y, 0.15], "size": [sx, sy, 0.3]}}
                for i, ((x, y), (sx, sy)) in enumerate(walls)
            ],
            "trajectories": [{"name": "tap", "poses": [[5.2, 2.0, 0.95, *down], [5.2, 2.0, 0.85, *down]]}],
            "task": [{"reach": "tap"}],
        }
    )


def rejected_everywhere(planner):
    """The planner's plan with IK held to a tolerance no solution meets (1e-300 m and rad: no floating-point
    residual is that small but 0)."""
    ctx = planner.context
    config = replace(ctx.config, ik_pos_tol_m=1e-300, ik_rot_tol_rad=1e-300, ik_budget_ms=60_000.0)
    ctx = replace(ctx, config=config, deadline=time.perf_counter() + 300.0, spent=[])
    return planner.method.plan(ctx, planner.start_cell(), False)


@pytest.mark.parametrize("method", ["global", "optimal"])
def test_rejections_of_every_placement_the_maps_allow_say_so(maps_dir, method):
    planner = Planner(reach_scene([]), method, maps_dir)
    (step,) = rejected_everywhere(planner)
    assert step.status == "infeasible"
    assert step.reason.startswith("IK or the collision check rejected all "), step.reason
    assert "placements the maps allow" in step.reason
    d = step.diagnosis
    assert d["tried"] == d["ik_failures"] > 0 and d["collision_failures"] == 0


@pytest.mark.parametrize("method", ["global", "optimal"])
def test_rejections_of_every_placement_the_base_can_reach_say_the_rest_lie_where_it_cannot_drive(maps_dir, method):
    planner = Planner(reach_scene(POCKET), method, maps_dir)
    problems, world = planner.problems, planner.world
    pocket = world.feasible & ~problems.reachable
    assert (problems.feasible_region(0) & pocket).any()  # the maps allow placements in the pocket
    (step,) = rejected_everywhere(planner)
    assert step.status == "infeasible"
    assert step.reason.startswith("IK or the collision check rejected the placements the base can reach ("), step.reason
    assert step.reason.endswith("; the others lie where the footprint cannot drive"), step.reason
    assert step.diagnosis["tried"] == step.diagnosis["ik_failures"] > 0


def test_groups_the_probes_dropped_come_back_once_and_are_searched_cell_by_cell(maps_dir):
    """``global`` drops a group a probe finds no verifying cell of (``DynamicProgram.hopeless``); when
    that leaves no chain, the program is solved again over every group, once, and drops none again:
    the step is said to be infeasible for what truly rejected it."""
    planner = Planner(reach_scene([]), "global", maps_dir)
    ctx = planner.context
    config = replace(ctx.config, ik_pos_tol_m=1e-300, ik_rot_tol_rad=1e-300, ik_budget_ms=60_000.0)
    ctx = replace(ctx, config=config, deadline=time.perf_counter() + 300.0, spent=[])
    dp = DynamicProgram(ctx, planner.start_cell(), 1, config.global_exact_repairs)
    dp.local = dp.program.lazy = True
    dropped_before = []
    real = dp.exact_again

    def counted():
        dropped_before.append(list(dp.dropped))
        return real()

    dp.exact_again = counted  # type: ignore[method-assign]
    chain, picks, failure = solve_verified(dp)
    assert chain is None and not picks and failure is not None
    assert len(dropped_before) == 1 and dropped_before[0], "the probes dropped the groups, once"
    assert not dp.probing and not dp.dropped
    assert failure.reason.startswith("IK or the collision check rejected all "), failure.reason
