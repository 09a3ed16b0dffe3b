"""Literal cases of the scene collision checker, scene geometry (polygons, occupancy, 6D poses) and errors."""

from __future__ import annotations

import dataclasses
import time
import types
import warnings

import coal
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import placement
from placement.collision import CLEARANCE_CAP, CollisionGeometryWarning, SceneCollision, scene_shapes
from placement.collision.scene import polygon_shapes, signed_area, triangulate
from placement.kinematics.ik import solve_ik
from placement.planning import parse_scene
from placement.scene import Obstacle, OccupancyMap, Polygon

BASE = (0.3, 0.0, 0.0)  # PR2 base 0.12 m from the table edge, facing it


def table_scene(**extra):
    """A 0.7 m high table from x = 0.75 m, two cups on it, the PR2 in front of it."""
    return parse_scene(
        {
            "version": 1,
            "resolution": 0.05,
            "bounds": [-3, -3, 3, 3],
            "robot": {"preset": "pr2", "start": [-1, 0, 0]},
            "obstacles": [
                {"name": "table_1", "box": {"center": [1.05, 0.0, 0.35], "size": [0.6, 0.9, 0.7]}, "table": True}
            ],
            "objects": [
                {"name": "cup_1", "position": [0.95, -0.2, 0.75], "yaw": 0.0, "size": [0.06, 0.06, 0.1]},
                {"name": "cup_2", "position": [0.95, -0.35, 0.75], "yaw": 0.0, "size": [0.06, 0.06, 0.1]},
            ],
            "place_locations": [{"name": "p", "position": [1.0, 0.3, 0.8]}],
            "task": [{"pick": "cup_1", "place": "p"}],
            **extra,
        }
    )


@pytest.fixture(scope="module")
def checker(pr2):
    return SceneCollision(pr2, table_scene())


def top_grasp(pr2, x, y, z, base=BASE) -> np.ndarray:
    """Right arm joints [rad] with the TCP at world (x, y, z) [m] pointing down (IK must succeed)."""
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (x - base[0], y - base[1], z)
    res = solve_ik(pr2, "right", T, pr2.arm("right").home, seeds=8)
    assert res.success
    return res.q


def test_home_in_front_of_the_table_is_free(checker, pr2):
    res = checker.check("right", [pr2.arm("right").home], BASE)
    assert res.free and 0 < res.clearance_m < CLEARANCE_CAP and res.culprit is not None


def test_arm_pushed_through_the_table_collides_naming_it(checker, pr2):
    q = top_grasp(pr2, 0.9, -0.05, 0.62)  # TCP 8 cm below the table top
    res = checker.check("right", [pr2.arm("right").home, q], BASE)
    assert not res.free and res.culprit.startswith("r_") and res.culprit.endswith(" vs table_1")
    assert res.pose == 1 and res.clearance_m < 0


def test_gripper_around_the_grasped_object_is_free_but_not_around_another(checker, pr2):
    q = top_grasp(pr2, 0.95, -0.2, 0.78)  # fingers around cup_1
    held = checker.check("right", [q], BASE, grasped="cup_1")
    assert held.free and held.clearance_m > 0
    for grasped in (None, "cup_2"):
        res = checker.check("right", [q], BASE, grasped=grasped)
        assert not res.free and res.culprit.startswith("r_gripper") and res.culprit.endswith(" vs cup_1")
    # cup_1 already carried away (an earlier step of the task): nothing is left to hit, for any link
    gone = checker.check("right", [q], BASE, grasped="cup_2", gone=["cup_1"])
    assert gone.free and gone.clearance_m >= held.clearance_m - 1e-9


def test_the_rest_of_the_arm_still_hits_the_grasped_object(checker, pr2):
    """Only the gripper may touch the grasped object: the forearm through it collides."""
    q = top_grasp(pr2, 0.95, -0.2, 0.98)
    res = checker.check("right", [q], BASE, grasped="cup_1")
    assert res.free
    moved = dataclasses.replace(
        table_scene(),
        objects=(
            dataclasses.replace(
                table_scene().object("cup_1"),
                position=np.array([0.95 - 0.25, -0.2, 1.0]),
                size=np.array([0.1, 0.3, 0.3]),
            ),
        ),
    )
    c = SceneCollision(pr2, moved)
    res = c.check("right", [q], BASE, grasped="cup_1")
    assert not res.free and not res.culprit.startswith("r_gripper") and res.culprit.endswith(" vs cup_1")


