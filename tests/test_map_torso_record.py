"""A torso setting a map holds is checked against the robot when the map opens, and a bad one is
named as the map's (its path and the record's key), not as the preset's."""

from __future__ import annotations

from pathlib import Path

import pytest

from placement import MapError
from placement.maps.opening import check_settings
from placement.maps.torso import TorsoSettings

LIFT = "torso_lift_joint"


def test_settings_within_the_urdf_limits_pass(pr2):
    check_settings(Path("maps/pr2"), "right", TorsoSettings(LIFT, (0.0, 0.2), 0.0, (0.0, 0.0, 1.0), 0.013), pr2)


@pytest.mark.parametrize("bad", [5.0, -0.5, float("nan")])
def test_a_setting_outside_the_limits_is_the_maps(pr2, bad):
    t = TorsoSettings(LIFT, (0.0, bad), 0.0, (0.0, 0.0, 1.0), 0.013)
    with pytest.raises(MapError) as err:
        check_settings(Path("maps/pr2"), "right", t, pr2)
    text = str(err.value)
    assert text.startswith("maps/pr2: the map of arm 'right' holds torso.values[1]") and "URDF limits" in text
    assert "rebuild the map" in text and "presets" not in text


def test_a_posture_joint_the_preset_does_not_hold_is_named(pr2):
    t = TorsoSettings("r_elbow_flex_joint", (0.0,), 0.0, None, 1.0, "index", (), ("r_elbow_flex_joint",), ((0.0,),))
    with pytest.raises(MapError, match=r"maps/pr2: .*'r_elbow_flex_joint', which is no fixed joint of preset 'pr2'"):
        check_settings(Path("maps/pr2"), "right", t, pr2)
