"""The build spec's torso postures (``torso: {joints, postures}``): every bad value is one PlacementError
line naming the key, from the parser (keys, lengths, repeats) and from the check against the robot
(unknown joint, a value outside its URDF limits), before any sampling; hypothesis throws junk at the
parser; the CLI builds both postures and ``maps info`` shows them."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from support.cli import assert_one_line_error, run
from support.knee_torso import CROUCH, HIP, KNEE, UPRIGHT, knee_torso_robot, write_knee_torso

from placement import PlacementError
from placement.maps.buildspec import TorsoSpec, parse_build_spec_text, parse_torso
from placement.maps.torso import check_torso
from placement.maps.torso_builds import build_torso_maps

GOOD = {"joints": [HIP, KNEE], "postures": [[0.0, 0.0], [0.9, -0.9]]}


def test_a_posture_spec_keeps_the_spec_order():
    spec = parse_build_spec_text(
        yaml.safe_dump({"robot": "x", "torso": {"joints": [HIP, KNEE], "postures": [[0.9, -0.9], [0, 0]]}})
    )
    assert spec.torso == TorsoSpec(HIP, (0.0, 1.0), (HIP, KNEE), ((0.9, -0.9), (0.0, 0.0)))
    # the one-joint form is unchanged: no joints, no postures
    assert parse_torso({"joint": "j", "values": [0.2, 0.1]}, "torso") == TorsoSpec("j", (0.1, 0.2))


@pytest.mark.parametrize(
    ("torso", "message"),
    [
        ({**GOOD, "joints": [HIP, HIP]}, r"torso\.joints\[1\]: 'hip_pitch' is given twice \(joints\[0\]\)"),
        ({**GOOD, "postures": [[0.0, 0.0], [0.7]]}, r"torso\.postures\[1\] must be a list of 2 values"),
        ({**GOOD, "postures": [[0.0, 0.0, 0.1]]}, r"torso\.postures\[0\] must be a list of 2 values"),
        ({**GOOD, "postures": [[0.1, 0.2], [0.1, 0.2]]}, r"torso\.postures\[1\] is given twice \(postures\[0\]"),
        # 1 ulp apart: the same posture, which would be built twice
        (
            {**GOOD, "postures": [[0.1, 0.2], [0.1, float(np.nextafter(0.2, 1))]]},
            r"torso\.postures\[1\] is given twice \(postures\[0\]; postures within 1e-09",
        ),
        ({**GOOD, "postures": [[0.0, "x"]]}, r"torso\.postures\[0\]\[1\] must be a setting"),
        ({**GOOD, "postures": [[0.0, 11.0]]}, r"torso\.postures\[0\]\[1\] must be a setting .* from -10 to 10"),
        ({**GOOD, "postures": []}, r"torso\.postures must be a list of 1 to 16 postures"),
        ({**GOOD, "joints": []}, r"torso\.joints must be a list of 1 to 16 joint names"),
        ({**GOOD, "joints": [HIP, ""]}, r"torso\.joints\[1\] must be a name"),
        ({**GOOD, "joint": HIP}, r"torso\.joint: give either joint and values .* or joints and postures"),
        ({**GOOD, "values": [0.1]}, r"torso\.values: give either joint and values"),
        ({**GOOD, "speed": 1}, r"torso: unknown key 'speed'; allowed: joints, postures"),
        ({"joints": [HIP, KNEE]}, r"torso\.postures is missing"),
        ({"postures": [[0.0]]}, r"torso\.joints is missing"),
    ],
)
def test_bad_postures_are_one_line_naming_the_key(torso, message):
    with pytest.raises(PlacementError, match=message) as err:
        parse_build_spec_text(yaml.safe_dump({"robot": "x", "torso": torso}), "build spec s.yaml")
    assert "\n" not in str(err.value) and str(err.value).startswith("build spec s.yaml: torso")


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(
    st.dictionaries(
        st.sampled_from(["joints", "postures", "joint", "values", "x"]),
        st.recursive(
            st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=4),
            lambda inner: st.lists(inner, max_size=3),
            max_leaves=8,
        ),
        max_size=3,
    )
)
def test_junk_postures_are_accepted_or_one_line_errors(torso):
    try:
        spec = parse_torso(torso, "torso")
    except PlacementError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("torso")
    else:
        if spec.joints:  # postures: indexed in the spec's order, one value per joint
            assert spec.values == tuple(float(i) for i in range(len(spec.postures)))
            assert all(len(p) == len(spec.joints) for p in spec.postures) and spec.joint == spec.joints[0]


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    return knee_torso_robot(tmp_path_factory.mktemp("knee_spec"))


@pytest.mark.parametrize(
    ("torso", "message"),
    [
        (
            {"joints": [HIP, "ankle_pitch"], "postures": [[0.0, 0.0]]},
            r"torso\.joints\[1\]: 'ankle_pitch' is not a fixed joint of robot 'knee_torso' "
            r"\(fixed_joints: hip_pitch, knee_pitch\)",
        ),
        ({"joints": [HIP, "joint_2"], "postures": [[0.0, 0.0]]}, r"torso\.joints\[1\]: 'joint_2' is not a fixed joint"),
        (
            {"joints": [HIP, KNEE], "postures": [[0.0, 0.0], [1.5, -0.9]]},
            r"torso\.postures\[1\]\[0\]: 1\.5 rad is outside the URDF limits \[-0\.3, 1\] rad of 'hip_pitch'",
        ),
        (
            {"joints": [HIP, KNEE], "postures": [[0.0, 0.5]]},
            r"torso\.postures\[0\]\[1\]: 0\.5 rad is outside the URDF limits \[-1, 0\.3\] rad of 'knee_pitch'",
        ),
    ],
)
def test_postures_are_checked_against_the_robot_before_sampling(robot, torso, message):
    spec = parse_torso(torso, "torso")
    with pytest.raises(PlacementError, match=message) as err:
        check_torso(robot, ["arm"], spec)
    assert "\n" not in str(err.value)
    with pytest.raises(PlacementError, match=message):  # the builder checks before its first sample
        build_torso_maps(robot, "arm", torso=spec, samples=10**11, progress=False)


def test_the_preset_posture_is_built_when_not_asked_for(robot):
    """Postures without the preset's: the arm's own map is still the preset's, at index k."""
    t = check_torso(robot, ["arm"], parse_torso({"joints": [HIP, KNEE], "postures": [list(CROUCH)]}, "torso"))["arm"]
    assert t.values == (0.0,) and t.reference == 1.0 and t.allowed == (0.0, 1.0)
    assert t.held(1.0) == dict(zip((HIP, KNEE), UPRIGHT)) and t.arrays == ("arm@posture=0",)
    assert t.array("arm", 1.0) == "arm"


