"""Scene format version 2: 6D objects, grasps, place orientations, trajectories, reach steps."""

from __future__ import annotations

import copy
import math

import coal
import numpy as np
import pinocchio as pin
import pytest
import yaml
from support.scenes import KITCHEN, ON_SIDE, S, set_key, v2_doc

from placement.planning.updates import parse_update
from placement.scene import SceneError, TaskStep, load_scene, parse_scene, save_scene, scene_to_dict
from placement.scene.checks import TOLERANCE, object_penetrates
from placement.scene.model import Box, SceneObject


def test_v2_scene_parses():
    s = parse_scene(v2_doc())
    can, cup = s.objects
    np.testing.assert_allclose(can.orientation, ON_SIDE, atol=1e-15)
    assert not can.upright and cup.upright
    # the pose against pinocchio's quaternion convention (x, y, z, w)
    M = pin.XYZQUATToSE3(np.array([2.0, 0.1, 0.785, *ON_SIDE])).homogeneous
    np.testing.assert_allclose(can.pose, M, atol=1e-12)
    assert cup.yaw == 0.3 and cup.grasps[0].name == "rim" and cup.grasps[0].poses.shape == (2, 7)
    np.testing.assert_allclose(cup.orientation, [0, 0, math.sin(0.15), math.cos(0.15)])
    assert s.place_locations[0].orientations.shape == (1, 4) and s.place_locations[1].orientations is None
    assert [t.name for t in s.trajectories] == ["door", "door2"]
    assert s.task == (
        TaskStep(reach=("door", "door2")),
        TaskStep("can", "spot"),
        TaskStep("cup", "bin"),
        TaskStep(reach=("door",)),
    )
    assert s.trajectory("door2").matrices().shape == (2, 4, 4)
    with pytest.raises(SceneError, match="no trajectory 'x'; trajectories: door, door2"):
        s.trajectory("x")
    # the footprint of the lying can: 0.07 along x, 0.12 along y
    np.testing.assert_allclose(can.bounds_xy(), (1.965, 0.04, 2.035, 0.16), atol=1e-9)
    # default bounds: everything, trajectories too, plus a metre
    far = v2_doc()
    far["trajectories"][0]["poses"].insert(0, [-4.0, 7.0, 1.0, 0, 0, 0, 1])
    assert parse_scene(far).bounds == pytest.approx((-5.0, -1.3, 3.4, 8.0))


def test_orientation_is_normalised_and_yaw_derived():
    doc = v2_doc()
    q = np.array([0.0, 0.0, math.sin(0.6), math.cos(0.6)]) * (1 + 5e-7)
    doc["objects"][1] = {
        "name": "cup",
        "position": [1.9, -0.1, 0.8],
        "orientation": q.tolist(),
        "size": [0.06, 0.06, 0.1],
    }
    cup = parse_scene(doc).objects[1]
    assert np.linalg.norm(cup.orientation) == pytest.approx(1, abs=1e-15)
    assert cup.yaw == pytest.approx(1.2) and cup.upright


def test_round_trip(tmp_path):
    s = load_scene(KITCHEN)
    assert parse_scene(scene_to_dict(s), KITCHEN.parent, "kitchen") == s
    out = save_scene(s, tmp_path / "kitchen.yaml")
    again = load_scene(out)
    assert again == s and again.version == 2
    again_doc = yaml.safe_load(out.read_text())
    assert again_doc["task"][0] == {"reach": ["drawer_left", "drawer_right"]}
    s2 = parse_scene(v2_doc())
    assert parse_scene(scene_to_dict(s2)) == s2
    # yaws that a quaternion would not give back bit for bit (or wrapped) stay yaws
    for yaw in (4.0, 0.1, -7.5, 1e-300):
        doc = v2_doc()
        doc["objects"][1]["yaw"] = yaw
        doc["objects"][0]["orientation"] = [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]
        doc["place_locations"][0]["orientations"] = [doc["objects"][0]["orientation"]]  # set down as picked
        doc["objects"][0]["size"] = [0.07, 0.07, 0.07]
        s3 = parse_scene(doc)
        assert s3.objects[1].yaw == yaw and parse_scene(scene_to_dict(s3)) == s3
    changed = scene_to_dict(s2)
    changed["objects"][0]["orientation"] = [0.0, S, 0.0, S]  # lying along x instead of y
    changed["place_locations"][0]["orientations"] = [[0.0, S, 0.0, S]]  # and set down so
    assert parse_scene(changed) != s2


V1_KEYS = [
    (["objects", 0, "orientation"], "objects[0].orientation"),
    (["objects", 1, "grasps"], "objects[1].grasps"),
    (["place_locations", 0, "orientations"], "place_locations[0].orientations"),
    (["trajectories"], "trajectories"),
    (["task", 0, "reach"], "task[0].reach"),
]