def test_arm_folded_into_the_body_is_a_self_collision(checker, pr2):
    q = np.array([-0.86, 1.4, -2.1, -1.72, 0.12, -1.49, -1.25])  # the hand pulled back against the shoulder
    res = checker.check("right", [q], (-2.0, 0.0, 0.0))
    assert not res.free and res.pose == 0
    a, b = res.culprit.split(" vs ")
    link_names = {f.name for f in pr2.model.frames}
    assert a in link_names and b in link_names  # robot vs robot


def test_update_takes_moved_obstacles(pr2):
    q = top_grasp(pr2, 0.9, -0.05, 0.62)
    c = SceneCollision(pr2, table_scene())
    assert not c.check("right", [q], BASE).free
    lower = dataclasses.replace(
        table_scene(),
        obstacles=(
            Obstacle(
                "table_1",
                dataclasses.replace(
                    table_scene().obstacle("table_1").shape,
                    center=np.array([1.05, 0.0, 0.25]),
                    size=np.array([0.6, 0.9, 0.5]),
                ),
            ),
        ),
    )
    c.update(lower)
    assert c.check("right", [q], BASE).free


def test_padding_rejects_near_misses(pr2):
    q = top_grasp(pr2, 0.9, -0.05, 0.725)  # fingertips just above the table top
    free = SceneCollision(pr2, table_scene()).check("right", [q], BASE)
    assert free.free and free.culprit.endswith(" vs table_1") and free.clearance_m < 0.05
    near = SceneCollision(pr2, table_scene(), padding=free.clearance_m - 0.002).check("right", [q], BASE)
    assert near == free
    padded = SceneCollision(pr2, table_scene(), padding=free.clearance_m + 0.002).check("right", [q], BASE)
    assert not padded.free and padded.culprit.endswith(" vs table_1")
    assert free.clearance_m <= padded.clearance_m < free.clearance_m + 0.002


def test_far_from_everything_reports_the_cap(pr2):
    empty = dataclasses.replace(table_scene(), obstacles=(), objects=())
    lone = SceneCollision(pr2, empty, clearance_cap=0.001)
    res = lone.check("right", [pr2.arm("right").home], BASE)
    assert res.free and res.clearance_m == 0.001 and res.culprit is None


def test_occupancy_cells_only_near_the_robot(pr2):
    """A 4 million cell map, nearly all occupied, given a height for the arm, checked in milliseconds;
    cells name the culprit. Without a height the map is the base's alone: the arm reaches over it."""
    occ = np.ones((2000, 2000), dtype=bool)  # 0.01 m cells over [-10, 10)^2
    occ[900:1100, 900:1100] = False  # a free 2 m x 2 m room around the origin
    scene = dataclasses.replace(
        table_scene(), objects=(), obstacles=(), occupancy=OccupancyMap(occ, 0.01, (-10.0, -10.0, 0.0), arm_height=3.0)
    )
    flat = dataclasses.replace(scene, occupancy=OccupancyMap(occ, 0.01, (-10.0, -10.0, 0.0)))
    assert SceneCollision(pr2, flat).check("right", [pr2.arm("right").home], (0.45, 0.0, 0.0)).free
    c = SceneCollision(pr2, scene)
    home = pr2.arm("right").home
    assert c.check("right", [home], (0.0, 0.0, 0.0)).free
    t = time.perf_counter()
    res = c.check("right", [home], (0.45, 0.0, 0.0))  # the arm reaches out of the room (x > 1 m)
    assert time.perf_counter() - t < 0.5
    assert not res.free and res.culprit.split(" vs ")[1].startswith("occupancy[")
    r, col = (int(v) for v in res.culprit.split("[")[1].rstrip("]").split(","))
    assert occ[r, col] and col >= 1100


