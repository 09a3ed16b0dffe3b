"""``package://NAME/...`` mesh paths resolve as a maker's package lays them out, in one place
(``placement.robots.description.package_dirs``) for onboarding, the collision check and the viewer:
a Python package whose URDF sits three folders below the package (the ``armar`` wheel's layout), a
sourced ROS 2 workspace (``AMENT_PREFIX_PATH``'s ``share``), and ``ROS_PACKAGE_PATH``."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from support.toy_robot import arm_urdf

from placement.collision.robot import resolve_mesh
from placement.robots.description import package_dirs
from placement.robots.onboarding.propose import propose


def _stl(path: Path) -> None:
    """A 0.6 x 0.5 x 0.3 m box's 12 triangles as binary STL (the toy robot's base)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    hx, hy, hz = 0.3, 0.25, 0.15
    c = np.array([[x, y, z] for x in (-hx, hx) for y in (-hy, hy) for z in (-hz, hz)], dtype=np.float32)
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6)]
    faces += [(0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    rec = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = c[np.array(faces)]
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(faces)) + rec.tobytes())


LAYOUTS = {
    # (where the URDF is, where the mesh is, the environment), under tmp_path
    "python_package": ("site/acme/description/urdf/toy.urdf", "site/acme/description/meshes/base.stl", {}),
    "ament_prefix": (
        "elsewhere/toy.urdf",
        "ws/install/acme/share/acme/description/meshes/base.stl",
        {"AMENT_PREFIX_PATH": "ws/install/acme"},
    ),
    "ros_package_path": (
        "elsewhere/toy.urdf",
        "src/acme/description/meshes/base.stl",
        {"ROS_PACKAGE_PATH": "src/acme"},
    ),
}


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_a_makers_mesh_path_resolves(tmp_path, monkeypatch, layout):
    urdf_at, mesh_at, env = LAYOUTS[layout]
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, str(tmp_path / v))
    urdf = tmp_path / urdf_at
    urdf.parent.mkdir(parents=True)
    _stl(tmp_path / mesh_at)
    text = arm_urdf().replace(
        '<box size="0.6 0.5 0.3"/>', '<mesh filename="package://acme/description/meshes/base.stl"/>'
    )
    urdf.write_text(text)
    found = resolve_mesh("package://acme/description/meshes/base.stl", urdf, package_dirs(urdf))
    assert found is not None and found.resolve() == (tmp_path / mesh_at).resolve()
    p = propose(urdf)
    assert not any("could not be found" in w or "left out" in w for w in p.warnings), p.warnings
    # the footprint comes from the mesh: the 0.6 x 0.5 m box's outline
    assert p.base.footprint is not None
    xs, ys = p.base.footprint[:, 0], p.base.footprint[:, 1]
    assert max(xs) - min(xs) == pytest.approx(0.6, abs=0.02) and max(ys) - min(ys) == pytest.approx(0.5, abs=0.02)


def test_a_mesh_without_its_package_is_named(tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(arm_urdf().replace('<box size="0.6 0.5 0.3"/>', '<mesh filename="package://nowhere/base.stl"/>'))
    p = propose(urdf)
    assert any("package://nowhere/base.stl" in w for w in p.warnings), p.warnings