@pytest.mark.parametrize("path, where", V1_KEYS, ids=[w for _, w in V1_KEYS])
def test_v2_keys_need_version_2(path, where):
    doc = v2_doc()
    value = doc
    for k in path:
        value = value[k]
    doc = {
        **doc,
        "version": 1,
        "trajectories": None,
        "task": [{"pick": "cup", "place": "bin"}],
        "objects": [{"name": "cup", "position": [1.9, -0.1, 0.8], "size": [0.06, 0.06, 0.1]}],
        "place_locations": [{"name": "bin", "position": [2.2, 0.2, 0.85]}],
    }
    del doc["trajectories"]
    parse_scene(doc)  # valid as version 1
    set_key([p if not isinstance(p, int) else 0 for p in path], value)(doc)
    with pytest.raises(SceneError) as err:
        parse_scene(doc, "/", "s")
    where = where.replace("[1]", "[0]")  # the version 1 scene has one object
    assert str(err.value) == f"s: {where}: '{path[-1]}' needs version: 2 (this scene has version: 1)"


ERRORS = [
    (set_key(["objects", 0, "yaw"], 0.1), "objects[0]: give 'orientation' [x, y, z, w] or 'yaw' [rad], not both"),
    (
        set_key(["objects", 0, "orientation"], [0, 0, 0, 2]),
        "objects[0].orientation: expected a unit quaternion [x, y, z, w] (ROS order), got norm 2",
    ),
    (set_key(["objects", 0, "orientation"], [0, 0, 1]), "objects[0].orientation: expected 4 numbers, got 3"),
    (set_key(["objects", 0, "orientation"], [0, 0, 0, float("nan")]), "objects[0].orientation[3]: expected a finite"),
    (set_key(["objects", 0, "quaternion"], [0, 0, 0, 1]), "unknown key 'objects[0].quaternion'"),
    (set_key(["objects", 1, "grasps"], []), "objects[1].grasps: expected a list of grasps {name, poses}, got an empty"),
    (
        set_key(["objects", 1, "grasps", 0, "poses"], []),
        "objects[1].grasps[0].poses: expected a list of 1 to 100 poses",
    ),
    (
        set_key(["objects", 1, "grasps", 0, "poses"], [[0, 0, 0, 0, 0, 1]] * 2),
        "objects[1].grasps[0].poses[0]: expected a pose [x, y, z, qx, qy, qz, qw], got 6 numbers",
    ),
    (
        set_key(["objects", 1, "grasps", 0, "poses", 1], [0, 0, 0, 0, 0, 0, 0]),
        "objects[1].grasps[0].poses[1][3:7]: expected a unit quaternion",
    ),
    (
        lambda d: d["objects"][1]["grasps"].append({"name": "rim", "poses": [[0, 0, 0, 0, 0, 0, 1]]}),
        "objects[1].grasps[1].name: duplicate grasp name 'rim'",
    ),
    (
        set_key(["objects", 1, "grasps", 0, "colour"], 1),
        "unknown key 'objects[1].grasps[0].colour'; allowed: name, poses",
    ),
    (set_key(["trajectories", 1, "name"], "table"), "trajectories[1].name: duplicate name 'table'"),
    (set_key(["trajectories", 0, "poses"], [[0, 0, 0, 0, 0, 0, 1]] * 101), "expected at most 100 poses, got 101"),
    (
        set_key(["task", 0, "reach"], ["door", "drawer"]),
        "task[0].reach[1]: 'drawer' is not a trajectory; trajectories: door, door2",
    ),
    (set_key(["task", 0, "reach"], ["door", "door"]), "task[0].reach[1]: trajectory 'door' is listed twice"),
    (set_key(["task", 0, "reach"], []), "task[0].reach: expected a trajectory name or a non-empty list"),
    (set_key(["task", 3, "reach"], 3), "task[3].reach: expected a non-empty string, got"),
    (set_key(["task", 0, "pick"], "can"), "task[0]: a step is {pick, place} or {reach}, not both"),
    (set_key(["task", 1, "reach"], "door"), "task[1]: a step is {pick, place} or {reach}, not both"),
    (
        set_key(["place_locations", 0, "orientations"], []),
        "place_locations[0].orientations: expected a list of quatern",
    ),
    (
        set_key(["place_locations", 0, "orientations"], [[1, 1, 0, 0]]),
        "place_locations[0].orientations[0]: expected a unit quaternion",
    ),
    (
        lambda d: d.update(bounds=[-1, -1, 3, 3]) or d["trajectories"][1]["poses"].append([3.5, 1, 1, 0, 0, 0, 1]),
        "trajectories[1].poses[2]: the end of trajectory 'door2' at (3.5, 1) is outside bounds [-1, -1, 3, 3]",
    ),
    # the lying can sunk 2 cm into the table: only its 6D box says so (its yaw-only box is 12 cm tall)
    (set_key(["objects", 0, "position"], [2.0, 0.1, 0.765]), "object 'can' is inside obstacle 'table'"),
    (
        lambda d: d["objects"][0].update(size=[0.1, 0.2, 0.1], position=[2.0, 0.1, 0.85]),
        "objects[0].size: object 'can' is wider than the gripper opening (0.09 m) across every side",
    ),
]


