"""End to end: scene -> placements whose IK solutions put the TCP where the step needs it."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml
from support.planning import SCENE, write_scene

from placement.planning.planner import Planner


def _planar(x, y, yaw):
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


def _check_fk(result, pr2, planner):
    """Independent FK (pinocchio, not the planner's kernels) of every step, limits, base clearance."""
    world = planner.world
    for s in result.steps:
        arm = pr2.arm(s.arm)
        q = np.array([s.joints[j] for j in arm.joints])
        assert np.all(q >= arm.lower - 1e-9) and np.all(q <= arm.upper + 1e-9)
        assert s.joints["torso_lift_joint"] == pr2.fixed_joints["torso_lift_joint"]
        T = _planar(*s.base) @ pr2.tcp_pose(s.arm, q)
        target = np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        assert np.degrees(np.arccos(np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1))) < 3
        assert world.pose_clear(*s.base)  # the footprint at the reported yaw (a circle: distance >= radius)
    assert result.verify(pr2) == []


def test_plan_is_verified_by_independent_fk(tmp_path, maps_dir, pr2):
    planner = Planner(write_scene(tmp_path, maps_dir))
    result = planner.plan()
    assert result.status == "ok"
    assert [(s.action, s.target) for s in result.steps] == [
        ("pick", "cup"),
        ("place", "spot"),
        ("pick", "box"),
        ("place", "spot"),
    ]
    _check_fk(result, pr2, planner)
    doc = result.to_json()
    for s in doc["steps"]:
        assert s["cost"]["total"] == pytest.approx(
            s["cost"]["navigation"] + s["cost"]["manipulation"] + s["cost"]["heuristic"]
        )


def test_verify_catches_a_wrong_plan(tmp_path, maps_dir, pr2):
    """PlanResult.verify is an oracle that can fail: a joint moved by 0.2 rad is caught."""
    result = Planner(write_scene(tmp_path, maps_dir)).plan()
    s = result.steps[0]
    name = pr2.arm(s.arm).joints[1]
    s.joints[name] += 0.2
    assert any("TCP off" in p for p in result.verify(pr2))


def test_methods_share_code_and_weights(tmp_path, maps_dir):
    path = write_scene(tmp_path, maps_dir)
    irm = Planner(path, "irm").plan()
    assert irm.status == "ok"
    for s in irm.steps:
        assert s.cost.navigation == 0 and s.cost.heuristic == 0 and s.cost.manipulation > 0
    single = Planner(path, "single-step").plan()
    assert all(s.cost.heuristic == 0 and s.cost.navigation > 0 for s in single.steps)
    sequential = Planner(path, "sequential").plan()
    assert all(s.cost.heuristic > 0 for s in sequential.steps[:-1]) and sequential.steps[-1].cost.heuristic == 0


def _run(*args):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "placement.cli.main", *args], capture_output=True, text=True, env=env)


@pytest.mark.slow
def test_cli_json_and_plots(tmp_path, maps_dir):
    path = write_scene(tmp_path, maps_dir)
    p = _run("query", str(path), "--json", "-q", "--plot", str(tmp_path / "plots"))
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["robot"]["name"] == "pr2" and set(doc["robot"]["arms"]) == {"right", "left"}
    step = doc["steps"][0]
    for key in (
        "step",
        "action",
        "target",
        "arm",
        "grasp",
        "base",
        "tcp",
        "joints",
        "manipulability",
        "cost",
        "travel_time_s",
        "timings_ms",
    ):
        assert key in step
    assert len(step["tcp"][0]) == 7 and len(step["tcp"]) == 2
    assert len(list((tmp_path / "plots").glob("*.png"))) == 4


@pytest.mark.slow
def test_unreachable_object_is_reported_not_placed(tmp_path, maps_dir):
    scene = json.loads(json.dumps(SCENE))["objects"]
    scene[0]["position"] = [3.0, 2.55, 2.6]  # far above any reach
    p = _run("query", str(write_scene(tmp_path, maps_dir, objects=scene)), "--json", "-q")
    assert p.returncode == 3
    doc = json.loads(p.stdout)
    assert doc["status"] == "infeasible"
    assert doc["steps"][0]["status"] == "infeasible"
    assert "outside the height range of the maps" in doc["steps"][0]["reason"]
    assert "infeasible" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow
def test_start_inside_obstacle_is_one_line(tmp_path, maps_dir):
    robot = {"preset": "pr2", "start": [3.0, 2.5, 0.0]}
    p = _run("query", str(write_scene(tmp_path, maps_dir, robot=robot)))
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert "inside an obstacle" in p.stderr


@pytest.mark.parametrize("obstacles", [False, True])
def test_generated_scenes_plan_and_verify(tmp_path, maps_dir, pr2, obstacles):
    """Generated table-clearing scenes (2 objects): every step verified by independent FK."""
    from placement.evaluation.generate import generate_scene

    doc = generate_scene(11, 0, objects=2, obstacles=obstacles, maps=str(maps_dir))
    doc["planner"] = {"threshold": 0.01, "yaw_steps": 40}
    path = tmp_path / "gen.yaml"
    path.write_text(yaml.safe_dump(doc))
    planner = Planner(path)
    result = planner.plan()
    assert result.status == "ok", result.steps[-1]
    _check_fk(result, pr2, planner)


def test_optimal_plans_verified_steps(tmp_path, maps_dir, pr2):
    """The DP yardstick plans the whole task; every step is verified by independent FK."""
    planner = Planner(write_scene(tmp_path, maps_dir), "optimal")
    result = planner.plan()
    assert result.status == "ok" and result.method == "optimal"
    assert len(result.steps) == 4
    _check_fk(result, pr2, planner)
    assert all(s.cost.heuristic == 0 for s in result.steps)


def test_optimal_names_the_step_that_fails(tmp_path, maps_dir):
    objects = json.loads(json.dumps(SCENE))["objects"]
    objects[1]["position"] = [2.8, 2.4, 2.6]  # the second pick (step 2) is out of reach
    result = Planner(write_scene(tmp_path, maps_dir, objects=objects), "optimal").plan()
    assert result.status == "infeasible"
    assert (result.failed_step.step, result.failed_step.target) == (2, "box")


@pytest.mark.slow
def test_optimal_writes_plots(tmp_path, maps_dir):
    path = write_scene(tmp_path, maps_dir)
    p = _run("query", str(path), "--method", "optimal", "-q", "--plot", str(tmp_path / "plots"))
    assert p.returncode == 0, p.stderr
    assert len(list((tmp_path / "plots").glob("*.png"))) == 4
