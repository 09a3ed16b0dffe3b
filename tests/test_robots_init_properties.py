"""Property tests of the description reader of `placement robots init`: random bytes and mutated valid
URDF/xacro documents give either a parsed description (whose tree analysis runs) or a one-line
RobotError, never any other exception."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.toy_robot import arm_urdf, arm_xacro

from placement.errors import RobotError
from placement.robots.onboarding.tree import analyse
from placement.robots.onboarding.urdf import load_description

FOLDER = Path(tempfile.mkdtemp(prefix="robots-init-props-"))
VALID = arm_urdf()
VALID_XACRO = arm_xacro()
#: replacement values for attribute values and numbers, the awkward ones included
VALUES = st.sampled_from(
    [
        "",
        "nan",
        "inf",
        "-inf",
        "1e308",
        "-1e400",
        "0",
        "x",
        "1 2",
        "${undefined}",
        "$(find nothing)",
        "<",
        "&amp;",
        "joint_1",
        "base_link",
        "continuous",
        "fixed",
        "floating",
        "planar",
        "prismatic",
    ]
) | st.text(max_size=5)


@st.composite
def mutated(draw, text: str) -> str:
    """``text`` with 1-3 edits: a slice deleted or duplicated, a quoted value replaced, random text inserted."""
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["delete", "duplicate", "value", "insert"]))
        i = draw(st.integers(0, len(text)))
        j = min(len(text), i + draw(st.integers(0, 120)))
        if kind == "delete":
            text = text[:i] + text[j:]
        elif kind == "duplicate":
            text = text[:j] + text[i:j] + text[j:]
        elif kind == "value":
            quotes = [k for k, c in enumerate(text) if c == '"']
            if len(quotes) >= 2:
                k = draw(st.integers(0, len(quotes) // 2 - 1)) * 2
                a, b = quotes[k], quotes[k + 1]
                text = text[: a + 1] + draw(VALUES) + text[b:]
        else:
            text = text[:i] + draw(st.text(max_size=10)) + text[i:]
    return text


def check(name: str, data: bytes) -> None:
    path = FOLDER / name
    path.write_bytes(data)
    try:
        d = load_description(path)
    except RobotError as exc:
        assert "\n" not in str(exc)
        return
    analyse(d.model, d.mimic, pin.neutral(d.model))


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated(VALID))
def test_mutated_urdf(text):
    check("m.urdf", text.encode("utf-8", "surrogatepass"))


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated(VALID_XACRO))
def test_mutated_xacro(text):
    check("m.urdf.xacro", text.encode("utf-8", "surrogatepass"))


@settings(deadline=None)
@given(st.binary(max_size=200) | st.text(max_size=200).map(lambda t: t.encode("utf-8", "surrogatepass")))
def test_random_bytes(data):
    check("r.urdf", data)
