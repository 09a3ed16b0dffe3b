"""Whole plans on tiny maps (the fast tier's planning): every method on the example scenes, each plan
checked independently (pinocchio FK of every pose, transfers, exact footprint clearance), the
certificate's bound below every travel, re-planning after a change equal to a fresh planner."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from support.budgets import unbudgeted
from support.plans import strip_timings

import placement
from placement.planning import METHODS, Planner, PlanResult, load_scene, save_scene

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SCENES = {
    "table_clearing": EXAMPLES / "table_clearing.yaml",
    "wrs_arena": EXAMPLES / "buildings" / "wrs_arena" / "tidy_up.yaml",
    "kitchen": EXAMPLES / "kitchen.yaml",  # version 2: a drawer's reach, side grasps, a can lying down
}
#: methods that must plan every step of these scenes on the tiny maps (``fixed`` parks only at the
#: tables' sides: the arena's shelf and the kitchen's drawer have none it reaches from)
COMPLETE = ("global", "optimal", "sequential", "single-step", "irm")


def unhurried(path: Path):
    """The scene at ``path`` with budgets that no load on the machine reaches (the plans must not
    depend on how busy it is)."""
    scene = load_scene(path)
    return unbudgeted(scene)


@pytest.fixture(scope="module")
def plans(tiny_maps):
    """(planner, plan) per (scene, method): one planner per scene, switched from method to method as
    ``evaluate`` switches it (its maps, options and checks shared; each plan is a fresh planner's:
    test_a_planner_shared_by_every_method_plans_as_fresh_planners)."""
    out = {}
    for name, path in SCENES.items():
        planner = Planner(unhurried(path), next(iter(METHODS)), tiny_maps)
        for method in METHODS:
            planner.set_method(method)
            out[name, method] = planner, planner.plan()
    return out


@pytest.mark.parametrize("scene", sorted(SCENES))
@pytest.mark.parametrize("method", METHODS)
def test_every_planned_step_verifies_independently(plans, scene, method):
    planner, result = plans[scene, method]
    if method in COMPLETE:
        assert result.ok, result.failed_step.reason if result.failed_step else "no steps"
    else:
        assert result.steps and (result.ok or result.failed_step is not None)
    assert result.verify(planner.robot, scene=planner.scene) == []
    doc = json.loads(json.dumps(result.to_json()))
    assert doc["status"] == result.status and len(doc["steps"]) == len(result.steps)


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_the_bound_is_below_every_complete_plans_travel_and_task_time(plans, scene):
    for method in COMPLETE:
        cert = plans[scene, method][1].certificate
        assert cert is not None and cert.travel_s is not None and cert.task_time_s is not None
        assert cert.lower_bound_s <= cert.travel_s + 1e-6, method
        assert cert.travel_s <= cert.task_time_s + 1e-6, method
        travel = sum(s.travel_time_s or 0.0 for s in plans[scene, method][1].steps)
        assert math.isclose(cert.travel_s, travel, abs_tol=1e-6), method


def test_optimal_travels_no_more_than_any_method_on_the_same_regions(plans):
    """``optimal`` is the exact least travel over the maps' regions whatever IK rejects later; the
    step-by-step methods stand on cells of the same regions, so none of them travels less (when no
    step needed a relaxed threshold)."""
    compared = 0
    for scene in SCENES:
        best = plans[scene, "optimal"][1].certificate
        assert best is not None and best.travel_s is not None
        for method in ("sequential", "single-step", "irm"):
            planner, result = plans[scene, method]
            relaxed = any(planner.problems.relaxed(i) < 1.0 for i in range(len(planner.problems.steps)))
            if not relaxed and result.certificate is not None and result.certificate.travel_s is not None:
                assert best.travel_s <= result.certificate.travel_s + 1e-6, (scene, method)
                compared += 1
    assert compared >= 3


def test_plan_returns_what_the_planner_returns(tiny_maps):
    result = placement.plan(unhurried(SCENES["table_clearing"]), "sequential", tiny_maps)
    assert isinstance(result, PlanResult)
    again = Planner(unhurried(SCENES["table_clearing"]), "sequential", tiny_maps).plan()
    assert strip_timings(result.to_json()) == strip_timings(again.to_json())


def test_a_moved_object_replans_as_a_fresh_planner(tiny_maps, tmp_path):
    planner = Planner(unhurried(SCENES["table_clearing"]), "global", tiny_maps)
    planner.plan()
    obj = planner.scene.objects[0]
    x, y, z = obj.position
    planner.update({"objects": [{"name": obj.name, "position": [float(x) + 0.1, float(y), float(z)]}]})
    moved = planner.plan()
    fresh = Planner(save_scene(planner.scene, tmp_path / "moved.yaml"), "global", tiny_maps).plan()
    assert [s.base for s in moved.steps] == [s.base for s in fresh.steps]
    assert [(s.arm, s.grasp) for s in moved.steps] == [(s.arm, s.grasp) for s in fresh.steps]


def test_a_planner_built_without_warming_plans_the_same(tiny_maps):
    cold = Planner(unhurried(SCENES["table_clearing"]), "global", tiny_maps, warm=False)
    warmed = Planner(unhurried(SCENES["table_clearing"]), "global", tiny_maps)
    assert strip_timings(cold.plan().to_json()) == strip_timings(warmed.plan().to_json())
    cold.warm()  # idempotent: the planner plans the same afterwards
    assert strip_timings(cold.plan().to_json()) == strip_timings(warmed.plan().to_json())


@pytest.mark.slow
def test_a_planner_shared_by_every_method_plans_as_fresh_planners(plans, tiny_maps):
    """The kitchen (side grasps, a drawer, a can lying down: the most work any method here does), each
    method's plan on the planner the others planned on before it equals a fresh planner's, bit for
    bit but the timings: what one method left in the caches changes no other method's plan."""
    for method in METHODS:
        fresh = Planner(unhurried(SCENES["kitchen"]), method, tiny_maps).plan()
        shared = plans["kitchen", method][1]
        assert strip_timings(shared.to_json()) == strip_timings(fresh.to_json()), method
