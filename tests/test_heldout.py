"""Held-out scenes (not the examples, not the scenes the planner's tests were tuned on), planned with the
test maps and checked by the independent collision check (tests/oracle_collision.py) and by pinocchio FK
(PlanResult.verify): no arm-scene or self collision, the base footprint clear of every obstacle, every
pose verified, and the planner's clearance_m the independent smallest distance (within 1 mm)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from oracle_collision import IndependentCheck

from placement.collision import SceneCollision
from placement.planning import Planner

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CAP = 0.2  # [m] the planner's clearance cap (placement.collision.CLEARANCE_CAP)


def check_plan(planner, result, robot) -> list:
    """Assert the plan is collision-free, verified and its clearances right; return the checks."""
    assert result.verify(robot) == []
    checks = IndependentCheck(robot, planner.scene, cap=CAP).check_plan(result.to_json())
    planned = [s for s in result.steps if s.ok]
    assert len(checks) == len(planned)
    for s, c in zip(planned, checks):
        assert not c.scene_hits and not c.self_hits and not c.object_hits, (
            s.step,
            c.scene_hits,
            c.self_hits,
            c.object_hits,
        )
        pad = planner.base_config.collision_padding
        assert c.scene_m >= pad and c.held_m >= pad and c.object_m >= pad
        if c.footprint_m is not None:
            assert c.footprint_m >= planner.base_config.footprint_padding - 1e-9, (s.step, c.footprint_m)
        mine = c.clearance(CAP)
        assert s.clearance_m == pytest.approx(mine, abs=1e-3) if mine < CAP else s.clearance_m >= CAP - 1e-3
    return checks


def write(tmp_path, doc: dict, name: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("seed,obstacles", [(21, False), (22, True)])
def test_generated_table_clearing(tmp_path, maps_dir, pr2, seed, obstacles):
    from placement.evaluation.generate import generate_scene

    doc = generate_scene(seed, 1, objects=3, obstacles=obstacles, maps=str(maps_dir))
    doc["planner"] = {"threshold": 0.01, "yaw_steps": 40}
    planner = Planner(write(tmp_path, doc, f"gen{seed}"))
    result = planner.plan()
    assert sum(s.ok for s in result.steps) >= 4
    check_plan(planner, result, pr2)


def kitchen_variant(maps) -> dict:
    """The kitchen example moved around: the shelf on the other wall, a box lying on its long side
    (turned about y, not x), the drawer pulls elsewhere along the counter, their handles 5 cm
    in front of it (at the face, the fingers closing around a handle are in the counter)."""
    doc = yaml.safe_load((EXAMPLES / "kitchen.yaml").read_text())
    doc["maps"] = str(maps)
    # machine-independent: the default 300 ms IK budget runs out on the reach step on a loaded machine
    doc["planner"] = {"ik_budget_ms": 60000, "time_budget_s": 3600}
    obs = {o["name"]: o for o in doc["obstacles"]}
    obs["shelf"]["box"] = {"center": [1.5, 4.6, 0.5], "size": [1.0, 0.4, 1.0]}
    obs["shelf_board"]["box"] = {"center": [1.5, 4.6, 1.41], "size": [1.0, 0.4, 0.02]}
    objects = {o["name"]: o for o in doc["objects"]}
    objects["juice"].update(position=[1.4, 4.62, 1.08], yaw=0.4)
    s = math.sqrt(0.5)
    objects["can_lying"].update(position=[3.3, 3.62, 0.78], orientation=[0.0, s, 0.0, s], size=[0.06, 0.07, 0.14])
    objects["can_lying"].pop("yaw", None)
    objects["cup"].update(position=[3.7, 3.4, 0.8])
    for t, x in zip(doc["trajectories"], (4.85, 5.55)):
        for p in t["poses"]:
            p[0], p[1] = x, p[1] + 0.05  # the handle 5 cm before the face: the fingers close around it
    return doc


@pytest.mark.slow
def test_v2_side_grasps_lying_object_and_reach(tmp_path, maps_dir, pr2):
    planner = Planner(write(tmp_path, kitchen_variant(maps_dir), "kitchen2"))
    result = planner.plan()
    done = {(s.action, s.target): s for s in result.steps if s.ok}
    assert ("reach", "drawer_left,drawer_right") in done
    assert done[("pick", "juice")].grasp.startswith("side-")
    assert ("pick", "can_lying") in done
    check_plan(planner, result, pr2)


# -- the checker can fail ----------------------------------------------------------------------------


def test_the_checker_sees_a_base_in_the_table_and_an_arm_in_it(tmp_path, maps_dir, pr2):
    from placement.evaluation.generate import generate_scene

    doc = generate_scene(21, 1, objects=1, maps=str(maps_dir))
    doc["planner"] = {"threshold": 0.01, "yaw_steps": 40}
    planner = Planner(write(tmp_path, doc, "one"), "sequential")  # a placement beside pick_table_2
    step = planner.plan().to_json()["steps"][0]
    table = next(o for o in planner.scene.obstacles if o.name == "pick_table_2")
    check = IndependentCheck(pr2, planner.scene)
    toward = np.asarray(table.shape.center[:2]) - step["base"][:2]
    moved = dict(step, base=[*(np.asarray(step["base"][:2]) + 0.25 * toward / np.linalg.norm(toward)), step["base"][2]])
    c = check.check_step(moved, [], step["target"])
    assert c.footprint_m <= 0 and any("pick_table" in h for h in c.scene_hits) and not c.free


@pytest.mark.slow
def test_the_checker_agrees_with_the_planners_check_on_random_arms(tmp_path, maps_dir, pr2):
    """Two implementations of the same rules (padding 0): the same verdict on random configurations
    of the right arm next to a table, including self-collisions."""
    from placement.evaluation.generate import generate_scene

    doc = generate_scene(22, 0, objects=2, maps=str(maps_dir))
    scene = Planner(write(tmp_path, doc, "two"), collisions=False).scene
    ours, theirs = IndependentCheck(pr2, scene), SceneCollision(pr2, scene, padding=0.0)
    arm = pr2.arm("right")
    rng = np.random.default_rng(5)
    table = next(o for o in scene.obstacles if o.name == "pick_table_2").shape
    base = (float(table.center[0]), float(table.center[1] - table.size[1] / 2 - 0.45), math.pi / 2)
    kinds = set()
    for _ in range(60):
        q = arm.lower + (arm.upper - arm.lower) * rng.random(arm.dof)
        step = {"step": 0, "arm": "right", "base": list(base), "poses": [{"joints": dict(zip(arm.joints, q))}]}
        c = ours.check_step(step, [], None)
        r = theirs.check(arm="right", qs=q[None], base=base)
        assert (not c.scene_hits and not c.self_hits) == r.free, (q, c.scene_hits, c.self_hits, r.culprit)
        if r.free and r.clearance_m < CAP:
            assert r.clearance_m == pytest.approx(c.clearance(CAP), abs=1e-3)
        kinds |= {"scene"} if c.scene_hits else set()
        kinds |= {"self"} if c.self_hits else set()
        kinds |= {"free"} if c.free else set()
    assert kinds == {"scene", "self", "free"}
