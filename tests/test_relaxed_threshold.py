"""A step whose maps keep the threshold nowhere is planned with its threshold lowered to half its best
map value (a telescoping arm's top grasps at table height, a sparse map) instead of being called
infeasible: IK and the collision check still decide."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from placement.planning import Planner
from placement.planning.problems.cache import RELAX
from placement.scene import load_scene

TABLE_CLEARING = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"


@pytest.fixture(scope="module")
def strict(maps_dir):
    """The table-clearing example with a threshold of 1 (no map value reaches it) and as it is."""
    scene = load_scene(TABLE_CLEARING)
    high = dataclasses.replace(scene, planner={**scene.planner, "threshold": 1.0, "time_budget_s": 3600.0})
    return Planner(high, "global", maps_dir), Planner(scene, "global", maps_dir)


def test_relaxed_is_half_the_best_ratio_only_where_nothing_keeps_the_threshold(strict):
    high, plain = strict
    for i in range(len(high.problems.steps)):
        opts = high.problems.options(i)
        best = max(float(o.value.max()) for o in opts if o.value.size)
        assert 0 < best < 1.0
        assert high.problems.relaxed(i) == pytest.approx(RELAX * best / 1.0)
        assert plain.problems.relaxed(i) == 1.0
        # the step's context holds the lowered thresholds; the others are untouched
        ctx = high.context.for_step(i)
        assert ctx.config.threshold == pytest.approx(RELAX * best)
        assert all(t == pytest.approx(RELAX * best) for t in ctx.thresholds.arms.values())
        assert high.context.config.threshold == 1.0


@pytest.mark.parametrize("method", ["global", "sequential"])
def test_a_threshold_no_cell_keeps_still_plans_verified_steps(strict, method):
    high, _ = strict
    high.set_method(method)
    result = high.plan()
    assert result.ok, result.failed_step
    assert result.verify(high.robot) == []
    for step in result.steps:  # every placement keeps its step's lowered threshold
        assert step.manipulability >= high.problems.relaxed(step.step) * 1.0 - 1e-6
