"""The ``fixed`` baseline's ranking: every (placement, option) value evaluated in one pass per map and
yaw equals its own evaluation (the plain loop below), and the placements are computed once per world."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from placement.planning import Planner
from placement.planning.methods.fixed import fixed_placements, placement_values, rank_fixed
from placement.planning.problems import manipulation_map
from placement.planning.torso import option_map
from placement.scene.navgrid import Window

ROOT = Path(__file__).resolve().parents[1]


def plain_values(ctx, options, placements):
    """Each (placement, option) alone, as the baseline was first written (the options the gripper rules
    out left out: they are never tried)."""
    nav = ctx.world.nav
    out = {}
    for flat, yaw in placements:
        for k, o in enumerate(options):
            if o.blocked is not None:
                continue
            cell = np.array([flat], dtype=np.int64)
            v, _ = manipulation_map(
                option_map(ctx, o), o.candidate.poses, nav, np.array([yaw]), cell, Window.around(cell, nav.shape, 0)
            )
            out[k, flat, yaw] = float(v[0, 0])
    return out


@pytest.mark.parametrize("scene", ["table_clearing.yaml", pytest.param("kitchen.yaml", marks=pytest.mark.slow)])
def test_one_pass_per_map_and_yaw_equals_each_alone(tiny_maps, scene):
    planner = Planner(ROOT / "examples" / scene, "fixed", tiny_maps, warm=False)
    ctx = planner.context
    placements = fixed_placements(ctx)
    assert len(placements) >= 4
    checked = 0
    for i in range(len(ctx.problems.steps)):
        options = ctx.problems.options(i)
        want = plain_values(ctx, options, placements)
        assert placement_values(ctx, options, placements) == want
        checked += sum(v > 0 for v in want.values())
        ranked = rank_fixed(ctx, options)
        assert [(-r.cost, r.option, r.cell) for r in ranked] == sorted(
            ((v, k, f) for (k, f, _), v in want.items() if v > 0), key=lambda t: (-t[0], t[1], t[2])
        )
    assert checked > 0


def test_the_placements_are_computed_once_per_world(tiny_maps):
    planner = Planner(ROOT / "examples" / "table_clearing.yaml", "fixed", tiny_maps, warm=False)
    first = fixed_placements(planner.context)
    assert fixed_placements(planner.context) == first
    assert fixed_placements(planner.context) is not fixed_placements(planner.context)  # a copy each time
