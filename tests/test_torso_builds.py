"""One map build per torso setting (a revolute torso pitch): each setting's map is the build of the robot
with the joint at that setting, stored beside the arm's own, opened by ``at_torso`` with its own grid and
witnesses (checked against pinocchio FK of the robot at that setting), and refused cleanly when the joint
or a value does not fit or a setting's map is missing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from support.cli import run
from support.fk import model_fk
from support.pitch_torso import HIGH, JOINT, LOW, pitch_torso_robot, write_pitch_torso

import placement
from placement import PlacementError
from placement.errors import MapError
from placement.maps.buildspec import TorsoSpec
from placement.maps.torso import check_torso
from placement.maps.torso_builds import build_torso_maps
from placement.storage.format import BuiltMap

VALUES = (0.0, 0.6)  # [rad]: upright (the preset's held value) and leaning forward
LEAN = f"arm@{JOINT}=0.6"
OPTIONS = {"samples": 100_000, "seed": 7, "resolution": 0.15, "bins": (8, 5, 8), "progress": False}


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    return pitch_torso_robot(tmp_path_factory.mktemp("pitch_torso"))


@pytest.fixture(scope="module")
def built(robot) -> dict[str, BuiltMap]:
    """The arm at both settings: 100k samples each, 0.15 m cells and a completion pass."""
    return build_torso_maps(robot, "arm", torso=TorsoSpec(JOINT, VALUES), completion=True, **OPTIONS)


@pytest.fixture(scope="module", params=["zarr", "hdf5"])
def stored(request, built, robot, tmp_path_factory) -> Path:
    name = "m.h5" if request.param == "hdf5" else "m"
    return placement.save_maps(tmp_path_factory.mktemp("builds") / name, robot, built, fmt=request.param)


@pytest.mark.slow
def test_each_setting_is_the_build_of_the_robot_at_it(built, robot):
    assert sorted(built) == ["arm", LEAN]
    leaning = robot.with_fixed({JOINT: 0.6})
    direct = placement.build_map(leaning, "arm", completion=True, **OPTIONS)
    m = built[LEAN]
    assert np.array_equal(m.values, direct.values) and m.witness is not None
    assert np.array_equal(m.witness, direct.witness)
    assert m.meta["setting"] == {"joint": JOINT, "value": 0.6, "unit": "rad"}
    assert m.meta["fixed_joints"] == {JOINT: 0.6} and "torso" not in m.meta
    # the arm's own map is the upright build, with the record; its own grid (the lean moves the reach)
    plain = placement.build_map(robot, "arm", completion=True, **OPTIONS)
    assert np.array_equal(built["arm"].values, plain.values)
    assert built["arm"].meta["grid"] != m.meta["grid"]
    record = built["arm"].meta["torso"]
    assert record["kind"] == "per_setting" and record["unit"] == "rad" and record["shift"] is None
    assert record["arrays"] == ["arm", LEAN] and record["velocity"] == pytest.approx(0.4)


def _fk(robot, arm: str, torso: float, q: np.ndarray) -> np.ndarray:
    """(4, 4) TCP in the base frame by pinocchio FK with the torso at ``torso`` [rad] (the test's reference)."""
    a = robot.arm(arm)
    data = model_fk(robot, {JOINT: torso, **dict(zip(a.joints, q))})
    base = data.oMf[robot.model.getFrameId(robot.base_frame)]
    tip = data.oMf[robot.model.getFrameId(a.tip_frame)]
    return (base.inverse() * tip).homogeneous @ a.tcp_offset


@pytest.mark.slow
@pytest.mark.parametrize("value", VALUES)
def test_views_are_the_settings_maps_and_their_witnesses_land_in_their_cells(stored, robot, value):
    rmap = placement.open_map(stored, "arm", robot)
    view = rmap.at_torso(value)
    assert view.torso_value == value and view.torso == rmap.torso and rmap.at_torso(value) is view
    assert view.at_torso(0.0) is rmap and view.robot.fixed_joints == {JOINT: value}
    if value != 0.0:
        assert view.array == LEAN and view.grid != rmap.grid
        assert view.value_quantiles == view.meta["value_quantiles"] != rmap.value_quantiles
    values, wit = view.values.reshape(-1), view.witness.reshape(-1)
    reached = np.flatnonzero(values > 0)
    plain = view.meta["witness"]["plain_samples"]
    completed = reached[wit[reached] >= plain]
    assert completed.size and completed.size < reached.size
    rng = np.random.default_rng(3)
    cells = np.concatenate([rng.choice(reached[wit[reached] < plain], 15), rng.choice(completed, 15)])
    elsewhere = 0
    for T in view.grid.centre(cells):
        q = view.witness_q(T)
        assert q is not None
        assert view.grid.index(_fk(robot, "arm", value, q)[None])[0] == view.grid.index(T[None])[0]
        elsewhere += view.grid.index(_fk(robot, "arm", 0.6 - value, q)[None])[0] != view.grid.index(T[None])[0]
    assert elsewhere >= 20  # at the other setting the same joints land elsewhere: the test can fail


def test_an_unknown_setting_is_refused(stored, robot):
    rmap = placement.open_map(stored, "arm", robot)
    with pytest.raises(MapError, match=r"no map for torso_pitch at 0.3 rad; the map stands for 0, 0.6 rad$"):
        rmap.at_torso(0.3)


@pytest.mark.slow
def test_a_missing_setting_map_is_refused(built, robot, tmp_path):
    path = placement.save_maps(tmp_path / "m", robot, {"arm": built["arm"]})
    with pytest.raises(MapError, match=rf"names the array '{LEAN}'.*torso.arrays.*rebuild"):
        placement.open_map(path, "arm", robot)


def test_a_setting_array_is_not_an_arm(stored, robot):
    with pytest.raises(MapError, match=r"no map for arm 'arm@torso_pitch=0.6'; it has: arm$"):
        placement.open_map(stored, LEAN, robot)


def _refused(robot, arms, spec: TorsoSpec, *words: str) -> None:
    with pytest.raises(PlacementError) as info:
        check_torso(robot, arms, spec, "build spec s.yaml: torso")
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("build spec s.yaml: torso"), msg
    for w in words:
        assert w in msg, msg


def test_the_joint_and_values_are_checked(robot, tmp_path):
    _refused(robot, ["arm"], TorsoSpec(JOINT, (0.0, 0.9)), "torso.values[1]", "0.9 rad", f"[{LOW:g}, {HIGH:g}] rad")
    _refused(robot, ["arm"], TorsoSpec("joint_1", (0.0,)), "torso.joint", "'joint_1' is not a fixed joint")
    two = pitch_torso_robot(tmp_path / "two", second_arm=True)
    check_torso(two, ["arm"], TorsoSpec(JOINT, VALUES))  # it carries this arm
    _refused(two, ["arm", "base_arm"], TorsoSpec(JOINT, VALUES), "does not carry arm 'base_arm'", "b_joint_1")
    leaning_base = pitch_torso_robot(tmp_path / "chest", base_frame="chest")
    _refused(leaning_base, ["arm"], TorsoSpec(JOINT, VALUES), "torso.joint", "moves the base frame 'chest'")
    # one build per setting checks self-collision at each setting: accepted (a shifted map refuses it)
    (s,) = check_torso(robot, ["arm"], TorsoSpec(JOINT, VALUES), self_collision=True).values()
    assert s.kind == "per_setting" and s.unit == "rad" and s.allowed == VALUES


def test_build_map_alone_refuses_a_per_setting_joint(robot):
    with pytest.raises(
        PlacementError, match=r"torso.joint: 'torso_pitch' needs one build per setting.*build_torso_maps"
    ):
        placement.build_map(robot, "arm", torso=TorsoSpec(JOINT, VALUES), **OPTIONS)


@pytest.mark.slow
def test_cli_builds_each_setting_and_info_shows_them(tmp_path):
    preset = write_pitch_torso(tmp_path / "robot")
    spec = tmp_path / "s.yaml"
    spec.write_text(
        yaml.safe_dump(
            {
                "robot": str(preset),
                "samples": 20_000,
                "resolution": 0.25,
                "bins": [4, 3, 4],
                "torso": {"joint": JOINT, "values": [0.3, 0.6]},
            }
        )
    )
    proc = run("maps", "build", "--spec", str(spec), "--out", str(tmp_path / "m"), "-q")
    assert proc.returncode == 0, proc.stderr
    assert (
        "torso_pitch is a revolute joint: 3 builds, one per setting (torso_pitch=0 rad; torso_pitch=0.3 rad; "
        "torso_pitch=0.6 rad): the build takes 3 times as long"
    ) in proc.stderr
    assert "(3 builds, one per torso setting)" in proc.stdout, proc.stdout
    proc = run("maps", "info", str(tmp_path / "m"))
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "torso torso_pitch: settings 0.3, 0.6 rad, one build per setting (the arm's own at 0 rad), 0.4 rad/s" in out
    for v in ("0.3", "0.6"):
        assert f"setting torso_pitch = {v} rad (array arm@torso_pitch={v}): built" in out, out
    assert out.count("  arm ") == 1  # the settings' arrays are not listed as arms
    proc = run("maps", "verify", str(tmp_path / "m"))
    assert proc.returncode == 0 and proc.stdout.count("all equal (bitwise)") == 3, proc.stdout
