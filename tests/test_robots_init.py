"""`placement robots init`: proposed presets load unedited, hold the URDF's arm chains, and put the TCP's
z axis from the wrist towards the fingers; xacro works; bad input is one line, exit 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from support.robots import ARMAR6_URDF
from support.toy_robot import arm_urdf, arm_xacro

import placement
from placement.robots.chain import ancestors
from placement.robots.onboarding.propose import propose
from placement.robots.onboarding.render import render
from placement.robots.spec import share_dir

ERD = "example-robot-data/robots/"
#: robot -> (URDF, {expected arm name: last arm joint}, joints whose chains are not the arms')
ROBOTS = {
    "pr2": (
        ERD + "pr2_description/urdf/pr2.urdf",
        {"left": "l_wrist_roll_joint", "right": "r_wrist_roll_joint"},
        ["head_tilt_joint"],
    ),
    "armar6": (str(ARMAR6_URDF), {"left": "arm_t8_joint_r0", "right": "arm_t8_joint_r1"}, ["neck_2_pitch"]),
    "tiago": (ERD + "tiago_description/robots/tiago.urdf", {"arm": "arm_7_joint"}, ["head_2_joint"]),
    "talos_reduced": (
        ERD + "talos_data/robots/talos_reduced.urdf",
        {"left": "arm_left_7_joint", "right": "arm_right_7_joint"},
        ["head_2_joint", "leg_left_6_joint"],
    ),
    "romeo": (
        ERD + "romeo_description/urdf/romeo.urdf",
        {"left": "LWristPitch", "right": "RWristPitch"},
        ["HeadRoll", "LAnkleRoll"],
    ),
    "tiago_pro": (
        ERD + "tiago_pro_description/robots/tiago_pro.urdf",
        {"left": "arm_left_7_joint", "right": "arm_right_7_joint"},
        ["head_2_joint"],
    ),
    "panda": (ERD + "panda_description/urdf/panda.urdf", {"arm": "panda_joint7"}, []),
}
FINGER_WORDS = ("finger", "thumb", "index", "middle", "ring", "pinky")


def urdf_path(robot: str) -> Path:
    path = ROBOTS[robot][0]
    full = Path(path) if path.startswith("/") else share_dir() / path
    if not full.is_file():
        pytest.skip(f"{full} is not available")
    return full


def run(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "placement.cli.main", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=dict(os.environ),
    )


def one_line_error(proc, *words):
    """Exit 2 and stderr exactly one `error: ...` line holding ``words`` (no traceback, no usage text)."""
    lines = proc.stderr.splitlines()
    assert (proc.returncode, len(lines), lines[0][:7] if lines else "") == (2, 1, "error: "), proc.stderr
    assert all(w in lines[0] for w in words), lines[0]


@pytest.fixture(scope="module")
def proposed(tmp_path_factory):
    """{robot: (loaded Robot, proposal)} for every robot of ROBOTS (each preset written and loaded)."""
    out = {}
    folder = tmp_path_factory.mktemp("init")
    for robot in ROBOTS:
        try:
            urdf = urdf_path(robot)
        except pytest.skip.Exception:
            continue
        preset = folder / f"{robot}.yaml"
        p = propose(urdf, preset)
        preset.write_text(render(p))
        out[robot] = (placement.load_robot(preset), p)
    return out


def expected_chain(model: pin.Model, last: str, others: list[str]) -> list[str]:
    """The arm's joints computed here: 1-DoF joints from the base to ``last``, minus every joint that
    also moves one of ``others`` (torso, legs) or that no other chain shares (nothing above a branch)."""
    shared = {j for o in others for j in ancestors(model, model.getJointId(o))}
    chain = [j for j in ancestors(model, model.getJointId(last)) if j not in shared and model.joints[j].nv == 1]
    return [model.names[j] for j in reversed(chain)]


@pytest.mark.slow
@pytest.mark.parametrize("robot", list(ROBOTS))
def test_init_finds_the_urdf_arm_chains(proposed, robot):
    if robot not in proposed:
        pytest.skip("URDF not available")
    r, _ = proposed[robot]
    _, arms, others = ROBOTS[robot]
    assert sorted(r.arms) == sorted(arms)
    for name, last in arms.items():
        want = expected_chain(r.model, last, others)
        if robot in ("tiago", "panda"):  # no other chain: the lift/base joints above the arm are held, not arm
            want = [j for j in want if "torso" not in j]
        assert r.arm(name).joints == want


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_tcp_z_points_from_the_wrist_to_the_fingers(proposed, robot):
    if robot not in proposed:
        pytest.skip("URDF not available")
    r, _ = proposed[robot]
    data = r.model.createData()
    for name in r.arms:
        a = r.arm(name)
        for q in (a.home, a.lower * 0.3 + a.upper * 0.7):
            full = r.full_q(name, q)
            pin.framesForwardKinematics(r.model, data, full)
            last = a.joint_ids[-1]
            fingers = [
                i
                for i, f in enumerate(r.model.frames)
                if f.type == pin.FrameType.BODY
                and last in ancestors(r.model, f.parentJoint)
                and any(w in f.name.lower() for w in FINGER_WORDS)
            ]
            assert fingers, f"{robot} {name}: no finger frames"
            centre = np.mean([data.oMf[i].translation for i in fingers], axis=0)
            towards = centre - data.oMi[last].translation
            tcp = data.oMf[r.model.getFrameId(a.tip_frame)].homogeneous @ a.tcp_offset
            cos = tcp[:3, 2] @ towards / np.linalg.norm(towards)
            assert cos > 0.8, f"{robot} {name}: TCP z makes {np.degrees(np.arccos(cos)):.0f} deg with wrist->fingers"


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_tcp_y_is_the_fingers_closing_direction(proposed, robot):
    """Grippers with sliding fingers: the TCP's y lies along every finger joint's slide (the Franka
    hand's fingers touch at the neutral pose, so no spread of finger frames can say it)."""
    if robot not in proposed:
        pytest.skip("URDF not available")
    r, _ = proposed[robot]
    data = r.model.createData()
    checked = 0
    for name in r.arms:
        a = r.arm(name)
        full = r.full_q(name, a.home)
        jac = pin.computeJointJacobians(r.model, data, full)
        pin.framesForwardKinematics(r.model, data, full)
        last = a.joint_ids[-1]
        tcp = data.oMf[r.model.getFrameId(a.tip_frame)].homogeneous @ a.tcp_offset
        for j in range(1, r.model.njoints):
            if j == last or last not in ancestors(r.model, j) or r.model.joints[j].nv != 1:
                continue
            col = jac[:, r.model.joints[j].idx_v]
            if np.linalg.norm(col[3:]) > 1e-9:  # a hinge, not a slide
                continue
            cos = abs(tcp[:3, 1] @ col[:3]) / np.linalg.norm(col[:3])
            assert cos > 0.99, (
                f"{robot} {name}: TCP y makes {np.degrees(np.arccos(min(cos, 1))):.0f} deg with {r.model.names[j]}"
            )
            checked += 1
    if robot == "panda":
        assert checked == 2
    elif not checked:
        pytest.skip(f"{robot}: no sliding finger joints")


def _beyond(r, arm: str, depth: float) -> list[str]:
    """Links of ``arm``'s gripper shapes (as the collision check knows them) that reach ``depth`` [m] or more
    beyond the TCP along its approach at home: coal collisions with the half-space past that plane."""
    import coal

    from placement.collision.robot import robot_geometry, transform

    g = robot_geometry(r)
    a = r.arm(arm)
    data = r.model.createData()
    q = r.full_q(arm, a.home, g.home_q)
    pin.framesForwardKinematics(r.model, data, q)
    gdata = pin.GeometryData(g.geom)
    pin.updateGeometryPlacements(r.model, data, g.geom, gdata, q)
    tcp = data.oMf[r.model.getFrameId(a.tip_frame)].homogeneous @ a.tcp_offset
    z, o = tcp[:3, 2], tcp[:3, 3]
    past = coal.Halfspace(-z, -(z @ o + depth))  # {x: z.(x - o) >= depth}
    out = []
    for k in g.arm_shapes(arm).gripper:
        res = coal.CollisionResult()
        if coal.collide(
            g.geom.geometryObjects[int(k)].geometry,
            transform(gdata.oMg[int(k)]),
            past,
            coal.Transform3s(),
            coal.CollisionRequest(),
            res,
        ):
            out.append(g.names[int(k)])
    return out


@pytest.mark.slow
@pytest.mark.parametrize("robot", list(ROBOTS))
def test_fingers_reach_at_most_4_cm_past_the_tcp(proposed, robot):
    """A top grasp puts the TCP on the object's top face: fingers far beyond it (TIAGo's palm-centred
    grasp frame: 9.5 cm) would go into the table. init moves such a TCP to 2 cm short of the far end."""
    from placement.robots.onboarding.tcp import GRASP_DEPTH, HAND_REACH_MAX

    if robot not in proposed:
        pytest.skip("URDF not available")
    r, _ = proposed[robot]
    for name in r.arms:
        assert _beyond(r, name, HAND_REACH_MAX + 1e-3) == [], f"{robot} {name}"
    if robot == "tiago":
        assert _beyond(r, "arm", GRASP_DEPTH - 2e-3), "the moved TCP is 2 cm short of the fingertips"
        assert r.arm("arm").tip_frame == "hand_grasping_frame"
        assert np.allclose(r.arm("arm").tcp_offset[:3, 2] @ r.arm("arm").tcp_offset[:3, 3], 0.0745, atol=2e-3)


def test_pr2_proposal_matches_the_builtin_preset(proposed):
    r, p = proposed["pr2"]
    pr2 = placement.load_robot("pr2")
    assert r.base_frame == pr2.base_frame == "base_footprint"
    assert set(r.fixed_joints) == {"torso_lift_joint"}
    for name in ("left", "right"):
        assert r.arm(name).tip_frame == pr2.arm(name).tip_frame
        # same approach axis as the hand-written preset (the closing axis may have the other sign)
        a, b = r.arm(name).tcp_offset, pr2.arm(name).tcp_offset
        assert np.allclose(a[:3, 2], b[:3, 2], atol=1e-6) and abs(a[:3, 1] @ b[:3, 1]) > 0.999
    # the footprint hull holds the PR2's 0.668 m square base
    assert r.footprint is not None
    assert r.footprint[:, 0].max() >= 0.334 and r.footprint[:, 1].max() >= 0.334
    assert any("v_max" in w for w in p.warnings)
    # no self pair of the PR2 (nor of ARMAR-6) collides in most configurations: nothing to ignore
    assert not p.ignore and "ignore_collisions" not in render(p)
    assert "armar6" not in proposed or not proposed["armar6"][1].ignore


def test_humanoid_base_frame_is_on_the_floor(proposed):
    if "talos_reduced" not in proposed:
        pytest.skip("URDF not available")
    r, p = proposed["talos_reduced"]
    data = r.model.createData()
    pin.framesForwardKinematics(r.model, data, r.reference_q())
    z = [data.oMf[i].translation[2] - data.oMf[r.base_frame_id].translation[2] for i in range(len(r.model.frames))]
    assert min(z) > -0.02  # nothing below the base frame: it is on the floor
    # the pelvis projected to the floor, not a sole that the legs move
    assert (r.base_frame, r.base_frame_parent) == ("base_floor", "base_link")
    assert ancestors(r.model, r.model.frames[r.base_frame_id].parentJoint) == []
    assert any("projected to the floor" in n for n in p.base.notes)


def test_lift_is_held_where_top_down_reach_at_table_height_is_largest(proposed):
    if "tiago" not in proposed:
        pytest.skip("URDF not available")
    r, _ = proposed["tiago"]
    lo, hi = r.model.lowerPositionLimit[0], r.model.upperPositionLimit[0]
    assert r.fixed_joints["torso_lift_joint"] > (lo + hi) / 2  # the issue's mid-range torso was too low


def test_xacro_expands_and_inits(tmp_path):
    src = tmp_path / "xtoy.urdf.xacro"
    src.write_text(arm_xacro())
    out = tmp_path / "presets" / "xtoy.yaml"
    out.parent.mkdir()
    p = run("robots", "init", str(src), "--out", str(out), "-q")
    assert p.returncode == 0, p.stderr
    assert 'urdf: "../xtoy.urdf.xacro"' in out.read_text()
    r = placement.load_robot(out)  # the preset names the xacro: expanded at load
    assert r.arm("arm").joints == [f"joint_{i}" for i in range(1, 7)]
    assert r.arm("arm").lower[0] == -2.0  # the property's value reached the limits


def test_mimic_and_finger_joints_are_not_arm_joints(tmp_path):
    src = tmp_path / "toy.urdf"
    src.write_text(arm_urdf())
    p = propose(src)
    assert [a.joints for a in p.arms] == [[f"joint_{i}" for i in range(1, 7)]]
    assert p.arms[0].tcp.tip_frame == "gripper_tool_frame"


@pytest.mark.slow
def test_json_and_stdout(tmp_path):
    src = tmp_path / "toy.urdf"
    src.write_text(arm_urdf())
    p = run("robots", "init", str(src), "--json", "-q")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["arms"]["arm"]["joints"][0] == "joint_1" and doc["base_frame"] == "base_footprint"
    p = run("robots", "init", str(src), "-q")
    assert p.returncode == 0 and p.stdout.startswith("# Generated by `placement robots init")


@pytest.mark.slow
def test_out_is_never_overwritten_without_force(tmp_path):
    src = tmp_path / "toy.urdf"
    src.write_text(arm_urdf())
    out = tmp_path / "toy.yaml"
    out.write_text("keep me\n")
    one_line_error(run("robots", "init", str(src), "--out", str(out)), "--force")
    assert out.read_text() == "keep me\n"
    assert run("robots", "init", str(src), "--out", str(out), "--force", "-q").returncode == 0
    assert placement.load_robot(out).name == "toy"


@pytest.mark.slow
@pytest.mark.parametrize(
    "case, words",
    [
        ("missing", ["not found"]),
        ("text", ["not a URDF"]),
        ("sdf", ["not a URDF", "<sdf>"]),
        ("no_arm", ["no arm with >= 5", "joint_4"]),
        ("xacro_error", ["xacro", "does not expand"]),
        ("directory", ["not a file"]),
    ],
)
def test_bad_input_is_one_line(tmp_path, case, words):
    files = {
        "text": ("robot.urdf", "just some text\n"),
        "sdf": ("robot.urdf", "<sdf version='1.6'/>"),
        "no_arm": ("small.urdf", arm_urdf(joints=4)),
        "xacro_error": ("bad.urdf.xacro", arm_xacro().replace("${-limit}", "${-undefined_limit}")),
    }
    if case == "missing":
        path = tmp_path / "nope.urdf"
    elif case == "directory":
        path = tmp_path
    else:
        name, text = files[case]
        path = tmp_path / name
        path.write_text(text)
    one_line_error(run("robots", "init", str(path), "--out", str(tmp_path / "out.yaml")), *words)
    assert not (tmp_path / "out.yaml").exists()


def test_preset_naming_a_broken_xacro_is_one_line(tmp_path):
    (tmp_path / "bad.xacro").write_text(arm_xacro().replace("${-limit}", "${-nope}"))
    preset = tmp_path / "p.yaml"
    preset.write_text(
        "name: x\nurdf: bad.xacro\nbase_frame: base_footprint\nfootprint_radius: 0.4\nv_max: 0.5\n"
        "omega_max: 1\narms: {arm: {joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6], "
        "tip_frame: gripper_tool_frame}}\n"
    )
    one_line_error(run("robots", "check", str(preset)), "p.yaml: urdf", "does not expand")


@pytest.mark.slow
def test_unusable_out_is_refused_before_any_work(tmp_path):
    src = tmp_path / "toy.urdf"
    src.write_text(arm_urdf())
    one_line_error(run("robots", "init", str(src), "--out", str(tmp_path / "no" / "x.yaml")), "does not exist")
    one_line_error(run("robots", "init", str(src), "--out", str(tmp_path)), "is a directory")


def test_package_paths_are_resolved():
    p = propose("package://example-robot-data/robots/panda_description/urdf/panda.urdf")
    assert p.urdf == "package://example-robot-data/robots/panda_description/urdf/panda.urdf"
    assert [a.name for a in p.arms] == ["arm"]


#: More of example-robot-data's robots with arms, as their makers' URDFs are: each proposal loads
#: (iCub's footprint had two corners within a millimetre, repeated after rounding; the Unitree Z1
#: names a link and its joint alike, and pinocchio's frame lookup raised).
MORE = [
    "baxter_description/urdf/baxter.urdf",
    "icub_description/robots/icub.urdf",
    "icub_description/robots/icub_reduced.urdf",
    "z1_description/urdf/z1.urdf",
    "kinova_description/robots/kinova.urdf",
    "xarm_description/urdf/xarm7.urdf",
    "alex_description/urdf/alex_nub_hands.urdf",
]


@pytest.mark.slow
@pytest.mark.parametrize("path", MORE, ids=[p.split("/")[-1].split(".")[0] for p in MORE])
def test_more_makers_robots_initialise_and_load(tmp_path, path):
    full = share_dir() / "example-robot-data" / "robots" / path
    if not full.is_file():
        pytest.skip(f"{full} is not available")
    out = tmp_path / "robot.yaml"
    p = run("robots", "init", str(full), "--out", str(out))
    assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr[-500:]
    robot = placement.load_robot(out)
    assert robot.arms
    c = run("robots", "check", str(out), "--json")
    assert c.returncode == 0, c.stderr[-500:]
