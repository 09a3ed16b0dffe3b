"""`robots init` / `robots check` on robots unlike the PR2: a lift with a telescoping arm (an arm by what it
reaches, with a warning that it spans 5 pose directions), a wheeled robot with a torso of three pitch joints
(the root projected to the floor as its base frame, the torso held upright and low enough for tables) and
example-robot-data's centauro (a base frame no joint moves, arms that reach tables)."""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
import pytest
from support.toy_robot import telescope_urdf, wheeled_torso_urdf

import placement
from placement.errors import PlacementError
from placement.robots.chain import ancestors
from placement.robots.onboarding.check import check_robot
from placement.robots.onboarding.propose import propose
from placement.robots.onboarding.rank import pose_rank
from placement.robots.onboarding.render import render
from placement.robots.spec import share_dir

CENTAURO = "example-robot-data/robots/centauro_description/urdf/centauro.urdf"


def written(tmp_path, name: str, text: str):
    """(loaded Robot, proposal, seconds) for the URDF ``text`` proposed and written as a preset."""
    src = tmp_path / f"{name}.urdf"
    src.write_text(text)
    out = tmp_path / f"{name}.yaml"
    t0 = time.perf_counter()
    p = propose(src, out)
    seconds = time.perf_counter() - t0
    out.write_text(render(p))
    return placement.load_robot(out), p, seconds


def pinocchio_rank(robot, arm: str, n: int = 10) -> int:
    """Largest rank of pinocchio's own frame Jacobian of the arm's joints (not the chain) at random q."""
    a = robot.arm(arm)
    data = robot.model.createData()
    tip = robot.model.getFrameId(a.tip_frame)
    cols = [robot.model.joints[j].idx_v for j in a.joint_ids]
    best = 0
    for q in np.random.default_rng(3).uniform(a.lower, a.upper, size=(n, a.dof)):
        full = robot.full_q(arm, q)
        J = pin.computeFrameJacobian(robot.model, data, full, tip, pin.LOCAL_WORLD_ALIGNED)[:, cols]
        best = max(best, int(np.linalg.matrix_rank(J, tol=1e-6)))
    return best


def base_is_still(robot) -> bool:
    """No joint moves the base frame (it hangs on the root)."""
    return ancestors(robot.model, robot.model.frames[robot.base_frame_id].parentJoint) == []


def test_lift_and_telescoping_arm_is_an_arm_with_a_rank_warning(tmp_path):
    r, p, _ = written(tmp_path, "telescope", telescope_urdf())
    assert r.arm("arm").joints == [
        "lift",
        "arm_l0",
        "arm_l1",
        "arm_l2",
        "arm_l3",
        "wrist_yaw",
        "wrist_pitch",
        "wrist_roll",
    ]
    # the neutral gripper hangs low (the old neutral-pose rule called it a leg); its reach is what counts
    data = r.model.createData()
    pin.framesForwardKinematics(r.model, data, pin.neutral(r.model))
    assert data.oMf[r.model.getFrameId("gripper_tool_frame")].translation[2] < 0.2
    assert pose_rank(r.arm("arm").chain, r.arm("arm").lower, r.arm("arm").upper) == pinocchio_rank(r, "arm") == 5
    assert any("spans 5 of the 6 pose directions" in w for w in p.warnings)
    doc = check_robot(r, samples=20_000)
    assert doc["arms"]["arm"]["pose_rank"] == 5
    assert any("spans 5 of the 6 pose directions" in w for w in doc["warnings"])


def test_full_arms_get_no_rank_warning(pr2):
    doc = check_robot(pr2, samples=5_000)
    assert all(v["pose_rank"] == 6 for v in doc["arms"].values())
    assert not any("pose directions" in w for w in doc["warnings"])


@pytest.mark.slow
def test_wheeled_torso_gets_the_floor_projected_root_and_an_upright_low_torso(tmp_path):
    r, p, _ = written(tmp_path, "wheeled", wheeled_torso_urdf())
    assert (r.base_frame, r.base_frame_parent) == ("base_floor", "base_link")
    assert base_is_still(r)
    model, data = r.model, r.model.createData()
    q = r.reference_q()
    pin.framesForwardKinematics(model, data, q)
    base = data.oMf[r.base_frame_id]
    # the base frame is on the floor: the wheels' bottoms (0.15 m radius, 0.1 m below the root) touch it
    assert base.translation[2] == pytest.approx(-0.25, abs=2e-3)
    wheel = data.oMf[model.getFrameId("wheel_left_link")].translation
    assert wheel[2] - 0.15 == pytest.approx(base.translation[2], abs=2e-3)
    # upright: the chest's rotation is the root's, though the torso bends
    held = [r.fixed_joints[f"torso_{i}_joint"] for i in (1, 2, 3)]
    assert any(abs(v) > 0.1 for v in held)
    chest = data.oMf[model.getFrameId("chest")]
    assert np.allclose(chest.rotation, np.eye(3), atol=1e-3)
    # and the bend brings the tables in reach: the straight torso's top-down band starts above them
    doc = check_robot(r, samples=40_000)
    for arm in ("left", "right"):
        down = doc["arms"][arm]["bands"]["down"]
        assert down["z_min"] <= 0.70 and down["z_max"] >= 0.90
    assert not any("top-down grasp" in w for w in doc["warnings"])
    text = render(p)
    assert "upright" in text and "base_frame_xyz: [0.0, 0.0, -0.25]" in text


