"""Building scenes with a published grasp set: DexYCB's Panda grasps of the YCB objects
(examples/buildings/ycb_grasps, written into examples/buildings/*/tidy_up_ycb.yaml by
tools/ycb_grasp_scenes.py), planned by the default method and checked independently."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from oracle_collision import IndependentCheck
from support.budgets import unbudgeted
from support.map_check import footprint_on_map

from placement.planning import Planner
from placement.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import ycb_grasp_scenes as ycb  # noqa: E402

SCENES = sorted((ROOT / "examples" / "buildings").glob("*/tidy_up_ycb.yaml"))


def test_the_scenes_hold_the_set_as_the_tool_writes_it():
    grasp_set = json.loads(ycb.GRASP_FILE.read_text())
    assert len(SCENES) == 3
    for path in SCENES:
        assert path.read_text() == ycb.scene_text(path.with_name("tidy_up.yaml"), grasp_set), path


def test_a_panda_hand_pose_becomes_the_tcp_between_its_fingertips():
    """The Panda hand at the model's origin, approaching along z, fingers moving along x: the TCP is
    0.1034 m ahead with its y across the fingers (the hand's x) and z along the approach; the
    pre-pose 0.1 m behind it. A model turned by -90 deg about z into the object (the cracker box)
    turns both."""
    pre, grasp = ycb.tcp_poses(np.eye(4), 0.0)
    want = np.array([[0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.1034], [0.0, 0.0, 0.0, 1.0]])
    np.testing.assert_allclose(grasp, want, atol=1e-12)
    np.testing.assert_allclose(pre[:3, 3], [0.0, 0.0, 0.0034], atol=1e-12)
    np.testing.assert_allclose(pre[:3, :3], want[:3, :3], atol=1e-12)
    hand = np.eye(4)
    hand[:3, 3] = [0.0, 0.05, 0.0]  # along the model's y: the cracker box's 0.16 m edge
    _, turned = ycb.tcp_poses(hand, -math.pi / 2)
    np.testing.assert_allclose(turned[:3, 3], [0.05, 0.0, 0.1034], atol=1e-12)  # the object's x
    np.testing.assert_allclose(turned[:3, 1], [0.0, 1.0, 0.0], atol=1e-12)  # closing across the 0.06 m edge


def test_a_grasp_outside_the_objects_box_is_refused():
    hand = np.eye(4)
    hand[:3, 3] = [0.0, 0.0, 0.2]  # the TCP 0.30 m above a 0.21 m box's centre
    with pytest.raises(ValueError, match="outside its box"):
        ycb.object_grasps("cracker_box", [0.16, 0.06, 0.21], [hand.tolist()])


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.parent.name)
def test_every_step_plans_with_a_published_grasp_and_holds(maps_dir, path):
    planner = Planner(unbudgeted(load_scene(path)), "global", maps_dir)
    result = planner.plan()
    assert result.ok, result.failed_step
    assert all(s.grasp.startswith("dexycb-") for s in result.steps)
    assert result.verify(planner.robot, scene=planner.scene) == []
    for step in result.steps:
        assert footprint_on_map(planner, step.base) == [], (step.step, step.base)
    checks = IndependentCheck(planner.robot, planner.scene).check_plan(result.to_json())
    assert all(c.free for c in checks), [(c.scene_hits, c.self_hits, c.object_hits) for c in checks]
