"""What a maker's description package holds and ROS resolves for it, without ROS: ``$(find PKG)``
in a xacro, and meshes qhull cannot wrap (a flat marker plate), which crashed the process."""

from __future__ import annotations

from pathlib import Path

import coal
import numpy as np
import pytest
from support.toy_robot import arm_xacro

from placement.collision.robot import convex_hull, spans_volume
from placement.errors import PlacementError
from placement.robots.description import read_description


def mesh(vertices: list[list[float]], triangles: list[list[int]]) -> coal.BVHModelOBBRSS:
    m = coal.BVHModelOBBRSS()
    m.beginModel(len(triangles), len(vertices))
    m.addVertices(np.array(vertices, dtype=float))
    m.addTriangles(np.array(triangles, dtype=np.int32))
    m.endModel()
    return m


def test_a_flat_mesh_is_its_own_bound_and_a_solid_one_gets_its_hull():
    """The Stretch's ArUco plates are 4 vertices in a plane: coal's qhull ended the process on them
    (a segfault in ``robots init``); now they are their own bound, and a tetrahedron gets its hull."""
    plate = mesh([[0, 0, 0], [0.06, 0, 0], [0.06, 0.06, 0], [0, 0.06, 0]], [[0, 1, 2], [0, 2, 3]])
    assert convex_hull(plate) == (plate, True)
    tetra = mesh([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
    hull, same = convex_hull(tetra)
    assert not same and hull.num_points == 4


@pytest.mark.parametrize(
    "vertices, solid",
    [
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], True),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], False),  # a plane
        ([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3], [4, 4, 4]], False),  # a line
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], False),  # too few
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.nan]], False),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0.5, 1e-8]], False),  # thinner than a micrometre
        ([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 1e-5]], True),  # a thin plate, 10 um thick
    ],
)
def test_spans_volume(vertices, solid):
    assert spans_volume(np.array(vertices, dtype=float)) is solid


def _package(root: Path, name: str, files: dict[str, str]) -> Path:
    (root / name).mkdir(parents=True)
    (root / name / "package.xml").write_text(f"<package><name>{name}</name></package>")
    for rel, text in files.items():
        (root / name / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / name / rel).write_text(text)
    return root / name


def test_find_resolves_packages_beside_the_robots_own(tmp_path, monkeypatch):
    """A vendor xacro that includes its own files and a sensor package's by ``$(find PKG)`` expands
    without a sourced ROS 2 when the packages sit side by side (as in a workspace's ``src``)."""
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    sensor = '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="camera_link"/></robot>'
    _package(tmp_path / "src", "cam_description", {"urdf/cam.xacro": sensor})
    body = arm_xacro().replace(
        '<link name="base_footprint"/>',
        '<link name="base_footprint"/>\n  <xacro:include filename="$(find cam_description)/urdf/cam.xacro"/>\n'
        '  <xacro:include filename="$(find toy_description)/urdf/extra.xacro"/>',
    )
    extra = '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="extra_link"/></robot>'
    robot = _package(tmp_path / "src", "toy_description", {"urdf/toy.urdf.xacro": body, "urdf/extra.xacro": extra})
    text = read_description(robot / "urdf" / "toy.urdf.xacro", "toy").decode()
    assert 'name="camera_link"' in text and 'name="extra_link"' in text and 'name="joint_6"' in text
    missing = body.replace("cam_description", "lidar_description")
    (robot / "urdf" / "missing.urdf.xacro").write_text(missing)
    with pytest.raises(PlacementError) as err:
        read_description(robot / "urdf" / "missing.urdf.xacro", "toy")
    words = str(err.value)
    assert "package 'lidar_description' not found" in words and "\n" not in words
    assert words.count("lidar_description") <= 3  # said once, not repeated in xacro's words