@pytest.mark.slow
def test_cli_builds_each_posture_and_info_shows_them(tmp_path):
    preset = write_knee_torso(tmp_path / "robot")
    spec = tmp_path / "s.yaml"
    spec.write_text(
        yaml.safe_dump({"robot": str(preset), "samples": 20_000, "resolution": 0.25, "bins": [4, 3, 4], "torso": GOOD})
    )
    proc = run("maps", "build", "--spec", str(spec), "--out", str(tmp_path / "m"), "-q")
    assert proc.returncode == 0, proc.stderr
    proc = run("maps", "info", str(tmp_path / "m"))
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert (
        "torso hip_pitch+knee_pitch: postures 0 (hip_pitch=0 rad, knee_pitch=0 rad); 1 (hip_pitch=0.9 rad, "
        "knee_pitch=-0.9 rad), one build per posture (the arm's own at hip_pitch=0 rad, knee_pitch=0 rad), "
        "0.4 rad/s, 0.7 rad/s"
    ) in out, out
    assert "setting posture 1 (hip_pitch=0.9, knee_pitch=-0.9) (array arm@posture=1): built" in out, out
    assert out.count("  arm ") == 1  # the posture's array is not listed as an arm
    proc = run("maps", "verify", str(tmp_path / "m"))
    assert proc.returncode == 0 and proc.stdout.count("all equal (bitwise)") == 2, proc.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"robot": str(preset), "torso": {"joints": [HIP, KNEE], "postures": [[2.0, 0.0]]}}))
    proc = run("maps", "build", "--spec", str(bad), "--out", str(tmp_path / "n"), "-q")
    assert_one_line_error(proc, "torso.postures[0][0]: 2 rad is outside the URDF limits [-0.3, 1] rad of 'hip_pitch'")
