"""talos_reduced leaning over a low table: the build spec maps/talos_reduced_torso.yaml, the scene
examples/talos_reduced_lean.yaml and tools/talos_lean.py.

Without maps: the spec is maps/talos_reduced.yaml plus ``torso`` (fewer samples) and passes placement's
own torso checks (``torso_2_joint`` a revolute joint that carries both arms: one build per setting),
checked against the URDF's XML and pinocchio's joint supports; a joint that carries no arm and a value
past the URDF limit are refused; the scene's low table is low; the map-free search finds a low-table
step out of reach upright and within reach leaning. ``maps info`` reports each torso setting's own
array (it once reported the arm's for every setting), on the toy pitch robot.

With the built maps (``maps/talos_reduced_torso``; skipped when absent): the global plan verifies, holds
every low-table step leaning, and pinocchio FK of the robot at each step's torso value puts the TCP on
the step's target, which the same joints upright miss.
"""

from __future__ import annotations

import json
import math
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml
from support.cli import run
from support.fk import world_tcp
from support.pitch_torso import JOINT as TOY_JOINT
from support.pitch_torso import write_pitch_torso

import placement
from placement import PlacementError
from placement.maps.buildspec import TorsoSpec, load_build_spec
from placement.maps.torso import torso_settings
from placement.maps.torso_builds import build_torso_maps
from placement.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from talos_lean import JOINT, low_steps  # noqa: E402

SPEC = ROOT / "maps" / "talos_reduced_torso.yaml"
SCENE = ROOT / "examples" / "talos_reduced_lean.yaml"
MAPS = ROOT / "maps" / "talos_reduced_torso"
LEAN = 0.78  # [rad] the spec's most forward setting
no_maps = pytest.mark.skipif(not (MAPS / "zarr.json").is_file(), reason="no talos_reduced_torso maps (see its spec)")


@pytest.fixture(scope="module")
def talos():
    return placement.load_robot(load_build_spec(SPEC).robot)


def test_the_spec_is_the_talos_spec_plus_a_revolute_torso(talos):
    spec, plain = load_build_spec(SPEC), load_build_spec(ROOT / "maps" / "talos_reduced.yaml")
    keep = ("robot", "arms", "seed", "resolution", "bins", "index", "format", "self_collision", "completion")
    assert {k: getattr(spec, k) for k in keep} == {k: getattr(plain, k) for k in keep}
    assert plain.torso is None and spec.torso is not None and spec.torso.joint == JOINT
    assert spec.torso.values[0] == talos.fixed_joints[JOINT] == 0.0 and spec.torso.values[-1] == LEAN
    xml = next(j for j in ET.parse(talos.urdf_path).getroot().iter("joint") if j.get("name") == JOINT)
    limit = xml.find("limit")
    assert xml.get("type") == "revolute" and limit is not None
    assert all(float(limit.get("lower")) <= v <= float(limit.get("upper")) for v in spec.torso.values)
    jid = talos.model.getJointId(JOINT)
    assert spec.arms is not None and sorted(spec.arms) == sorted(talos.arms)
    for arm in spec.arms:
        s = torso_settings(talos, arm, spec.torso)
        assert s.shift is None and s.unit == "rad" and s.reference == 0.0  # one build per setting
        assert s.velocity == pytest.approx(float(limit.get("velocity")))
        # the joint carries every joint of the arm (pinocchio's supports: the joints from the root)
        assert all(jid in talos.model.supports[talos.model.getJointId(j)] for j in talos.arm(arm).joints)


def test_a_joint_that_carries_no_arm_and_a_value_past_the_limit_are_refused(talos, tmp_path):
    preset = yaml.safe_load((ROOT / "examples" / "robots" / "talos_reduced.yaml").read_text())
    preset["fixed_joints"]["head_1_joint"] = 0.0  # the head's pan, held too: it carries no arm
    (tmp_path / "talos_head.yaml").write_text(yaml.safe_dump(preset))
    held = placement.load_robot(tmp_path / "talos_head.yaml")
    with pytest.raises(PlacementError, match=r"torso.joint: 'head_1_joint' does not carry arm 'left'"):
        torso_settings(held, "left", TorsoSpec("head_1_joint", (0.0, 0.3)))
    with pytest.raises(PlacementError, match=r"torso.values\[1\]: 0.9 rad is outside the URDF limits"):
        torso_settings(talos, "left", TorsoSpec(JOINT, (0.0, 0.9)))


def test_the_scene_has_a_low_and_an_ordinary_table():
    scene = load_scene(SCENE)
    tops = {o.name: o.shape.center[2] + o.shape.size[2] / 2 for o in scene.obstacles if o.table}
    assert tops == pytest.approx({"low_table": 0.42, "table": 0.75})
    assert str(scene.maps).endswith("maps/talos_reduced_torso") and len(scene.task) == 3


@pytest.fixture(scope="module")
def ground():
    from kitchen_torso import Ground

    return Ground(SCENE, JOINT)


def test_a_low_table_step_needs_the_lean(ground):
    assert low_steps(ground) == [1, 2, 4]  # place on it, pick the two objects standing on it
    assert ground.placement(2, 0.0) is None  # pick low_box upright: no base on the grid
    found = ground.placement(2, LEAN)
    assert found is not None and found.tries <= ground.cap
    assert ground.placement(0, 0.0) is not None  # the ordinary table's pick, upright


@pytest.mark.slow
def test_maps_info_reports_each_settings_own_array(tmp_path):
    preset = write_pitch_torso(tmp_path / "robot")
    robot = placement.load_robot(preset)
    built = build_torso_maps(
        robot, "arm", torso=TorsoSpec(TOY_JOINT, (0.3, 0.8)), samples=20_000, resolution=0.25, bins=(4, 3, 4)
    )
    placement.save_maps(tmp_path / "m", robot, built)
    proc = run("maps", "info", str(tmp_path / "m"), "--json", "-q")
    assert proc.returncode == 0, proc.stderr
    info = json.loads(proc.stdout)["arms"]["arm"]
    filled = {s["array"]: s["filled_cells"] for s in info["settings"]} | {"arm": info["filled_cells"]}
    assert filled == {name: int((m.values > 0).sum()) for name, m in built.items()}
    assert len(set(filled.values())) == 3  # the builds differ, so a setting showing the arm's would fail


@no_maps
def test_the_global_plan_leans_over_the_low_table(talos, ground):
    from placement.planning.planner import Planner

    result = Planner(SCENE, "global", maps=MAPS).plan()
    assert all(s.ok for s in result.steps), [s.reason for s in result.steps]
    assert result.verify(talos) == []
    low = low_steps(ground)
    assert [s.joints[JOINT] for s in result.steps if s.step in low] == [LEAN] * len(low)
    for s in result.steps:
        a = talos.arm(s.arm)
        joints = {j: s.joints[j] for j in a.joints}
        T, target = world_tcp(talos, s.arm, joints | {JOINT: s.joints[JOINT]}, s.base), np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        cos = np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1)
        assert math.degrees(math.acos(cos)) < 3
        if s.step in low:  # upright, the same arm joints put the hand elsewhere
            up = world_tcp(talos, s.arm, joints | {JOINT: 0.0}, s.base)
            assert np.linalg.norm(up[:3, 3] - target[:3, 3]) > 0.1
