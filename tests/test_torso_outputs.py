"""The torso as a placement variable, downstream of a planned step: a step may hold the preset's
fixed joints (the PR2's torso lift, 0 .. 0.31 m at 0.013 m/s) at its own values, and everything
that reads a step result honours them: ``PlanResult.verify`` (FK of the arm and FK of the whole
configuration), the configuration in the JSON, the task-time model and the viewer.

The references are independent of the code under test: the TCP poses come from pinocchio FK of a
configuration set joint by joint on the URDF model (not from ``Robot.with_fixed``), the torso's
limits and velocity from the URDF's XML."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from support.fk import model_fk
from support.robots import random_configs
from support.steps import placed_step

from placement.planning import PlacedStep, PlanResult
from placement.planning.results import Cost, configuration_problems
from placement.planning.task_time import task_time
from placement.planning.verification.configuration import resting
from placement.viewer.plan_file import PlanFileError, parse_plan
from placement.viewer.robot_view import step_config

TORSO = "torso_lift_joint"
RAISED = 0.25  # [m]; the PR2 preset holds 0.15
BASE = (1.0, 2.0, 0.3)  # x [m], y [m], yaw [rad]


def urdf_limit(robot, joint: str) -> dict[str, float]:
    """The ``<limit>`` attributes (lower, upper [m], velocity [m/s]) of ``joint`` in the URDF's XML."""
    root = ET.parse(robot.urdf_path).getroot()
    el = next(j for j in root.iter("joint") if j.get("name") == joint).find("limit")
    return {k: float(el.get(k)) for k in ("lower", "upper", "velocity")}


def base_matrix(x: float, y: float, yaw: float) -> np.ndarray:
    B = np.eye(4)
    B[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, yaw)
    B[:2, 3] = x, y
    return B


def fk_world_tcp(robot, arm: str, joints: dict[str, float], base) -> np.ndarray:
    """(4, 4) world TCP by pinocchio FK of the model with every joint of ``joints`` set by name (the
    rest neutral) and the base frame placed at ``base``."""
    model = robot.model
    data = model_fk(robot, joints)
    a = robot.arm(arm)
    root = base_matrix(*base) @ np.linalg.inv(data.oMf[robot.base_frame_id].homogeneous)
    return root @ data.oMf[model.getFrameId(a.tip_frame)].homogeneous @ a.tcp_offset


def raised_step(robot, seed: int = 3, torso: float = RAISED) -> PlacedStep:
    """A planned right-arm step of two TCP poses reached by random arm configurations with the torso
    at ``torso``, the other arm tucked (its idle) as the planner's configuration says."""
    arm = robot.arm("right")
    qs = random_configs(arm, 2, np.random.default_rng(seed))
    r = resting(robot, "right")
    fixed = {TORSO: torso}
    tcp = np.stack([fk_world_tcp(robot, "right", r.idle["left"] | dict(zip(arm.joints, q)) | fixed, BASE) for q in qs])
    return PlacedStep(
        0,
        "pick",
        "cup",
        arm="right",
        grasp="top",
        base=BASE,
        tcp=tcp,
        q=qs[-1],
        qs=qs,
        joints=dict(zip(arm.joints, map(float, qs[-1]))) | fixed,
        manipulability=0.05,
        cost=Cost(1.0, 0.5, 0.1),
        travel_time_s=2.0,
        resting=r,
    )


def plan_of(*steps: PlacedStep) -> PlanResult:
    return PlanResult("s", "sequential", {"name": "pr2"}, list(steps))


@pytest.fixture(params=["configuration", "arm FK"])
def path(request):
    """verify's two FK paths: of the whole configuration (a step with ``resting``), of the arm alone."""
    return request.param


def variant(s: PlacedStep, path: str, **joints: float) -> PlacedStep:
    """``s`` with its fixed joints changed, checked along ``path``."""
    return replace(s, joints=s.joints | joints, resting=s.resting if path == "configuration" else None)


def test_the_references_see_the_torso(pr2):
    """The independent FK moves the TCP straight up by the torso's change (a prismatic joint along z)."""
    s = raised_step(pr2)
    lower = raised_step(pr2, torso=0.15)
    np.testing.assert_allclose(s.tcp[:, :3, 3] - lower.tcp[:, :3, 3], [[0, 0, 0.1]] * 2, rtol=0, atol=1e-9)
    assert urdf_limit(pr2, TORSO) == pytest.approx({"lower": 0.0, "upper": 0.31, "velocity": 0.013})