@pytest.mark.parametrize("mutate, message", ERRORS, ids=[m for _, m in ERRORS])
def test_invalid_v2_scene(mutate, message):
    doc = v2_doc()
    mutate(doc)
    with pytest.raises(SceneError) as err:
        parse_scene(copy.deepcopy(doc), "/", "scene", source="scene.yaml")
    msg = str(err.value)
    assert message in msg and msg.startswith("scene.yaml: ") and "\n" not in msg


def test_lying_can_on_the_table_is_fine_and_wide_objects_with_grasps_too():
    doc = v2_doc()
    doc["objects"][1]["size"] = [0.3, 0.3, 0.1]  # too wide to generate, but it has its own grasps
    doc["objects"][1]["position"] = [1.9, -0.15, 0.8]  # clear of the can (objects may not overlap)
    assert parse_scene(doc).objects[0].position[2] == 0.785


def _coal_depth(o: SceneObject, box: Box) -> float:
    """Signed distance [m] between the object's box and the obstacle box by coal (negative inside)."""
    a = coal.Box(*o.size)
    b = coal.Box(*box.size)
    Tb = np.eye(4)
    Tb[:2, :2] = [[math.cos(box.yaw), -math.sin(box.yaw)], [math.sin(box.yaw), math.cos(box.yaw)]]
    Tb[:3, 3] = box.center
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    req.enable_signed_distance = True
    return coal.distance(
        a, coal.Transform3s(o.pose[:3, :3], o.pose[:3, 3]), b, coal.Transform3s(Tb[:3, :3], Tb[:3, 3]), req, res
    )


def test_tilted_box_penetration_against_coal():
    rng = np.random.default_rng(3)
    obstacle = Box([0.0, 0.0, 0.4], [0.6, 0.4, 0.8], 0.3)
    checked = 0
    for _ in range(400):
        q = rng.normal(size=4)
        o = SceneObject(
            "o", rng.uniform([-0.5, -0.4, 0.6], [0.5, 0.4, 1.0]), 0.0, rng.uniform(0.05, 0.3, 3), q / np.linalg.norm(q)
        )
        d = _coal_depth(o, obstacle)
        if abs(d) < 3 * TOLERANCE:  # the tolerance band: touching counts as outside, by design
            continue
        assert object_penetrates(o, obstacle) == (d < 0), (o, d)
        checked += 1
    assert checked > 300


def test_update_may_turn_an_object():
    s = parse_scene(v2_doc())
    new, moved, _, _ = parse_update(
        {"objects": [{"name": "cup", "orientation": ON_SIDE, "position": [1.9, -0.1, 0.78]}]}, s
    )
    cup = new.object("cup")
    assert moved == {"cup"} and not cup.upright and cup.grasps == s.object("cup").grasps
    np.testing.assert_allclose(cup.orientation, ON_SIDE)
    back, _, _, _ = parse_update({"objects": [{"name": "cup", "yaw": 0.5, "position": [1.9, -0.1, 0.8]}]}, new)
    assert back.object("cup").upright and back.object("cup").yaw == 0.5
    for change, message in [
        ({"objects": [{"name": "cup", "yaw": 1.0, "orientation": ON_SIDE}]}, "objects[0]: give 'orientation'"),
        ({"objects": [{"name": "cup", "orientation": [0, 0, 0, 3]}]}, "objects[0].orientation: expected a unit"),
        ({"objects": [{"name": "cup", "grasps": []}]}, "objects[0].grasps: an update moves objects"),
        ({"objects": [{"name": "can", "position": [2.0, 0.1, 0.7]}]}, "object 'can' is inside obstacle 'table'"),
    ]:
        with pytest.raises(SceneError) as err:
            parse_update(change, s)
        assert str(err.value).startswith("update: ") and message in str(err.value)
    v1_doc = {k: v for k, v in v2_doc().items() if k != "trajectories"}
    v1 = parse_scene(
        {
            **v1_doc,
            "version": 1,
            "objects": [{"name": "cup", "position": [1.9, -0.1, 0.8], "size": [0.06, 0.06, 0.1]}],
            "place_locations": [{"name": "bin", "position": [2.2, 0.2, 0.85]}],
            "task": [{"pick": "cup", "place": "bin"}],
        }
    )
    with pytest.raises(SceneError, match=r"update: objects\[0\].orientation: 'orientation' needs version: 2"):
        parse_update({"objects": [{"name": "cup", "orientation": ON_SIDE}]}, v1)
