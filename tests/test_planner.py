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

import placement
from placement.planning.planner import Planner

SCENE = {
    "version": 1,
    "resolution": 0.05,
    "bounds": [0.0, 0.0, 6.0, 5.0],
    "robot": {"preset": "pr2", "start": [1.0, 4.0, 0.0]},
    "obstacles": [
        {"name": "table", "box": {"center": [3.0, 2.5, 0.375], "size": [0.8, 0.6, 0.75]}, "table": True},
        {"name": "shelf", "box": {"center": [1.0, 0.8, 0.375], "size": [0.6, 0.6, 0.75]}},
        {"name": "pillar", "cylinder": {"center": [4.5, 4.0, 1.0], "radius": 0.2, "height": 2.0}},
    ],
    "objects": [
        {"name": "cup", "position": [3.0, 2.55, 0.8], "yaw": 0.4, "size": [0.06, 0.06, 0.1]},
        {"name": "box", "position": [2.8, 2.4, 0.8], "yaw": 1.0, "size": [0.05, 0.12, 0.1]},
    ],
    "place_locations": [{"name": "spot", "position": [1.0, 0.8, 0.85]}],
    "task": [{"pick": "cup", "place": "spot"}, {"pick": "box", "place": "spot"}],
    "planner": {"threshold": 0.01, "yaw_steps": 40},
}


def write_scene(tmp_path, maps_dir, **changes):
    scene = json.loads(json.dumps(SCENE))
    scene["maps"] = str(maps_dir)
    for key, value in changes.items():
        scene[key] = value
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def _planar(x, y, yaw):
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


def test_plan_is_verified_by_independent_fk(tmp_path, maps_dir, pr2):
    planner = Planner(write_scene(tmp_path, maps_dir))
    result = planner.plan()
    assert result["status"] == "ok"
    assert [(s["action"], s["target"]) for s in result["steps"]] == [
        ("pick", "cup"), ("place", "spot"), ("pick", "box"), ("place", "spot")]
    world = planner.world
    for s in result["steps"]:
        arm = pr2.arm(s["arm"])
        q = np.array([s["joints"][j] for j in arm.joints])
        assert np.all(q >= arm.lower - 1e-9) and np.all(q <= arm.upper + 1e-9)
        assert s["joints"]["torso_lift_joint"] == pr2.fixed_joints["torso_lift_joint"]
        T = _planar(*s["base"]) @ pr2.tcp_pose(s["arm"], q)  # pinocchio FK, not the planner's
        target = placement.robots.pose_to_matrix(s["tcp"][-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        assert np.degrees(np.arccos(np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1))) < 3
        iy, ix = world.nav.cell(s["base"][0], s["base"][1])
        assert world.distance[iy, ix] >= pr2.footprint_radius
        assert s["cost"]["total"] == pytest.approx(
            s["cost"]["navigation"] + s["cost"]["manipulation"] + s["cost"]["heuristic"])
        assert s["travel_time_s"] >= 0


def test_methods_share_code_and_weights(tmp_path, maps_dir):
    path = write_scene(tmp_path, maps_dir)
    irm = Planner(path, "irm").plan()
    assert irm["status"] == "ok"
    for s in irm["steps"]:
        assert s["cost"]["navigation"] == 0 and s["cost"]["heuristic"] == 0
    single = Planner(path, "single-step").plan()
    assert all(s["cost"]["heuristic"] == 0 for s in single["steps"])


def _run(*args):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "placement.cli.main", *args], capture_output=True, text=True, env=env)


def test_cli_json_and_plots(tmp_path, maps_dir):
    path = write_scene(tmp_path, maps_dir)
    p = _run("query", str(path), "--json", "-q", "--plot", str(tmp_path / "plots"))
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["robot"]["name"] == "pr2" and set(doc["robot"]["arms"]) == {"right", "left"}
    step = doc["steps"][0]
    for key in ("step", "action", "target", "arm", "grasp", "base", "tcp", "joints", "manipulability", "cost",
                "travel_time_s", "timings_ms"):
        assert key in step
    assert len(step["tcp"][0]) == 7 and len(step["tcp"]) == 2
    assert len(list((tmp_path / "plots").glob("*.png"))) == 4


