"""URDF vectors written with commas are read as meant, with a warning (the maker's ARMAR-6 in the
``armar`` package writes ``rpy="1.5707963, 1.3089969 1.5707963"``, which urdfdom refuses whole); a
malformed number elsewhere is one line naming the joint or link, never urdfdom's C++ errors. The
maker's ARMAR-6 (a fixed hand, no fingers) gets its TCP out in its hand."""

from __future__ import annotations

import importlib.util

import pytest
from hypothesis import given
from hypothesis import strategies as st
from support.toy_robot import arm_urdf

from placement.errors import RobotError
from placement.robots.description import readable_urdf
from placement.robots.onboarding.propose import propose


def test_a_comma_vector_is_spaced_and_said():
    text = '<joint name="j"><origin rpy="1.5707963, 1.3089969 1.5707963" xyz="0,0 , 0.1"/></joint>'
    got, notes = readable_urdf(text)
    assert got == '<joint name="j"><origin rpy="1.5707963 1.3089969 1.5707963" xyz="0 0 0.1"/></joint>'
    assert len(notes) == 2 and "rpy '1.5707963, 1.3089969 1.5707963'" in notes[0]


def test_what_is_not_three_numbers_stays_as_written():
    for text in ('<origin rpy="1, 2"/>', '<origin xyz="a, b, c"/>', '<origin xyz="1 2 3"/>', '<mesh scale="1,2,3"/>'):
        assert readable_urdf(text) == (text, [])


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
separators = st.sampled_from([", ", ",", " ,", " , ", "  "])


@given(st.tuples(finite, finite, finite), separators, separators, st.sampled_from(["xyz", "rpy"]))
def test_three_numbers_come_back_exactly(values, s1, s2, attr):
    text = f'<origin {attr}="{values[0]!r}{s1}{values[1]!r}{s2}{values[2]!r}"/>'
    got, notes = readable_urdf(text)
    inner = got.split('"')[1]
    assert [float(v) for v in inner.split()] == list(values)
    assert len(notes) == (1 if "," in text else 0)


@given(st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=200))
def test_any_text_without_commas_is_unchanged(text):
    text = text.replace(",", "")
    assert readable_urdf(text) == (text, [])


@pytest.mark.parametrize(
    "change, words",
    [
        (
            ('<axis xyz="0 1 0"/>', '<axis xyz="0 1 zero"/>'),
            ["toy.urdf: joint 'joint_", "axis xyz '0 1 zero' is not 3 numbers"],
        ),
        (('<limit lower="-2"', '<limit lower="-2deg"'), ["joint 'joint_1'", "limit lower '-2deg' is not a number"]),
    ],
)
def test_a_malformed_number_names_its_joint(tmp_path, capfd, change, words):
    urdf = tmp_path / "toy.urdf"
    text = arm_urdf()
    assert change[0] in text
    urdf.write_text(text.replace(*change, 1))
    with pytest.raises(RobotError) as err:
        propose(urdf)
    assert all(w in str(err.value) for w in words), str(err.value)
    assert capfd.readouterr().err == ""


@pytest.mark.skipif(importlib.util.find_spec("armar") is None, reason="the armar package is not installed")
def test_the_makers_armar6_initialises_first_try(capfd):
    import armar

    p = propose(armar.get_path_to_urdf_file("armar6"))
    assert sorted(a.name for a in p.arms) == ["left", "right"]
    assert sum("is read as '1.5707963 1.3089969 1.5707963'" in w for w in p.warnings) == 2, p.warnings
    assert p.base.footprint is not None  # the platform's meshes resolve through package://armar/...
    assert "Error" not in capfd.readouterr().err
    for arm in p.arms:
        # no fingers, no tool frame: the approach points to the fixed hand ('hand_fixed_r*', mounted
        # 0.26 m out along the wrist's z), not along the last joint's axis (its y: 90 degrees off)
        assert arm.tcp.tip_frame.startswith("arm_t8_r") and "fixed hand" in arm.tcp.how, arm.tcp.how
        assert float(arm.tcp.offset[:3, 2] @ [0.0, 0.0, 1.0]) > 0.99, arm.tcp.offset
        assert 0.2 < arm.tcp.offset[2, 3] < 0.45  # near the hand's far end, where the fingertips are
