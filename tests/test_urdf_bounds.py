"""Odd but valid URDFs are refused in one line before pinocchio parses them: a chain of fixed joints
5,000 deep (it overflowed the C++ stack: exit 139), 20,000 links (minutes), a joint 1e308 m away (a
LinAlgError traceback). Real robots stay far inside the bounds (example-robot-data's load)."""

from __future__ import annotations

import pytest
from support.cli import assert_one_line_error, run

from placement.robots.description import MAX_DEPTH, MAX_LINKS, MAX_MOVING_JOINTS

pytestmark = pytest.mark.slow


def chain(n: int, xyz: str = "0 0 0.01", boxes: bool = False, kind: str = "fixed") -> str:
    body = '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>' if boxes else ""
    limit = '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>' if kind != "fixed" else ""
    out = ['<robot name="odd">', '<link name="l0"/>']
    for i in range(1, n + 1):
        out.append(f'<link name="l{i}">{body}</link>')
        out.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/><child link="l{i}"/><origin xyz="{xyz}"/>'
            f"{limit}</joint>"
        )
    return "\n".join([*out, "</robot>"])


@pytest.mark.parametrize(
    "text, words",
    [
        (chain(5000), [f"more than the {MAX_LINKS:,} a robot may have"]),
        (chain(MAX_LINKS - 10), [f"a chain of more than {MAX_DEPTH:,} joints"]),
        (chain(20_000, boxes=True), ["20,001 links"]),
        (chain(3, xyz="1e308 0 0"), ["joint 'j1'", "within +-10000 m of its parent link"]),
        (chain(3, xyz="nan 0 0"), ["joint 'j1'", "not three finite numbers"]),
        (
            chain(MAX_DEPTH - 1, kind="revolute", boxes=True),
            [f"{MAX_DEPTH - 1} moving (non-fixed) joints", f"the {MAX_MOVING_JOINTS} a robot"],
        ),
    ],
    ids=["deep_fixed", "deep_below_link_cap", "many_links", "far_joint", "nan_joint", "many_moving_joints"],
)
def test_an_odd_urdf_is_refused_in_one_line(tmp_path, text, words):
    path = tmp_path / "odd.urdf"
    path.write_text(text)
    assert_one_line_error(run("robots", "init", str(path)), *words)
