"""The floor in the arm's collision model: arm links and a held object may touch z = 0, not enter it
(against pinocchio placements and coal's half-space distance on the exact shapes)."""

from __future__ import annotations

import dataclasses

import coal
import numpy as np
import pytest
from support.scenes import base_doc

import placement
from placement.collision import SceneCollision
from placement.scene import parse_scene


def table_scene():
    """The shared full scene (a table, a pillar, a wall, cups 'cup_1' and 'cup_2'); tests empty it."""
    return parse_scene(base_doc())


FLOOR_ARM_URDF = """<robot name="floor_arm">
<link name="base_footprint"/>
<link name="base_link"><collision><origin xyz="0 0 0.15"/><geometry><box size="0.4 0.4 0.3"/></geometry></collision></link>
<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/></joint>
<link name="turret"/>
<joint name="yaw" type="revolute"><parent link="base_link"/><child link="turret"/><origin xyz="0.25 0 0.5"/>
<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<link name="boom"><collision><origin xyz="0.3 0 0"/><geometry><box size="0.6 0.05 0.05"/></geometry></collision></link>
<joint name="pitch" type="revolute"><parent link="turret"/><child link="boom"/><axis xyz="0 1 0"/>
<limit lower="-1" upper="2" effort="1" velocity="1"/></joint>
<link name="w1"/><link name="w2"/><link name="w3"/>
<joint name="wrist_1" type="revolute"><parent link="boom"/><child link="w1"/><origin xyz="0.6 0 0"/>
<axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="wrist_2" type="revolute"><parent link="w1"/><child link="w2"/><axis xyz="0 1 0"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="wrist_3" type="revolute"><parent link="w2"/><child link="w3"/><axis xyz="1 0 0"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<link name="tool"/>
<joint name="tool_joint" type="fixed"><parent link="w3"/><child link="tool"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def floor_arm(tmp_path_factory):
    """A boom 0.6 m long pitching about a pivot 0.5 m above the floor: straight down it enters the floor
    by 0.1 m."""
    import yaml

    folder = tmp_path_factory.mktemp("floor_arm")
    (folder / "floor_arm.urdf").write_text(FLOOR_ARM_URDF)
    preset = {
        "name": "floor_arm",
        "urdf": str(folder / "floor_arm.urdf"),
        "base_frame": "base_footprint",
        "footprint_radius": 0.3,
        "v_max": 0.3,
        "omega_max": 1.0,
        "arms": {
            "arm": {"joints": ["yaw", "pitch", "wrist_1", "wrist_2", "wrist_3"], "tip_frame": "tool", "home": [0.0] * 5}
        },
    }
    (folder / "floor_arm.yaml").write_text(yaml.safe_dump(preset))
    return placement.load_robot(folder / "floor_arm.yaml")


def _below_floor_reference(c, robot, arm, q, base):
    """The deepest dip below z = 0 [m] (negative) of every collision shape the arm moves, each shape
    exact (no hull, no bound), from pinocchio's placements and coal's half-space distance."""
    import pinocchio as pin

    from placement.collision.bounds import base_matrix

    geo = c.geometry
    data, gdata = robot.model.createData(), pin.GeometryData(geo.geom)
    pin.updateGeometryPlacements(robot.model, data, geo.geom, gdata, robot.full_q(arm, q, geo.home_q))
    world = base_matrix(*base) @ np.linalg.inv(geo.base_in_model)
    floor = coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    deepest = np.inf
    for g in geo.arm_shapes(arm).moving:
        M = world @ gdata.oMg[int(g)].homogeneous
        res.clear()
        shape = geo.geom.geometryObjects[int(g)].geometry
        d = coal.distance(shape, coal.Transform3s(M[:3, :3], M[:3, 3]), floor, coal.Transform3s(), req, res)
        deepest = min(deepest, float(d))
    return deepest


def test_the_floor_stops_the_arm_and_agrees_with_an_exact_reference(floor_arm):
    """Random boom angles, base anywhere on an empty floor: the check calls a configuration a floor
    collision exactly when a moved shape dips more than FLOOR_SLACK below z = 0, by that depth."""
    from placement.collision.floor import FLOOR_SLACK

    empty = dataclasses.replace(table_scene(), objects=(), obstacles=())
    c = SceneCollision(floor_arm, empty)
    rng = np.random.default_rng(7)
    seen = {"floor": 0, "free": 0}
    for _ in range(80):
        q = np.array([rng.uniform(-1.2, 1.2), rng.uniform(0.5, 1.6), 0.0, 0.0, 0.0])
        base = (float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), float(rng.uniform(-np.pi, np.pi)))
        res = c.check("arm", [q], base)
        depth = _below_floor_reference(c, floor_arm, "arm", q, base)
        if depth < -FLOOR_SLACK:
            assert not res.free and res.culprit == "boom vs floor" and res.pose == 0, (q, depth, res)
            assert res.clearance_m == pytest.approx(depth, abs=1e-6)
            seen["floor"] += 1
        else:
            assert res.free, (q, depth, res)
            seen["free"] += 1
    assert seen["floor"] >= 10 and seen["free"] >= 10, seen
    # straight down: 0.5 - 0.6 - 0.025 (the boom's half width past its end, turned) -> -0.1 m
    down = c.check("arm", [[0.0, np.pi / 2, 0.0, 0.0, 0.0]], (0.0, 0.0, 0.0))
    assert down.culprit == "boom vs floor" and down.clearance_m == pytest.approx(-0.1, abs=1e-9)


def test_a_held_object_may_stand_on_the_floor_but_not_enter_it(floor_arm):
    from placement.collision.held import Held

    empty = dataclasses.replace(table_scene(), obstacles=())
    c = SceneCollision(floor_arm, empty)
    q = np.zeros(5)  # the boom level: its tool 0.5 m above the floor
    tcp = floor_arm.tcp_pose("arm", q)
    box = np.array([0.06, 0.06, 0.1])
    for dip in (0.0, 0.01):
        # an upright box hanging under the TCP with its bottom at z = -dip
        offset = np.eye(4)
        offset[:3, 3] = [0.0, 0.0, -(tcp[2, 3] - box[2] / 2 + dip)]
        offset = (
            np.linalg.inv(tcp) @ np.block([[np.eye(3), tcp[:3, 3:4]], [np.zeros((1, 3)), np.ones((1, 1))]]) @ offset
        )
        res = c.check("arm", [q], (0.0, 0.0, 0.0), gone=("cup_1",), held=Held("cup_1", box, offset))
        if dip == 0.0:
            assert res.free, res
        else:
            assert res.culprit == "cup_1 (held) vs floor" and res.clearance_m == pytest.approx(-0.01), res