@pytest.mark.slow
def test_check_names_the_torso_values_that_fix_a_warning(tmp_path):
    r, _, _ = written(tmp_path, "wheeled", wheeled_torso_urdf())
    straight = tmp_path / "straight.yaml"
    text = (tmp_path / "wheeled.yaml").read_text()
    for j in (1, 2, 3):
        text = "\n".join(
            f'  "torso_{j}_joint": 0' if line.startswith(f'  "torso_{j}_joint"') else line for line in text.splitlines()
        )
    straight.write_text(text + "\n")
    doc = check_robot(placement.load_robot(straight), samples=40_000)
    out = [w for w in doc["warnings"] if "top-down grasp" in w]
    assert out and "out of reach" in out[0]
    fixes = [w for w in doc["warnings"] if w.startswith("holding torso_1_joint") and "top-down band" in w]
    assert fixes and "(upright)" in fixes[0]


@pytest.mark.slow
def test_a_defined_base_frame_is_checked(tmp_path):
    _, _, _ = written(tmp_path, "wheeled", wheeled_torso_urdf())
    text = (tmp_path / "wheeled.yaml").read_text()
    cases = {
        "taken": (text.replace('base_frame: "base_floor"', 'base_frame: "chest"'), "already a URDF frame"),
        "no_parent": (
            text.replace('base_frame_parent: "base_link"', 'base_frame_parent: "nowhere"'),
            "base_frame_parent",
        ),
        "half": (text.replace('base_frame_parent: "base_link"\n', ""), "base_frame_parent"),
        "far": (text.replace("[0.0, 0.0, -0.25]", "[0.0, 0.0, -25]"), "base_frame_xyz[2]"),
    }
    for case, (body, words) in cases.items():
        path = tmp_path / f"{case}.yaml"
        path.write_text(body)
        with pytest.raises(PlacementError) as err:
            placement.load_robot(path)
        assert words in str(err.value) and "\n" not in str(err.value), case


@pytest.mark.parametrize(
    "preset, parent",
    [
        ("pr2", None),
        ("examples/robots/tiago.yaml", None),
        # a humanoid has no floor frame no joint moves: init defines the pelvis projected to the floor
        ("examples/robots/talos_reduced.yaml", "base_link"),
        ("examples/robots/romeo.yaml", "base_link"),
    ],
)
def test_presets_base_frames_are_still_and_on_the_floor(preset, parent):
    from pathlib import Path

    path = preset if preset == "pr2" else Path(__file__).resolve().parents[1] / preset
    r = placement.load_robot(path)
    assert r.base_frame_parent == parent and r.model.existFrame(r.base_frame)
    assert base_is_still(r)
    if parent is not None:
        # nothing below the defined frame (within 2 cm): it is on the floor
        data = r.model.createData()
        pin.framesForwardKinematics(r.model, data, r.reference_q())
        z0 = data.oMf[r.base_frame_id].translation[2]
        assert min(f.translation[2] for f in data.oMf) - z0 > -0.02


@pytest.mark.slow
def test_centauro(tmp_path):
    urdf = share_dir() / CENTAURO
    if not urdf.is_file():
        pytest.skip(f"{urdf} is not available")
    out = tmp_path / "centauro.yaml"
    t0 = time.perf_counter()
    p = propose(urdf, out)
    seconds = time.perf_counter() - t0
    out.write_text(render(p))
    r = placement.load_robot(out)
    assert seconds < 60
    assert sorted(r.arms) == ["left", "right"]
    assert base_is_still(r) and r.base_frame_parent == "pelvis"
    # the base frame is on the floor under the pelvis: the wheels' contact frames are at its height
    data = r.model.createData()
    pin.framesForwardKinematics(r.model, data, r.reference_q())
    base = data.oMf[r.base_frame_id]
    assert np.allclose(base.translation[:2], 0.0)
    neutral = r.model.createData()
    pin.framesForwardKinematics(r.model, neutral, pin.neutral(r.model))
    for k in (1, 2, 3, 4):
        contact = data.oMf[r.model.getFrameId(f"contact_{k}")]
        assert contact.translation[2] == pytest.approx(base.translation[2], abs=0.01)
        # the wheels stand upright: the legs' pitch rotations compose to the identity
        mount = r.model.getJointId(f"ankle_yaw_{k}")
        assert np.allclose(data.oMi[mount].rotation, neutral.oMi[mount].rotation, atol=1e-3)
    doc = check_robot(r, samples=40_000)
    for arm in ("left", "right"):
        down = doc["arms"][arm]["bands"]["down"]
        assert down["z_min"] <= 0.70 and down["z_max"] >= 0.90, (arm, down)