def test_verify_passes_at_the_raised_torso(pr2, path):
    assert plan_of(variant(raised_step(pr2), path)).verify(pr2) == []


def test_verify_fails_when_the_step_claims_the_preset_torso(pr2, path):
    problems = plan_of(variant(raised_step(pr2), path, torso_lift_joint=0.15)).verify(pr2)
    assert problems == [
        "step 0 (pick cup): pose 0: TCP off by 10.0 cm and 0.0 deg",
        "step 0 (pick cup): pose 1: TCP off by 10.0 cm and 0.0 deg",
    ]


def test_a_torso_outside_its_limits_is_reported(pr2, path):
    problems = plan_of(variant(raised_step(pr2), path, torso_lift_joint=0.5)).verify(pr2)
    where = "configuration: " if path == "configuration" else ""
    assert f"step 0 (pick cup): {where}fixed joint torso_lift_joint is 0.5, outside its URDF limits [0, 0.31]" in (
        problems
    )
    # at the upper limit it is no problem (only the TCP moved)
    top = plan_of(variant(raised_step(pr2), path, torso_lift_joint=0.31)).verify(pr2)
    assert top and all("TCP off by 6.0 cm" in p for p in top)


def test_a_missing_torso_is_reported(pr2, path):
    s = variant(raised_step(pr2, torso=0.15), path)
    s.joints.pop(TORSO)
    problems = plan_of(s).verify(pr2)
    assert problems[0] == "step 0 (pick cup): fixed joint torso_lift_joint is missing"
    # the configuration then names no fixed joint either; the TCP is no problem (the preset's torso)
    assert problems[1:] == (
        ["step 0 (pick cup): configuration: fixed joints [], not ['torso_lift_joint']"]
        if path == "configuration"
        else []
    )


def test_configuration_problems_take_any_torso_within_limits(pr2):
    conf = raised_step(pr2).configuration()
    assert configuration_problems(pr2, conf, "here") == []
    conf["joints"][TORSO] = -0.01
    assert configuration_problems(pr2, conf, "here") == [
        "here: configuration: fixed joint torso_lift_joint is -0.01, outside its URDF limits [0, 0.31]"
    ]


def test_the_configuration_json_carries_the_steps_torso(pr2):
    doc = json.loads(json.dumps(plan_of(raised_step(pr2)).to_json(), allow_nan=False))
    s = doc["steps"][0]
    assert s["joints"][TORSO] == RAISED and s["configuration"]["joints"][TORSO] == RAISED
    assert s["configuration"]["fixed_joints"] == [TORSO]
    # and the configuration's FK (every joint by name) puts the TCP on the last pose
    conf = s["configuration"]
    T = fk_world_tcp(pr2, "right", conf["joints"], (conf["base"]["x"], conf["base"]["y"], conf["base"]["yaw"]))
    np.testing.assert_allclose(T, raised_step(pr2).tcp[-1], rtol=0, atol=2e-6)  # base rounded to 1e-6


def test_task_time_adds_the_torso_in_parallel(pr2):
    """Two steps in place, the arm at home: the torso goes 0.15 (the preset's, the robot's start)
    -> 0.0 -> 0.26 m at 0.013 m/s, so 11.54 s then 20 s, and the step lasts as long as the torso."""
    home = pr2.arm("right").home
    joints = dict(zip(pr2.arm("right").joints, map(float, home)))

    def still(i: int, torso: float) -> PlacedStep:
        return placed_step(i, "pick", "x", arm="right", joints=joints | {TORSO: torso})

    t = task_time(pr2, plan_of(still(0, 0.0), still(1, 0.26)), (0.0, 0.0, 0.0))
    v = urdf_limit(pr2, TORSO)["velocity"]
    assert t["steps"][0] == pytest.approx({"base_s": 0.0, "arm_s": 0.0, "torso_s": 0.15 / v, "step_s": 0.15 / v})
    assert t["steps"][1]["torso_s"] == pytest.approx(20.0, abs=1e-9) and t["steps"][1]["step_s"] >= 20.0
    assert t["total_s"] == pytest.approx(0.15 / 0.013 + 20.0)
    # a longer base move hides the torso: parallel, not added
    far = replace(still(1, 0.26), travel_time_s=30.0)
    t = task_time(pr2, plan_of(still(0, 0.0), far), (0.0, 0.0, 0.0))
    assert t["steps"][1] == pytest.approx({"base_s": 30.0, "arm_s": 0.0, "torso_s": 20.0, "step_s": 30.0})
    # a step at the preset's torso from the start costs no torso time
    assert task_time(pr2, plan_of(still(0, 0.15)), (0.0, 0.0, 0.0))["steps"][0]["torso_s"] == 0.0


