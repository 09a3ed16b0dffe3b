"""Property tests of the preset loader: random and mutated presets give a valid Robot or one RobotError line.

Mutations start from the built-in PR2 preset and the ARMAR-6 fixture preset:
keys deleted or added, values replaced by other types, NaN, infinities, other
joint and frame names of the robot, lists shortened, lengthened, reordered.
Text mutations edit the PR2 YAML file itself (invalid YAML, duplicate keys).
Anything but a :class:`RobotError` (or a valid robot) fails the test.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from support.presets import pr2_mapping
from support.robots import ARMAR6_URDF, armar6_spec

import placement
from placement.errors import RobotError
from placement.kernels.kinematics import fk_jacobian_batch
from placement.robots.preset import PRESET_DIR
from placement.robots.spec import ARM_KEYS, TOP_KEYS

SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
WORKDIR = Path(tempfile.mkdtemp(prefix="preset-properties-"))
IGNORING = {
    **pr2_mapping(),
    "ignore_collisions": [["r_wrist_roll_link", "r_forearm_link"], ["base_link", "torso_lift_link"]],
}
BASES = [pr2_mapping(), IGNORING] + ([armar6_spec()] if ARMAR6_URDF.is_file() else [])


def _model_names() -> list[str]:
    names = set()
    for base in BASES:
        model = placement.load_robot(write(base)).model
        names.update(model.names[1:])
        names.update(f.name for f in model.frames)
    return sorted(names)


def write(spec) -> Path:
    path = WORKDIR / "preset.yaml"
    path.write_text(spec if isinstance(spec, str) else yaml.safe_dump(spec, sort_keys=False, allow_unicode=True))
    return path


NAMES = _model_names()
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**30), 10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-4, 4),
    st.text(max_size=8),
    st.sampled_from(NAMES),
    st.sampled_from(sorted(TOP_KEYS) + sorted(ARM_KEYS)),
)
# one level of nesting is enough to reach every branch of the checks and keeps an example cheap
junk = (
    scalars
    | st.lists(scalars, max_size=9)
    | st.dictionaries(scalars, scalars | st.lists(scalars, max_size=8), max_size=3)
)


def paths(node, prefix=()):
    """Every (path, value) inside a parsed document, the root included."""
    yield prefix, node
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield from paths(v, prefix + (k,))


def mutate(data, doc):
    """Apply one random edit to ``doc`` (in place; returns the new root)."""
    path, value = data.draw(st.sampled_from(list(paths(doc))))
    op = data.draw(st.sampled_from(["replace", "name", "number", "delete", "insert", "reorder", "wrap"]))
    new = value
    if op == "replace":
        new = data.draw(junk)
    elif op == "name":
        new = data.draw(st.sampled_from(NAMES))
    elif op == "number" and isinstance(value, (int, float)) and not isinstance(value, bool):
        new = data.draw(st.sampled_from([math.nan, math.inf, -value, value * 10, value + 1e-3, 0, 1e308 * 10]))
    elif op == "delete" and isinstance(value, (dict, list)) and value:
        key = data.draw(st.sampled_from(list(value.keys()) if isinstance(value, dict) else range(len(value))))
        del value[key]
    elif op == "insert" and isinstance(value, dict):
        value[data.draw(st.sampled_from(sorted(TOP_KEYS) + sorted(ARM_KEYS)) | scalars)] = data.draw(junk)
    elif op == "insert" and isinstance(value, list):
        item = data.draw(st.sampled_from(value) if value else junk)
        value.insert(data.draw(st.integers(0, len(value))), item)
    elif op == "reorder" and isinstance(value, list):
        new = data.draw(st.permutations(value))
    elif op == "wrap":
        new = [value]
    if new is value:
        return doc
    if not path:
        return new
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    parent[path[-1]] = new
    return doc


def check(spec) -> str:
    """Load ``spec``: either a RobotError of one line naming the file, or a robot that keeps its promises.

    Returns the outcome ("valid robot" or the error class) for hypothesis' statistics.
    """
    path = write(spec)
    try:
        robot = placement.load_robot(path)
    except RobotError as exc:
        msg = str(exc)
        assert "\n" not in msg and msg.startswith(f"{path}: "), msg
        return f"error: {type(exc).__name__}"
    assert robot.arms and min(robot.footprint_radius, robot.v_max, robot.omega_max) > 0
    assert all(math.isfinite(v) for v in (robot.footprint_radius, robot.v_max, robot.omega_max))
    links = {f.name for f in robot.model.frames if f.type == pin.FrameType.BODY}
    assert all(len(pair) == 2 and pair <= links for pair in robot.ignore_collisions)
    for name in robot.arms:
        a = robot.arm(name)
        assert a.dof >= 6 and len(set(a.joints)) == a.dof and not set(a.joints) & set(robot.fixed_joints)
        assert np.all(np.isfinite(a.home)) and np.all(a.continuous | ((a.lower <= a.home) & (a.home <= a.upper)))
        R = a.tcp_offset[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
        assert a.chain.link_T.shape == (a.dof, 4, 4) and np.all(np.isfinite(a.chain.link_T))
        T, J = fk_jacobian_batch(a.home[None], a.chain.link_T, a.chain.axis, a.chain.kind, a.chain.tip_T)
        assert np.all(np.isfinite(T)) and np.all(np.isfinite(J))
    return "valid robot"


@SETTINGS
@given(st.data())
def test_mutated_presets(data):
    doc = yaml.safe_load(yaml.safe_dump(data.draw(st.sampled_from(BASES))))
    for _ in range(data.draw(st.integers(1, 3))):
        doc = mutate(data, doc)
    event(check(doc))


@SETTINGS
@given(
    st.dictionaries(st.sampled_from(sorted(TOP_KEYS)) | scalars, junk, max_size=9),
    st.dictionaries(st.sampled_from(sorted(ARM_KEYS)) | scalars, junk, max_size=5),
)
def test_random_presets(top, arm):
    """Random documents with the preset's keys (and others); half of them carry a random arm."""
    if arm:
        top = {**top, "arms": {"right": arm}}
    event(check(top))


PR2_TEXT = (PRESET_DIR / "pr2.yaml").read_text()


@SETTINGS
@given(st.data())
def test_mutated_preset_text(data):
    """Edits of the PR2 YAML text: cut, repeated or altered lines, stray characters."""
    lines = PR2_TEXT.splitlines(keepends=True)
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(lines) - 1))
        op = data.draw(st.sampled_from(["delete", "duplicate", "insert", "truncate"]))
        if op == "delete":
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "insert":
            j = data.draw(st.integers(0, len(lines[i])))
            stray = data.draw(st.sampled_from(list(":-[]{}#&*!|>'\"%@`, \t\n")) | st.text(max_size=3))
            lines[i] = lines[i][:j] + stray + lines[i][j:]
        else:
            lines[i] = lines[i][: data.draw(st.integers(0, len(lines[i])))] + "\n"
        if not lines:
            break
    event(check("".join(lines)))


@pytest.mark.parametrize("base", range(len(BASES)))
def test_the_bases_are_valid(base):
    """The mutations start from valid presets (else every example would be an error)."""
    assert check(BASES[base]) == "valid robot"
    assert placement.load_robot(write(BASES[base])).arms == list(BASES[base]["arms"])