def test_six_d_object_pose_is_used():
    """An object with a ``pose`` (scene v2) is a box at that pose; without it, position and yaw."""
    tilt = np.eye(4)
    tilt[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # 90 deg about x: the 0.4 m y side stands up
    tilt[:3, 3] = (1.0, 0.0, 1.0)
    obj = types.SimpleNamespace(
        name="plank", position=np.array([1.0, 0.0, 1.0]), yaw=0.0, size=np.array([0.05, 0.4, 0.02]), pose=tilt
    )
    scene = types.SimpleNamespace(obstacles=(), objects=(obj,), occupancy=None)
    (shape,) = scene_shapes(scene)
    assert np.allclose(shape.aabb, [[0.975, -0.01, 0.8], [1.025, 0.01, 1.2]])
    probe, req = coal.Sphere(0.01), coal.CollisionRequest()
    above = coal.Transform3s(np.eye(3), np.array([1.0, 0.0, 1.15]))
    T = coal.Transform3s(shape.pose[:3, :3], shape.pose[:3, 3])
    assert coal.collide(shape.geometry, T, probe, above, req, coal.CollisionResult())
    del obj.pose
    (flat,) = scene_shapes(scene)
    T = coal.Transform3s(flat.pose[:3, :3], flat.pose[:3, 3])
    assert not coal.collide(flat.geometry, T, probe, above, req, coal.CollisionResult())


def test_non_convex_polygon_prism_keeps_its_notch():
    """An L-shaped prism: a probe in the notch is free, one in either leg collides, even wholly inside."""
    pieces = polygon_shapes("l_wall", [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]])
    assert len(pieces) > 1

    def hits(x, y, z=1.0):
        T = coal.Transform3s(np.eye(3), np.array([x, y, z]))
        return any(
            coal.collide(
                p.geometry, coal.Transform3s(), coal.Sphere(0.05), T, coal.CollisionRequest(), coal.CollisionResult()
            )
            for p in pieces
        )

    assert hits(1.5, 0.5) and hits(0.5, 1.5) and hits(0.5, 0.5, 2.9)
    assert not hits(1.5, 1.5) and not hits(0.5, 0.5, 3.1)


@settings(deadline=None)
@given(st.lists(st.floats(0.2, 2.0), min_size=3, max_size=12), st.floats(0, 6.28))
def test_triangulation_covers_star_polygons(radii, turn):
    """Star-shaped polygons (simple by construction): triangles with the polygon's area, none flipped."""
    k = len(radii)
    ang = turn + 2 * np.pi * np.arange(k) / k
    pts = np.stack([np.cos(ang) * radii, np.sin(ang) * radii], axis=1)
    tris = triangulate(pts)
    assert len(tris) == k - 2
    areas = [signed_area(t) for t in tris]
    assert min(areas) >= -1e-12
    assert sum(areas) == pytest.approx(signed_area(pts), rel=1e-9, abs=1e-12)


