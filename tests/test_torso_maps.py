"""The torso lift as a placement variable: the build spec's ``torso`` key, its checks against the robot,
the record in the stored metadata, and map views at other lift settings checked against pinocchio FK of
the robot with the lift moved (``Robot.with_fixed``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from support.cli import ROOT, run
from support.presets import changed, pr2_mapping
from support.telescoping import telescoping_preset, telescoping_urdf

import placement
from placement import PlacementError
from placement.errors import MapError
from placement.maps.buildspec import TorsoSpec, load_build_spec, parse_build_spec
from placement.maps.torso import TorsoSettings, check_torso
from placement.storage.format import BuiltMap

LIFT = "torso_lift_joint"
VALUES = (0.0, 0.1, 0.2, 0.31)
SMALL = {"resolution": 0.1, "bins": (10, 5, 10), "progress": False}
TINY = {"resolution": 0.25, "bins": (4, 3, 4), "progress": False}  # few chunks: quick to save


@pytest.fixture(scope="module")
def built(pr2) -> BuiltMap:
    """A small PR2 right-arm map (0.1 m cells, 200k samples and a completion pass) with the lift settings."""
    torso = TorsoSpec(LIFT, VALUES)
    return placement.build_map(pr2, "right", samples=200_000, seed=4, torso=torso, completion=True, **SMALL)


@pytest.fixture(scope="module", params=["zarr", "hdf5"])
def stored(request, built, pr2, tmp_path_factory) -> Path:
    name = "pr2.h5" if request.param == "hdf5" else "pr2"
    return placement.save_maps(tmp_path_factory.mktemp("torso") / name, pr2, {"right": built}, fmt=request.param)


# -- the spec key alone ------------------------------------------------------------------------------------


def test_torso_key_parses_sorted():
    spec = parse_build_spec({"robot": "pr2", "torso": {"joint": LIFT, "values": [0.2, 0.1, 0, 0.31]}})
    assert spec.torso == TorsoSpec(LIFT, (0.0, 0.1, 0.2, 0.31))
    assert parse_build_spec({"robot": "pr2"}).torso is None


@pytest.mark.parametrize(
    "torso,words",
    [
        ({"joint": LIFT, "values": [0.1, 0.2, 0.1]}, ["torso.values[2]", "twice"]),
        ({"joint": LIFT, "values": [0.1, 0.2, 0.1 + 2**-55]}, ["torso.values[2]", "twice", "within 1e-09"]),
        ({"joint": LIFT, "values": [0.1, "high"]}, ["torso.values[1]", "length"]),
        ({"joint": LIFT, "values": [0.1, float("nan")]}, ["torso.values[1]"]),
        ({"joint": LIFT, "values": []}, ["torso.values", "1 to 16"]),
        ({"joint": LIFT, "values": [i / 100 for i in range(17)]}, ["torso.values", "1 to 16"]),
        ({"joint": LIFT, "values": 0.1}, ["torso.values"]),
        ({"joint": "", "values": [0.1]}, ["torso.joint"]),
        ({"values": [0.1]}, ["torso.joint", "missing"]),
        ({"joint": LIFT, "values": [0.1], "speed": 1}, ["torso", "unknown key 'speed'"]),
        ([LIFT, 0.1], ["torso", "mapping"]),
    ],
)
def test_bad_torso_key_names_it(torso, words):
    with pytest.raises(PlacementError) as info:
        parse_build_spec({"robot": "pr2", "torso": torso}, "build spec s.yaml")
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("build spec s.yaml: torso"), msg
    for w in words:
        assert w in msg, msg


def test_the_shipped_specs_check_against_their_robots():
    for spec_file, values in (("pr2.yaml", (0.0, 0.15, 0.31)), ("tiago.yaml", (0.0, 0.12, 0.24, 0.35))):
        spec = load_build_spec(ROOT / "maps" / spec_file)
        assert spec.torso == TorsoSpec(LIFT, values)
        robot = placement.load_robot(spec.robot)
        for arm, s in check_torso(robot, spec.arms_of(robot), spec.torso).items():
            assert s.joint == LIFT and s.reference == robot.fixed_joints[LIFT], arm
            assert np.allclose(s.shift, (0, 0, 1), atol=1e-9) and s.velocity > 0


# -- the key against the robot -----------------------------------------------------------------------------


def _robot(tmp_path: Path, spec: dict) -> placement.robots.Robot:
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return placement.load_robot(path)


def _refused(robot, arm: str, spec: TorsoSpec, *words: str, self_collision: bool = False) -> None:
    with pytest.raises(PlacementError) as info:
        check_torso(robot, [arm], spec, "build spec s.yaml: torso", self_collision)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("build spec s.yaml: torso"), msg
    for w in words:
        assert w in msg, msg


def test_torso_checks_against_the_robot(pr2, tmp_path):
    _refused(pr2, "right", TorsoSpec("head_pan_joint", (0.0,)), "torso.joint", "not a fixed joint", LIFT)
    _refused(pr2, "right", TorsoSpec(LIFT, (0.0, 0.2, 0.4)), "torso.values[2]", "0.4", "limits [0, 0.31]")
    _refused(pr2, "right", TorsoSpec(LIFT, (-0.01, 0.2)), "torso.values[0]", "limits")
    _refused(pr2, "right", TorsoSpec(LIFT, (0.0,)), "self_collision", self_collision=True)
    head = _robot(tmp_path / "head", changed(pr2_mapping(), fixed_joints={LIFT: 0.15, "head_pan_joint": 0.0}))
    # a revolute joint is one build per setting, but it must carry the arm
    _refused(head, "right", TorsoSpec("head_pan_joint", (0.0,)), "torso.joint", "does not carry arm 'right'")
    # a base frame the lift carries: the lift moves the whole map frame, not the arm in it
    lifted = _robot(tmp_path / "lifted", changed(pr2_mapping(), base_frame="torso_lift_link"))
    _refused(lifted, "right", TorsoSpec(LIFT, (0.0,)), "torso.joint", "moves the base frame")


def test_a_lift_that_does_not_carry_the_arm_is_refused(tmp_path):
    urdf = tmp_path / "telescoping.urdf"
    urdf.write_text(telescoping_urdf())
    spec = telescoping_preset(str(urdf))
    arm = spec["arms"]["arm"]
    # the lift and tele_4 held: tele_4 lies between the other telescoping joints and the wrist
    arm["joints"] = [j for j in arm["joints"] if j not in ("lift", "tele_4")]
    arm["home"] = arm["home"][1:4] + arm["home"][5:]
    spec["fixed_joints"] = {"lift": 0.5, "tele_4": 0.1}
    robot = _robot(tmp_path, spec)
    _refused(robot, "arm", TorsoSpec("tele_4", (0.0, 0.1)), "torso.joint", "arm 'arm'", "tele_1")
    # the lift itself carries the whole arm: accepted, along its z axis, at its URDF speed
    (s,) = check_torso(robot, ["arm"], TorsoSpec("lift", (0.3, 0.9))).values()
    assert s == TorsoSettings("lift", (0.3, 0.9), 0.5, s.shift, 0.5)
    assert np.allclose(s.shift, (0, 0, 1), atol=1e-12)


@pytest.mark.slow
def test_cli_refuses_a_bad_torso_before_sampling(tmp_path):
    spec = tmp_path / "s.yaml"
    spec.write_text(f"robot: pr2\narms: right\nsamples: 1e11\ntorso: {{joint: {LIFT}, values: [0.1, 0.5]}}\n")
    proc = run("maps", "build", "--spec", str(spec), "--out", str(tmp_path / "m"))
    assert proc.returncode != 0 and "torso.values[1]" in proc.stderr and "limits" in proc.stderr, proc.stderr
    assert not (tmp_path / "m").exists()


# -- the stored record -------------------------------------------------------------------------------------


@pytest.mark.slow
def test_the_record_is_stored_and_read_back(stored, pr2):
    rmap = placement.open_map(stored, "right", pr2)
    t = rmap.torso
    assert isinstance(t, TorsoSettings)
    assert t.joint == LIFT and t.values == VALUES and t.reference == 0.15 and t.velocity == pytest.approx(0.013)
    assert np.abs(np.array(t.shift) - (0, 0, 1)).max() <= 1e-9
    assert rmap.torso_value == 0.15 and t.allowed == (0.0, 0.1, 0.15, 0.2, 0.31)


@pytest.mark.slow
def test_a_map_without_the_key_loads_as_before(pr2, tmp_path):
    m = placement.build_map(pr2, "right", samples=1000, seed=4, **TINY)
    assert "torso" not in m.meta
    rmap = placement.open_map(placement.save_maps(tmp_path / "plain", pr2, {"right": m}), "right", pr2)
    assert rmap.torso is None and rmap.torso_value is None
    with pytest.raises(MapError, match="no torso settings"):
        rmap.at_torso(0.15)


def test_a_record_naming_a_joint_the_preset_does_not_hold_is_refused(pr2, tmp_path):
    m = placement.build_map(pr2, "right", samples=1000, seed=4, torso=TorsoSpec(LIFT, VALUES), **TINY)
    meta = json.loads(json.dumps(m.meta))
    meta["torso"]["joint"] = "head_pan_joint"  # as another build or software could have written it
    path = placement.save_maps(tmp_path / "other", pr2, {"right": BuiltMap(m.values, meta, m.witness)})
    with pytest.raises(MapError, match="lift 'head_pan_joint'.*does not hold.*fixed_joints: torso_lift_joint"):
        placement.open_map(path, "right", pr2)


@pytest.mark.slow
def test_info_shows_the_record(stored):
    proc = run("maps", "info", str(stored))
    assert proc.returncode == 0, proc.stderr
    assert f"torso {LIFT}: settings 0, 0.1, 0.2, 0.31 m (built at 0.15 m" in proc.stdout, proc.stdout


# -- views at other lift settings, against pinocchio ---------------------------------------------------------


def test_views_share_the_arrays(stored, pr2):
    rmap = placement.open_map(stored, "right", pr2)
    view = rmap.at_torso(0.31)
    assert view.torso_value == 0.31 and view.at_torso(0.15) is rmap and rmap.at_torso(0.31) is view
    assert rmap.at_torso(0.15) is rmap and view.at_torso(0.31) is view
    assert view.store is rmap.store and view.torso == rmap.torso and view.grid.shape == rmap.grid.shape
    view.load()
    assert rmap.in_memory  # read through the view, held once for both
    with pytest.raises(MapError, match=r"at 0.25 m; the map stands for 0, 0.1, 0.15, 0.2, 0.31 m"):
        rmap.at_torso(0.25)


@pytest.mark.slow
@pytest.mark.parametrize("value", VALUES)
def test_views_match_fk_with_the_lift_moved(stored, pr2, value):
    rmap = placement.open_map(stored, "right", pr2)
    view = rmap.at_torso(value)
    lifted = pr2.with_fixed({LIFT: value})
    a = pr2.arm("right")
    rng = np.random.default_rng(int(value * 100))
    qs = rng.uniform(a.lower, a.upper, size=(300, a.dof))
    T_r = np.array([pr2.tcp_pose("right", q) for q in qs])
    T_v = np.array([lifted.tcp_pose("right", q) for q in qs])
    # the lift moves the TCP rigidly, by what the view moves its grid
    moved = np.array(view.grid.origin) - np.array(rmap.grid.origin)
    assert np.abs(T_v[:, :3, 3] - T_r[:, :3, 3] - moved).max() <= 1e-9
    assert np.abs(T_v[:, :3, :3] - T_r[:, :3, :3]).max() <= 1e-9
    assert np.abs(moved - (value - 0.15) * np.array([0, 0, 1])).max() <= 1e-9
    v_view, v_ref = view.value(T_v), rmap.value(T_r)
    assert np.array_equal(v_view, v_ref) and np.count_nonzero(v_ref) >= 20
    if value != 0.15:
        # the reference map's answer at the lifted poses differs: the test can fail
        assert not np.array_equal(rmap.value(T_v), v_ref)
    # witness joints of the view's reached cells land in the same cell with the lift at value: cells of
    # plain samples and of completion samples (regenerated by IK steps on the stored grid)
    plain = rmap.meta["witness"]["plain_samples"]
    wit = rmap.witness.reshape(-1)
    reached = np.flatnonzero(rmap.values.reshape(-1) > 0)
    completed = reached[wit[reached] >= plain]
    assert completed.size and completed.size < reached.size
    cells = np.concatenate([reached[wit[reached] < plain][:5], rng.choice(completed, 10)])
    for T in view.grid.centre(cells):
        q = view.witness_q(T)
        assert q is not None
        assert view.grid.index(lifted.tcp_pose("right", q)[None])[0] == view.grid.index(T[None])[0]
