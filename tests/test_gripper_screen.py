"""The gripper alone rules out candidates before any map (placement.planning.problems.screening).

The screen must never rule out what verification could accept: a gripper it finds in the scene at a
TCP pose within the IK tolerances of an arm configuration's must collide in the full check of that
configuration, at any base. Checked on random configurations around a table, a crate and a pillar.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from support.collision import scene_doc
from support.planning import SCENE

from placement.collision import SceneCollision
from placement.collision.bounds import base_matrix
from placement.planning import Planner
from placement.planning.problems.screening import screen_slack
from placement.planning.settings import PlannerConfig
from placement.scene import load_scene


def turned(rng: np.random.Generator, angle: float) -> np.ndarray:
    """A rotation matrix by ``angle`` [rad] about a random axis."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


@pytest.mark.parametrize("padding", [0.0, 0.03])
def test_a_gripper_the_screen_rules_out_collides_in_every_configuration_within_the_ik_tolerances(
    tmp_path, pr2, padding
):
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_doc("pr2", 0.6)))
    checker = SceneCollision(pr2, load_scene(path), padding=padding)
    config = PlannerConfig()
    rng = np.random.default_rng(11)
    ruled_out = kept = 0
    for k in range(400):
        arm = sorted(pr2.arms)[k % 2]
        a = pr2.arm(arm)
        q = np.clip(a.home + rng.normal(0.0, 0.8, size=a.dof), a.lower, a.upper)
        # bases before the table (its front edge at x = 0.3): many grippers reach into it or the crate
        base = (float(rng.uniform(-0.6, 0.0)), float(rng.uniform(-0.8, 0.8)), float(rng.uniform(-0.6, 0.6)))
        tcp = base_matrix(*base) @ pr2.tcp_pose(arm, q)
        # what an IK solution within the tolerances may be off by, at most
        near = np.eye(4)
        near[:3, :3] = turned(rng, rng.uniform(0.0, config.ik_rot_tol_rad))
        step = rng.normal(size=3)
        near[:3, 3] = step / np.linalg.norm(step) * rng.uniform(0.0, config.ik_pos_tol_m)
        target = tcp @ near
        hit = checker.gripper_collisions(arm, [target[None]], screen_slack(checker, arm, config))[0]
        if hit is None:
            kept += 1
            continue
        ruled_out += 1
        full = checker.check(arm, q[None], base)
        assert not full.free, (k, arm, hit.culprit, full)
        assert hit.culprit is not None and hit.culprit.split(" vs ")[0] in {
            checker.geometry.names[int(g)] for g in checker.geometry.arm_shapes(arm).gripper
        }
    assert ruled_out >= 20 and kept >= 20, (ruled_out, kept)  # both kinds were compared


def test_the_slack_is_the_tolerances_times_the_grippers_reach(tmp_path, pr2):
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_doc("pr2", 0.6)))
    checker = SceneCollision(pr2, load_scene(path))
    reach = checker.gripper_reach("right")
    # the PR2's fingertips are about 0.16 m from its TCP (between the finger pads, 18 cm from the wrist)
    assert 0.1 < reach < 0.25
    config = PlannerConfig(ik_pos_tol_m=0.002, ik_rot_tol_rad=0.02)
    assert screen_slack(checker, "right", config) == pytest.approx(0.002 + 0.02 * reach)


#: A cup on the table grasped from above (free) and from below, through the table top.
TOP = {"name": "top", "poses": [[0, 0, 0.1, 1, 0, 0, 0], [0, 0, 0, 1, 0, 0, 0]]}
BELOW = {"name": "below", "poses": [[0, 0, -0.1, 0, 0, 0, 1], [0, 0, 0, 0, 0, 0, 1]]}


