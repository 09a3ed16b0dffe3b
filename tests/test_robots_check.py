"""`placement robots check` and the reach bands: JSON, plain-words warnings, plots, and bands that agree
with an independent pinocchio FK sampling within a map cell."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
import yaml
from support.toy_robot import arm_urdf

import placement
from placement.robots.onboarding.check import check_robot
from placement.robots.onboarding.reach import QUANTILE, base_clearance, chain_fk, reach_band, sample_configs

CELL = 0.1  # [m] the map cell the bands must agree to


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "placement.cli.main", *args], capture_output=True, text=True, env=dict(os.environ)
    )


def pinocchio_band(robot, arm: str, approach: str, n: int, seed: int) -> tuple[float, float, float, float]:
    """(z_min, z_max, r_min, r_max) [m] from pinocchio's own FK of ``n`` configurations (not the chain)."""
    a = robot.arm(arm)
    rng = np.random.default_rng(seed)
    model, data = robot.model, robot.model.createData()
    tip = model.getFrameId(a.tip_frame)
    ref = robot.reference_q()
    zs, rs = [], []
    for q in rng.uniform(a.lower, a.upper, size=(n, len(a.lower))):
        pin.framesForwardKinematics(model, data, robot.full_q(arm, q, ref))
        T = (data.oMf[robot.base_frame_id].inverse() * data.oMf[tip]).homogeneous @ a.tcp_offset
        z = T[:3, 2]
        r = math.hypot(T[0, 3], T[1, 3])
        if r < base_clearance(robot):
            continue
        if approach == "down":
            ok = -z[2] >= math.cos(math.radians(15))
        else:
            ok = abs(z[2]) <= math.sin(math.radians(15)) and z[:2] @ T[:2, 3] > 0.5 * r * np.linalg.norm(z[:2])
        if ok:
            zs.append(T[2, 3])
            rs.append(r)
    q = (QUANTILE, 1 - QUANTILE)
    return (*np.quantile(zs, q), *np.quantile(rs, q))


@pytest.mark.slow
@pytest.mark.parametrize("approach", ["down", "horizontal"])
def test_bands_agree_with_pinocchio_fk(pr2, approach):
    band = reach_band(pr2, "right", approach)
    independent = pinocchio_band(pr2, "right", approach, 40_000 if approach == "down" else 6_000, seed=7)
    assert band.matched > 100
    for mine, theirs in zip((band.z_min, band.z_max, band.r_min, band.r_max), independent):
        assert abs(mine - theirs) <= CELL, (band, independent)


def test_armar6_bands_agree_with_pinocchio_fk(armar6):
    band = reach_band(armar6, "left", "horizontal")
    independent = pinocchio_band(armar6, "left", "horizontal", 6_000, seed=3)
    for mine, theirs in zip((band.z_min, band.z_max, band.r_min, band.r_max), independent):
        assert abs(mine - theirs) <= CELL


def test_chain_fk_is_pinocchio(pr2, armar6):
    for robot, arm in ((pr2, "left"), (armar6, "right")):
        a = robot.arm(arm)
        Q = sample_configs(a.lower, a.upper, 20, seed=1)
        T = chain_fk(a.chain, Q)
        for q, t in zip(Q, T):
            assert np.allclose(t, robot.tcp_pose(arm, q), atol=1e-9)


@pytest.mark.slow
def test_raising_the_torso_raises_the_band(tmp_path):
    heights = []
    for lift in (0.0, 0.31):
        spec = yaml.safe_load(open(placement.robots.preset.PRESET_DIR / "pr2.yaml"))
        spec["urdf"] = str(placement.robots.spec.resolve_path(spec["urdf"], tmp_path))
        spec["srdf"] = str(placement.robots.spec.resolve_path(spec["srdf"], tmp_path))
        spec["fixed_joints"]["torso_lift_joint"] = lift
        path = tmp_path / f"pr2_{lift}.yaml"
        path.write_text(yaml.safe_dump(spec))
        heights.append(reach_band(placement.load_robot(path), "right", "down").z_max)
    assert heights[1] - heights[0] == pytest.approx(0.31, abs=0.05)


def toy_preset(tmp_path, lift_tcp: str = "[0, 0, 0, 0, 0.7071068, 0, 0.7071068]") -> str:
    (tmp_path / "toy.urdf").write_text(arm_urdf(mount=0.1))  # shoulder 0.35 m above the floor
    path = tmp_path / "toy.yaml"
    path.write_text(
        "name: toy\nurdf: toy.urdf\nbase_frame: base_footprint\nfootprint_radius: 0.3\nv_max: 0.5\n"
        "omega_max: 1\narms: {arm: {joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6], "
        f"tip_frame: gripper_tool_frame, tcp_offset: {lift_tcp}}}}}\n"
    )
    return str(path)


@pytest.mark.slow
def test_check_json_and_warnings(tmp_path):
    p = run("robots", "check", toy_preset(tmp_path), "--json")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    down = doc["arms"]["arm"]["bands"]["down"]
    assert down["z_max"] < 0.75  # shoulder 0.35 m high, 0.6 m of arm, the hand 0.22 m long
    assert any(
        "top-down grasp reaches only" in w and "0.75 m tables" in w and "with no joint held" in w
        for w in doc["warnings"]
    ), doc["warnings"]
    assert doc["arms"]["arm"]["tcp_axis"]["ok"]


def test_a_tcp_pointing_into_the_arm_is_flagged(tmp_path):
    # -90 deg about y: TCP z along the tool frame's -x, back into the wrist
    doc = check_robot(
        placement.load_robot(toy_preset(tmp_path, "[0, 0, 0, 0, -0.7071068, 0, 0.7071068]")), samples=2000
    )
    assert not doc["arms"]["arm"]["tcp_axis"]["ok"]
    assert any("points back towards the wrist" in w for w in doc["warnings"])


def test_pr2_at_mid_torso_has_no_table_warning(pr2):
    doc = check_robot(pr2, samples=50_000)
    assert not [w for w in doc["warnings"] if "top-down" in w]


@pytest.mark.slow
def test_plots(tmp_path):
    out = tmp_path / "plots"
    p = run("robots", "check", toy_preset(tmp_path), "--plot", str(out), "--json")
    assert p.returncode == 0, p.stderr
    plots = json.loads(p.stdout)["plots"]
    assert sorted(os.path.basename(x) for x in plots) == ["toy_reach.png", "toy_tcp_arm.png"]
    for x in plots:
        assert open(x, "rb").read(8) == b"\x89PNG\r\n\x1a\n"


def test_bad_preset_and_plot_dir_are_one_line(tmp_path):
    p = run("robots", "check", str(tmp_path / "none.yaml"))
    assert p.returncode == 2 and p.stderr.startswith("error: unknown robot") and len(p.stderr.splitlines()) == 1
    (tmp_path / "file").write_text("x")
    p = run("robots", "check", "pr2", "--plot", str(tmp_path / "file" / "sub"))
    assert p.returncode == 2 and "--plot" in p.stderr and len(p.stderr.splitlines()) == 1
