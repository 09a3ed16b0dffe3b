"""Scenes planned without time budgets, for tests whose plans must not depend on the machine's load."""

from __future__ import annotations

from dataclasses import replace

from placement.scene import Scene

#: Budgets no test run reaches: the IK search's at its maximum, the task's at an hour.
NO_BUDGET = {"ik_budget_ms": 60000.0, "time_budget_s": 3600.0}


def unbudgeted(scene: Scene) -> Scene:
    """``scene`` with :data:`NO_BUDGET` over its planner keys."""
    return replace(scene, planner={**scene.planner, **NO_BUDGET})