def grasp_scene(tmp_path, maps_dir, grasps):
    doc = yaml.safe_load(yaml.safe_dump(SCENE))
    doc.update(version=2, maps=str(maps_dir), task=[{"pick": "cup", "place": "spot"}])
    doc["objects"][0]["grasps"] = grasps
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_grasp_through_the_table_top_gets_no_map_and_says_why(tmp_path, maps_dir):
    planner = Planner(grasp_scene(tmp_path, maps_dir, [TOP, BELOW]), "sequential", maps_dir)
    opts = planner.problems.options(0)
    by_grasp = {(o.arm, o.candidate.grasp): o for o in opts}
    for arm in planner.robot.arms:
        top, below = by_grasp[(arm, "top")], by_grasp[(arm, "below")]
        assert top.blocked is None and top.value.size and top.value.max() > 0
        assert below.blocked is not None and below.value.size == 0
        assert " vs table at the pre-grasp pose" in below.blocked
        assert below.blocked.startswith(f"{arm[0]}_gripper")
    # without a collision check nothing is ruled out
    unchecked = Planner(grasp_scene(tmp_path, maps_dir, [TOP, BELOW]), "sequential", maps_dir, collisions=False)
    assert all(o.blocked is None for o in unchecked.problems.options(0))


@pytest.mark.parametrize("method", ["global", "sequential", "single-step", "fixed"])
def test_a_step_whose_every_grasp_goes_through_the_table_says_so(tmp_path, maps_dir, method):
    result = Planner(grasp_scene(tmp_path, maps_dir, [BELOW]), method, maps_dir).plan()
    failed = result.failed_step
    assert failed is not None and failed.step == 0
    assert failed.reason.startswith("the gripper collides at every candidate (2) wherever the base stands, mostly ")
    assert "vs table at the pre-grasp pose" in failed.reason
    assert failed.diagnosis["gripper_blocked"] == 2


def test_a_moved_object_that_blocked_a_grasp_frees_it_again(tmp_path, maps_dir):
    # the cup's side grasp from -x passes through the box standing 8 cm beside it
    side = {"name": "side", "poses": [[-0.1, 0, 0, 0, 0.7071068, 0, 0.7071068], [0, 0, 0, 0, 0.7071068, 0, 0.7071068]]}
    path = grasp_scene(tmp_path, maps_dir, [side])
    doc = yaml.safe_load(path.read_text())
    doc["objects"][1].update(position=[2.91, 2.55, 0.8], yaw=0.0)
    path.write_text(yaml.safe_dump(doc))
    planner = Planner(path, "sequential", maps_dir)
    assert all(o.blocked is not None and " vs box " in o.blocked for o in planner.problems.options(0))
    planner.update({"objects": [{"name": "box", "position": [2.5, 2.2, 0.8]}]})
    assert all(o.blocked is None for o in planner.problems.options(0))


def test_a_twin_hands_screen_is_its_own_with_its_own_links_named(tmp_path, pr2):
    """The PR2's hands are one gripper twice: the right hand's screen, renamed, is what the left hand's
    own would be, on random TCP poses around the table (many in it), with and without the slack."""
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_doc("pr2", 0.6)))
    checker = SceneCollision(pr2, load_scene(path), padding=0.02)
    assert checker.gripper_twin("left") == "right" and checker.gripper_twin("right") is None
    rng = np.random.default_rng(5)
    poses = []
    for _ in range(300):
        T = np.eye(4)
        T[:3, :3] = turned(rng, rng.uniform(0.0, math.pi))
        T[:3, 3] = rng.uniform([0.2, -0.6, 0.55], [1.0, 0.6, 0.95])
        back = np.eye(4)
        back[2, 3] = -0.1  # a pre-grasp 10 cm back along the approach
        poses.append(np.stack([T @ back, T]))
    for slack in (0.0, 0.01):
        right = checker.gripper_collisions("right", poses, slack)
        left = checker.gripper_collisions("left", poses, slack)
        assert checker.twin_results(right, "right", "left") == left
        assert sum(h is not None for h in left) >= 30 and sum(h is None for h in left) >= 30
        assert all(h.culprit.startswith("l_gripper") for h in left if h is not None)
    # a hand whose shapes sit a micrometre elsewhere is no twin: it gets its own screen
    ids, rel = checker._gripper_frames("left")
    moved = rel.copy()
    moved[0, 0, 3] += 1e-6
    other = SceneCollision(pr2, load_scene(path), padding=0.02)
    other._grippers["left"] = (ids, moved)
    assert other.gripper_twin("left") is None