def test_the_viewer_configuration_puts_the_tcp_where_fk_says(pr2):
    s = raised_step(pr2)
    for step in (s, replace(s, resting=None)):  # a step of the planner, one without its resting
        q = step_config(pr2, step)
        data = pr2.model.createData()
        pin.framesForwardKinematics(pr2.model, data, q)
        a = pr2.arm("right")
        root = base_matrix(*BASE) @ np.linalg.inv(data.oMf[pr2.base_frame_id].homogeneous)
        T = root @ data.oMf[pr2.model.getFrameId(a.tip_frame)].homogeneous @ a.tcp_offset
        np.testing.assert_allclose(T[:3, 3], s.tcp[-1][:3, 3], rtol=0, atol=1e-6)
        jm = pr2.model.joints[pr2.model.getJointId(TORSO)]
        assert q[jm.idx_q] == RAISED


def test_a_plan_file_keeps_the_steps_torso(pr2):
    doc = plan_of(raised_step(pr2)).to_json()
    (step,) = parse_plan(doc, "plan.json", pr2)
    assert step.joints[TORSO] == RAISED and list(step.joints)[-1] == TORSO
    # read back, the step holds at its raised torso (the last pose: the reader keeps its joints only)
    assert plan_of(replace(step, tcp=step.tcp[-1:])).verify(pr2) == []
    assert plan_of(replace(step, tcp=step.tcp[-1:], joints=step.joints | {TORSO: 0.15})).verify(pr2) != []
    q = step_config(pr2, step)
    assert q[pr2.model.joints[pr2.model.getJointId(TORSO)].idx_q] == RAISED
    # a file that gives no torso holds the preset's
    del doc["steps"][0]["joints"][TORSO]
    assert parse_plan(doc, "plan.json", pr2)[0].joints[TORSO] == pr2.fixed_joints[TORSO] == 0.15


@pytest.mark.parametrize("value", [0.5, -0.02])
def test_a_plan_file_with_a_torso_outside_its_limits_is_refused(pr2, value):
    doc = plan_of(raised_step(pr2)).to_json()
    doc["steps"][0]["joints"][TORSO] = value
    with pytest.raises(PlanFileError) as e:
        parse_plan(doc, "plan.json", pr2)
    assert str(e.value) == (
        f"plan.json: steps[0].joints.torso_lift_joint: {value:g} is outside the URDF limits [0, 0.31] of robot 'pr2'"
    )


def test_the_drawn_robot_has_the_steps_torso(pr2):
    """The plan view draws each step at its own torso: FK of the drawn model from the drawn root
    reaches the step's TCP, and the torso link stands 0.1 m higher than at the preset's value."""
    pytest.importorskip("viser", reason="the viewer extra is not installed")
    from placement.viewer.plan_view import PlanView
    from placement.viewer.server import start_server

    s, low = raised_step(pr2), raised_step(pr2, torso=0.15)
    server = start_server(0)
    try:
        pv = PlanView(server, pr2, None, [s, replace(low, step=1)])
        d = pv.robot_drawing
        heights = []
        for i in (0, 1):
            pv.show(i)
            root = np.eye(4)
            root[:3, :3] = pin.Quaternion(*d.frame.wxyz).toRotationMatrix()
            root[:3, 3] = d.frame.position
            tip = pin.updateFramePlacement(pr2.model, d.data, pr2.model.getFrameId(pr2.arm("right").tip_frame))
            T = root @ tip.homogeneous @ pr2.arm("right").tcp_offset
            np.testing.assert_allclose(T[:3, 3], pv.steps[i].tcp[-1][:3, 3], rtol=0, atol=1e-6)
            heights.append((root @ d.data.oMi[pr2.model.getJointId(TORSO)].homogeneous)[2, 3])
        assert heights[0] - heights[1] == pytest.approx(0.1, abs=1e-9)
    finally:
        server.stop()