def test_robot_without_collision_geometry_warns_and_is_never_blocked(armar6_preset):
    robot = placement.load_robot(armar6_preset)  # the shared ARMAR-6 has no mesh files
    scene = table_scene()
    with pytest.warns(CollisionGeometryWarning, match="links without their collision meshes: platform") as rec:
        c = SceneCollision(robot, dataclasses.replace(scene, robot_preset=str(armar6_preset)))
    assert len(rec) == 1 and "0 shapes" in str(rec[0].message)
    res = c.check("right", [robot.arm("right").home], BASE)
    assert res == placement.collision.CollisionResult(True, CLEARANCE_CAP, None, None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the geometry is loaded once per robot: no second warning
        SceneCollision(robot, scene)


def test_bad_input_is_one_clear_error(checker, pr2):
    with pytest.raises(placement.ArmNotFound, match="its arms are: right, left"):
        checker.check("middle", [np.zeros(7)], BASE)
    with pytest.raises(placement.PlacementError, match=r"qs must be \(poses, 7\)"):
        checker.check("right", np.zeros((2, 6)), BASE)
    with pytest.raises(placement.PlacementError, match=r"qs must be \(poses, 7\)"):
        checker.check("right", [np.full(7, np.nan)], BASE)
    with pytest.raises(placement.PlacementError, match="object 'mug' is not in the scene; objects: cup_1, cup_2"):
        checker.check("right", [np.zeros(7)], BASE, grasped="mug")
    with pytest.raises(placement.PlacementError, match="object 'jug' is not in the scene"):
        checker.check("right", [np.zeros(7)], BASE, gone=["jug"])
    with pytest.raises(placement.PlacementError, match="padding"):
        SceneCollision(pr2, table_scene(), padding=-0.1)
    bad = dataclasses.replace(table_scene(), obstacles=(Obstacle("blob", types.SimpleNamespace(mass=1.0)),))
    with pytest.raises(placement.PlacementError, match="obstacle 'blob': shape SimpleNamespace is not supported"):
        SceneCollision(pr2, bad)


def test_polygon_obstacle_in_a_scene(pr2):
    """A polygon obstacle (non-convex) next to the robot: the arm swung into it collides, naming it."""
    wall = Obstacle(
        "l_counter", Polygon(np.array([[0.6, -1.2], [1.2, -1.2], [1.2, 0.9], [0.95, 0.9], [0.95, -0.75], [0.6, -0.75]]))
    )
    scene = dataclasses.replace(table_scene(), obstacles=(wall,), objects=())
    c = SceneCollision(pr2, scene)
    for x, y in ((0.75, -0.3), (0.8, -0.4)):  # over the notch (x < 0.95, y > -0.75)
        assert c.check("right", [top_grasp(pr2, x, y, 0.9)], BASE).free
    q = top_grasp(pr2, 1.0, -0.2, 0.9)
    res = c.check("right", [q], BASE)
    assert not res.free and res.culprit.endswith(" vs l_counter")


def test_a_degenerate_collision_shape_is_left_out_with_a_warning(tmp_path, pr2):
    """A zero, NaN or infinite scale or size has no volume (and coal's hull fails on it): the shape is
    left out and one warning names its link; the rest of the robot is still checked."""
    import re
    import xml.etree.ElementTree as ET
    from pathlib import Path

    import yaml

    from placement.collision.robot import CollisionGeometryWarning, RobotGeometry, degenerate
    from placement.robots import load_robot
    from placement.robots.preset import PRESET_DIR

    for bad in (
        '<mesh filename="x.stl" scale="0 0 0"/>',
        '<mesh filename="x.stl" scale="nan 1 1"/>',
        '<box size="0.1 inf 0.1"/>',
        '<cylinder radius="0" length="1"/>',
        '<sphere radius="abc"/>',
    ):
        assert degenerate(ET.fromstring(f"<collision><geometry>{bad}</geometry></collision>"))
    assert not degenerate(ET.fromstring('<collision><geometry><box size="0.1 0.2 0.3"/></geometry></collision>'))
    urdf = Path(pr2.urdf_path)
    # the base link's collision mesh scaled to nothing
    text, n = re.subn(r'(<mesh filename="[^"]*base_v0/base_L\.stl")', r'\1 scale="0 0 0"', urdf.read_text(), count=1)
    assert n == 1
    (tmp_path / "pr2.urdf").write_text(text)
    preset = yaml.safe_load((PRESET_DIR / "pr2.yaml").read_text())
    preset["urdf"] = str(tmp_path / "pr2.urdf")
    preset.pop("srdf", None)
    (tmp_path / "pr2.yaml").write_text(yaml.safe_dump(preset))
    robot = load_robot(str(tmp_path / "pr2.yaml"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        geo = RobotGeometry(robot, [str(urdf.resolve().parents[4])])
    assert geo.geom.ngeoms > 10 and geo.lost == ["base_link"]
    assert any(issubclass(c.category, CollisionGeometryWarning) and "base_link" in str(c.message) for c in caught)