def test_unreachable_object_is_reported_not_placed(tmp_path, maps_dir):
    scene = json.loads(json.dumps(SCENE))["objects"]
    scene[0]["position"] = [3.0, 2.55, 2.6]  # far above any reach
    p = _run("query", str(write_scene(tmp_path, maps_dir, objects=scene)), "--json", "-q")
    assert p.returncode == 3
    doc = json.loads(p.stdout)
    assert doc["status"] == "infeasible"
    assert doc["steps"][0]["status"] == "infeasible" and doc["steps"][0]["reason"]
    assert "infeasible" in p.stderr and "Traceback" not in p.stderr


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
    assert result["status"] == "ok", result["steps"][-1]
    for s in result["steps"]:
        arm = pr2.arm(s["arm"])
        q = np.array([s["joints"][j] for j in arm.joints])
        T = _planar(*s["base"]) @ pr2.tcp_pose(s["arm"], q)
        assert np.linalg.norm(T[:3, 3] - np.array(s["tcp"][-1][:3])) < 0.01
        iy, ix = planner.world.nav.cell(s["base"][0], s["base"][1])
        assert planner.world.distance[iy, ix] >= pr2.footprint_radius


def test_optimal_plans_verified_steps(tmp_path, maps_dir, pr2):
    """The DP yardstick plans the whole task; every step is verified by independent FK."""
    planner = Planner(write_scene(tmp_path, maps_dir), "optimal")
    result = planner.plan()
    assert result["status"] == "ok" and result["method"] == "optimal"
    assert len(result["steps"]) == 4
    for s in result["steps"]:
        arm = pr2.arm(s["arm"])
        q = np.array([s["joints"][j] for j in arm.joints])
        T = _planar(*s["base"]) @ pr2.tcp_pose(s["arm"], q)
        assert np.linalg.norm(T[:3, 3] - np.array(s["tcp"][-1][:3])) < 0.01
        assert s["cost"]["heuristic"] == 0


def test_updates_redo_only_what_changed(tmp_path, maps_dir, pr2):
    planner = Planner(write_scene(tmp_path, maps_dir))
    first = planner.plan()
    assert first["status"] == "ok"
    cached_place = planner._options[1]  # the place step's IRMs do not depend on the cup
    info = planner.update({"objects": [{"name": "cup", "position": [3.2, 2.5, 0.8]}]})
    assert info["updated"] == ["cup"]
    assert 0 not in planner._options and planner._options[1] is cached_place
    moved = planner.plan()
    assert moved["status"] == "ok"
    assert moved["steps"][0]["tcp"][-1][:2] == pytest.approx([3.2, 2.5])
    # a crate on the chosen placement: the new plan avoids it
    x, y, _ = moved["steps"][0]["base"]
    planner.update({"obstacles": {"add": [{"name": "crate", "box": {"center": [x, y, 0.3], "size": [0.4, 0.4, 0.6]}}]}})
    again = planner.plan()
    assert again["status"] == "ok"
    assert math.hypot(again["steps"][0]["base"][0] - x, again["steps"][0]["base"][1] - y) > pr2.footprint_radius
    with pytest.raises(placement.PlacementError, match="colour"):
        planner.update({"colour": 1})
    with pytest.raises(placement.PlacementError, match="unknown object 'mug'"):
        planner.update({"objects": [{"name": "mug", "yaw": 1.0}]})


def test_stream_mode(tmp_path, maps_dir):
    env = dict(os.environ)
    lines = '{"objects": [{"name": "cup", "yaw": 1.0}]}\nnot json\n'
    p = subprocess.run([sys.executable, "-m", "placement.cli.main", "query", str(write_scene(tmp_path, maps_dir)),
                        "--stream", "-q"], input=lines, capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr
    out = [json.loads(x) for x in p.stdout.splitlines()]
    assert len(out) == 3 and out[0]["status"] == "ok" and out[1]["update"]["updated"] == ["cup"]
    assert "error" in out[2] and "Traceback" not in p.stderr
