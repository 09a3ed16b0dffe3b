"""A torso of several joints held at postures (one map build per posture): a robot whose arm rides on a
hip and a knee pitch (tests/support/knee_torso.py) built at the upright posture and at a crouch where the
knee undoes the hip's lean. Each posture's map is the build of the robot held there, bit for bit; a cup in
the middle of a deep table is picked at the crouch, checked by pinocchio FK with both joints at the
posture; the plan lists both joints; the torso time is the slowest joint's."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from support.deep_table import deep_table_scene
from support.fk import world_tcp
from support.knee_torso import CROUCH, HIP, KNEE, UPRIGHT, write_knee_torso

import placement
from placement.maps.buildspec import parse_torso
from placement.maps.torso_builds import build_torso_maps
from placement.planning.planner import Planner
from placement.planning.task_time import task_time
from placement.planning.torso import held_setting, robot_at, torso_seconds

SPEC = {"joints": [HIP, KNEE], "postures": [list(UPRIGHT), list(CROUCH)]}
OPTIONS = {"samples": 200_000, "seed": 2, "resolution": 0.1, "bins": (8, 5, 8), "progress": False}
CROUCHED = "arm@posture=1"


@pytest.fixture(scope="module")
def knee(tmp_path_factory):
    """(robot, preset path, built maps, stored maps path): the arm at both postures, 0.1 m cells."""
    folder = tmp_path_factory.mktemp("knee_torso")
    preset = write_knee_torso(folder / "robot")
    robot = placement.load_robot(preset)
    built = build_torso_maps(robot, "arm", torso=parse_torso(SPEC, "torso"), **OPTIONS)
    return robot, preset, built, placement.save_maps(folder / "maps", robot, built)


@pytest.mark.slow
def test_each_posture_is_the_build_of_the_robot_held_there(knee):
    robot, _, built, _ = knee
    assert sorted(built) == ["arm", CROUCHED]
    crouched = robot.with_fixed({HIP: CROUCH[0], KNEE: CROUCH[1]})
    direct = placement.build_map(crouched, "arm", **OPTIONS)
    m = built[CROUCHED]
    assert np.array_equal(m.values, direct.values) and m.witness is not None
    assert np.array_equal(m.witness, direct.witness)
    assert m.meta["grid"] == direct.meta["grid"]
    assert m.meta["fixed_joints"] == {HIP: 0.9, KNEE: -0.9} and "torso" not in m.meta
    assert m.meta["setting"] == {"joint": HIP, "value": 1.0, "unit": "index", "posture": {HIP: 0.9, KNEE: -0.9}}
    record = built["arm"].meta["torso"]
    assert record["kind"] == "posture" and record["unit"] == "index" and record["shift"] is None
    assert record["joints"] == [HIP, KNEE] and record["postures"] == [[0.0, 0.0], [0.9, -0.9]]
    assert record["values"] == [0.0, 1.0] and record["reference_setting"] == 0 and record["reference"] == 0.0
    assert record["arrays"] == ["arm", CROUCHED] and record["velocities"] == pytest.approx([0.4, 0.7])
    # the crouch moves the chest forward: the reach moves with it (another grid)
    assert built["arm"].meta["grid"] != m.meta["grid"]


def test_the_stored_postures_open_at_their_robots(knee):
    robot, _, _, maps = knee
    rmap = placement.open_map(maps, "arm", robot)
    t = rmap.torso
    assert t is not None and t.kind == "posture" and t.label == f"{HIP}+{KNEE}"
    assert t.held(1.0) == {HIP: 0.9, KNEE: -0.9} and rmap.torso_value == 0.0
    view = rmap.at_torso(1.0)
    assert view.array == CROUCHED and view.robot is not None
    assert view.robot.fixed_joints == {HIP: 0.9, KNEE: -0.9}
    assert rmap.at_torso(1.0) is view and view.at_torso(0.0) is rmap
    with pytest.raises(placement.MapError, match=r"no map for posture 2 of hip_pitch\+knee_pitch.*postures 0, 1"):
        rmap.at_torso(2.0)


def test_the_torso_time_is_the_slowest_joints(tmp_path, knee):
    robot, preset, _, maps = knee
    ctx = Planner(deep_table_scene(tmp_path, preset, maps), "sequential").context
    # hip 0.9 rad at 0.4 rad/s = 2.25 s; knee 0.9 rad at 0.7 rad/s = 1.29 s: they move together
    assert torso_seconds(ctx, 0.0, 1.0) == pytest.approx(2.25, abs=1e-12)
    assert torso_seconds(ctx, 1.0, 0.0) == pytest.approx(2.25, abs=1e-12)
    assert torso_seconds(ctx, 1.0, 1.0) == 0.0
    assert robot_at(ctx, 1.0).fixed_joints == {HIP: 0.9, KNEE: -0.9}
    assert robot_at(ctx, 0.0).fixed_joints == {HIP: 0.0, KNEE: 0.0}
    assert held_setting(ctx, {HIP: 0.9, KNEE: -0.9, "joint_1": 0.1}, 0.0) == 1.0
    assert held_setting(ctx, {HIP: 0.9, KNEE: 0.0}, 0.0) == 0.0  # no posture: the one before


@pytest.mark.parametrize("method", ["global", "sequential"])
def test_a_far_cup_is_picked_crouched(tmp_path, knee, method):
    robot, preset, _, maps = knee
    planner = Planner(deep_table_scene(tmp_path, preset, maps), method)
    problems = planner.context.problems
    assert {o.torso for o in problems.options(0)} == {0.0, 1.0}
    # upright, no placement keeps the threshold for the pick: only the crouch reaches the cup
    upright = [o for o in problems.options(0) if o.torso == 0.0]
    assert max(float(o.value.max(initial=0.0)) for o in upright) < planner.context.threshold("arm")
    result = planner.plan()
    assert all(s.ok for s in result.steps), [s.reason for s in result.steps]
    pick = result.steps[0]
    assert (pick.joints[HIP], pick.joints[KNEE]) == CROUCH
    assert result.verify(robot) == []
    # the task time's torso term from the plan's joints: upright -> crouch is the hip's 0.9 / 0.4 s
    timing = task_time(robot, result, (1.0, 4.0, 0.0))
    assert timing is not None and timing["steps"][0]["torso_s"] == pytest.approx(2.25, abs=1e-12)
    plan = json.loads(json.dumps(result.to_json()))
    for s, doc in zip(result.steps, plan["steps"]):  # the plan lists every torso joint, not the index
        assert doc["joints"][HIP] == s.joints[HIP] and doc["joints"][KNEE] == s.joints[KNEE]
        conf = doc["configuration"]  # the whole robot: both torso joints among its fixed joints
        assert {HIP, KNEE} <= set(conf["fixed_joints"])
        assert (conf["joints"][HIP], conf["joints"][KNEE]) == (s.joints[HIP], s.joints[KNEE])
    for s in result.steps:  # pinocchio FK of the robot with both torso joints at the step's posture
        arm_q = {j: s.joints[j] for j in robot.arm(s.arm).joints}
        T = world_tcp(robot, s.arm, {**arm_q, HIP: s.joints[HIP], KNEE: s.joints[KNEE]}, s.base)
        target = np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        cos = np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1)
        assert math.degrees(math.acos(cos)) < 3
        if (s.joints[HIP], s.joints[KNEE]) != UPRIGHT:  # the posture matters: upright misses the target
            up = world_tcp(robot, s.arm, {**arm_q, HIP: 0.0, KNEE: 0.0}, s.base)
            assert np.linalg.norm(up[:3, 3] - target[:3, 3]) > 0.1
