"""Scene files (docs/scenes.md): parsing, strict validation, defaults, round trips."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import yaml
from support.occupancy import EXPECTED, write_map
from support.scenes import FULL_SCENE, base_doc, set_key

from placement.errors import PlacementError
from placement.planning.settings import PLANNER_KEYS
from placement.scene import (
    Box,
    Cylinder,
    Obstacle,
    PlaceLocation,
    Polygon,
    Scene,
    SceneError,
    SceneObject,
    TaskStep,
    load_scene,
    parse_scene,
    save_scene,
    scene_to_dict,
)


@pytest.fixture
def scene_file(tmp_path):
    write_map(tmp_path)
    path = tmp_path / "scene.yaml"
    path.write_text(FULL_SCENE)
    return path


def test_full_scene_loads(scene_file, tmp_path):
    s = load_scene(scene_file)
    assert isinstance(s, Scene)
    assert (s.version, s.name, s.resolution) == (1, "scene", 0.1)
    assert s.bounds == (-3.0, -3.0, 7.0, 5.0)
    assert s.robot_preset == "pr2"
    assert s.start == (0.0, 0.0, 1.5707963)
    assert s.maps == str(tmp_path / "maps" / "pr2")
    assert s.occupancy_map == tmp_path / "floor.yaml"
    assert s.source == scene_file
    np.testing.assert_array_equal(s.occupancy.occupied, EXPECTED)
    assert s.obstacles[0] == Obstacle("table_1", Box([2.0, 0.0, 0.375], [0.8, 0.6, 0.75], 0.1), True)
    assert s.obstacles[1] == Obstacle("pillar", Cylinder([-1.0, 3.0, 1.0], 0.2, 2.0))
    assert s.obstacles[2] == Obstacle("wall", Polygon([[-2.5, -2.5], [6.5, -2.5], [6.5, -2.4], [-2.5, -2.4]]))
    assert s.objects == (
        SceneObject("cup_1", [2.1, 0.1, 0.8], 0.3, [0.08, 0.08, 0.1]),
        SceneObject("cup_2", [1.9, -0.1, 0.81], 0.0, [0.06, 0.1, 0.12]),
    )
    assert s.place_locations == (PlaceLocation("bin_a", [5.0, 1.0, 0.9]), PlaceLocation("bin_b", [5.0, -1.0, 0.9]))
    assert s.task == (TaskStep("cup_1", "bin_a"), TaskStep("cup_2", "bin_b"))
    assert s.planner == {"lambda_n": 0.05, "yaw_steps": 60, "grasp_yaws": [0.0, 1.5707963]}
    assert s.tables == (s.obstacles[0],)
    assert s.object("cup_2") is s.objects[1]
    assert s.place_location("bin_b") is s.place_locations[1]
    with pytest.raises(SceneError, match=r"no object 'mug'; objects: cup_1, cup_2"):
        s.object("mug")
    assert s.grid_shape == (80, 100)
    assert not s.objects[0].position.flags.writeable  # frozen all the way down


def test_round_trip(scene_file, tmp_path):
    s = load_scene(scene_file)
    # through a dict with absolute paths
    assert parse_scene(scene_to_dict(s), "/", "scene") == s
    # through a file in another directory, paths written relative to it
    other = tmp_path / "copy"
    other.mkdir()
    out = save_scene(s, other / "scene.yaml")
    again = load_scene(out)
    assert again == s
    assert again.occupancy_map == s.occupancy_map and again.maps == s.maps
    assert yaml.safe_load(out.read_text())["maps"] == "../maps/pr2"
    # and a change is seen
    assert parse_scene({**scene_to_dict(s), "resolution": 0.05}, "/", "scene") != s


def test_default_bounds_cover_everything_plus_a_metre():
    doc = {
        "version": 1,
        "robot": {"start": [0.0, 0.0, 0.0]},
        "obstacles": [
            # rotated by 90 deg: footprint x 1.7 .. 2.3, y -0.5 .. 0.5
            {"name": "t", "box": {"center": [2.0, 0.0, 0.4], "size": [1.0, 0.6, 0.8], "yaw": math.pi / 2}},
            {"name": "c", "cylinder": {"center": [-1.0, 3.0, 0.5], "radius": 0.25, "height": 1.0}},
            {"name": "w", "polygon": [[0.0, -2.0], [4.0, -2.0], [4.0, -1.9]]},
        ],
        "objects": [{"name": "o", "position": [2.0, 0.1, 0.85], "size": [0.06, 0.06, 0.1]}],
        "place_locations": [{"name": "p", "position": [5.0, 1.0, 0.8]}],
        "task": [{"pick": "o", "place": "p"}],
    }
    s = parse_scene(doc)
    assert s.resolution == 0.05
    assert s.robot_preset == "pr2"
    assert s.bounds == pytest.approx((-2.25, -3.0, 6.0, 4.25))
    assert s.maps is None and s.occupancy_map is None and s.planner == {}
    assert s.grid_shape == (145, 165)


def test_default_bounds_include_the_occupancy_map(tmp_path):
    write_map(tmp_path)  # extent x 1 .. 3, y 2 .. 3.5
    doc = {
        "version": 1,
        "robot": {"start": [0.0, 0.0, 0.0]},
        "occupancy_map": "floor.yaml",
        "objects": [{"name": "o", "position": [1.5, 0.5, 0.8], "size": [0.1, 0.1, 0.1]}],
        "place_locations": [{"name": "p", "position": [0.5, 0.5, 0.8]}],
        "task": [{"pick": "o", "place": "p"}],
    }
    s = parse_scene(doc, tmp_path, "s")
    assert s.bounds == pytest.approx((-1.0, -1.0, 4.0, 4.5))


# -- validation ------------------------------------------------------------------------------------


ERRORS = [
    # unknown keys, with the allowed set
    (
        set_key(["obstacles", 0, "colour"], "red"),
        "scene.yaml: unknown key 'obstacles[0].colour'; allowed: box, cylinder, name, polygon, table",
    ),
    (
        set_key(["robots"], {}),
        "unknown key 'robots'; allowed: bounds, keepout_mask, maps, objects, obstacle_cloud, obstacles, occupancy_map",
    ),
    (set_key(["robot", "goal"], [0, 0, 0]), "unknown key 'robot.goal'; allowed: preset, start"),
    (set_key(["task", 0, "arm"], "left"), "unknown key 'task[0].arm'; allowed: pick, place"),
    (set_key(["place_locations", 1, "yaw"], 0.0), "unknown key 'place_locations[1].yaw'; allowed: name, position"),
    (
        set_key(["planner", "speed"], 2.0),
        "unknown key 'planner.speed'; allowed: collision_padding, d_max, face_target, footprint_padding, grasp_yaws, ik_budget_ms, "
        "lambda_m, lambda_n, lambda_nh, memory_budget_gib, threshold, threshold_quantile, time_budget_s, time_polish, velocity_k, "
        "velocity_lambda, yaw_steps",
    ),
    # yaw only, no quaternions
    (
        set_key(["obstacles", 0, "box", "quaternion"], [0, 0, 0, 1]),
        "unknown key 'obstacles[0].box.quaternion'; allowed: center, size, yaw (shapes and objects rotate about z only",
    ),
    (
        set_key(["objects", 0, "orientation"], [0, 0, 0, 1]),
        "scene.yaml: objects[0].orientation: 'orientation' needs version: 2 (this scene has version: 1)",
    ),
    # missing required keys
    (set_key(["version"], KeyError), "scene.yaml: missing required key 'version'"),
    (set_key(["robot"], KeyError), "missing required key 'robot'"),
    (set_key(["robot", "start"], KeyError), "missing required key 'robot.start'"),
    (set_key(["task"], KeyError), "missing required key 'task'"),
    (set_key(["objects", 1, "size"], KeyError), "missing required key 'objects[1].size'"),
    (set_key(["obstacles", 1, "cylinder", "height"], KeyError), "missing required key 'obstacles[1].cylinder.height'"),
    (set_key(["task", 1, "place"], KeyError), "missing required key 'task[1].place'"),
    # version
    (
        set_key(["version"], 3),
        "scene.yaml: version: unsupported scene format version 3; this build reads versions 1, 2",
    ),
    (set_key(["version"], "1"), "version: expected an integer, got string '1'"),
    # wrong types and shapes
    (
        set_key(["obstacles", 0, "box", "size"], [0.8, 0.6]),
        "scene.yaml: obstacles[0].box.size: expected 3 numbers, got 2",
    ),
    (set_key(["robot", "start"], "origin"), "robot.start: expected a list of 3 numbers, got string 'origin'"),
    (set_key(["objects", 0, "yaw"], "0.3"), "objects[0].yaw: expected a number, got string '0.3'"),
    (
        set_key(["obstacles", 1, "cylinder", "radius"], True),
        "obstacles[1].cylinder.radius: expected a number, got bool",
    ),
    (set_key(["obstacles", 0, "table"], 1), "obstacles[0].table: expected true or false, got 1"),
    (set_key(["obstacles"], {"name": "x"}), "scene.yaml: obstacles: expected a list, got a mapping"),
    (set_key(["objects", 0], "cup"), "objects[0]: expected a mapping, got string 'cup'"),
    (set_key(["objects", 0, "name"], ""), "objects[0].name: expected a non-empty string"),
    (set_key(["task"], {"pick": "cup_1"}), "task: expected a list of {pick, place} steps, got a mapping"),
    (set_key(["task"], []), "task: expected at least one {pick, place} step"),
    (set_key(["maps"], 3), "maps: expected a non-empty string, got 3"),
    # non-finite numbers
    (
        set_key(["objects", 0, "position"], [float("nan"), 0.0, 0.8]),
        "objects[0].position[0]: expected a finite number, got nan",
    ),
    (set_key(["robot", "start"], [0.0, 0.0, float("inf")]), "robot.start[2]: expected a finite number, got inf"),
    (set_key(["resolution"], float("inf")), "resolution: expected a finite number, got inf"),
    # non-positive sizes, radius, resolution
    (set_key(["resolution"], 0), "scene.yaml: resolution: must be >= 0.01, got 0"),
    (set_key(["resolution"], -0.05), "resolution: must be >= 0.01, got -0.05"),
    (set_key(["obstacles", 0, "box", "size"], [0.8, -0.6, 0.75]), "obstacles[0].box.size[1]: must be > 0, got -0.6"),
    (set_key(["obstacles", 1, "cylinder", "radius"], 0.0), "obstacles[1].cylinder.radius: must be > 0, got 0.0"),
    (set_key(["obstacles", 1, "cylinder", "height"], -1), "obstacles[1].cylinder.height: must be > 0, got -1"),
    (set_key(["objects", 0, "size"], [0.08, 0.08, 0]), "objects[0].size[2]: must be > 0, got 0"),
    # shapes
    (set_key(["obstacles", 2, "polygon"], [[0, 0], [1, 0]]), "obstacles[2].polygon: expected at least 3 points, got 2"),
    (set_key(["obstacles", 2, "polygon"], [[0, 0], [1, 1], [2, 2]]), "obstacles[2].polygon: the polygon has zero area"),
    (set_key(["obstacles", 2, "polygon"], [[0, 0], [1, 0], [1]]), "obstacles[2].polygon[2]: expected 2 numbers, got 1"),
    (
        set_key(["obstacles", 1, "box"], {"center": [0, 0, 0], "size": [1, 1, 1]}),
        "obstacles[1]: expected exactly one shape (box, cylinder, polygon), got box and cylinder",
    ),
    (
        set_key(["obstacles", 1, "cylinder"], KeyError),
        "obstacles[1]: expected exactly one shape (box, cylinder, polygon), got none",
    ),
    (set_key(["obstacles", 2, "table"], True), "obstacles[2].table: a polygon has no height"),
    # names and task references
    (set_key(["objects", 1, "name"], "cup_1"), "objects[1].name: duplicate name 'cup_1' (already used by objects[0])"),
    (
        set_key(["place_locations", 0, "name"], "table_1"),
        "place_locations[0].name: duplicate name 'table_1' (already used by obstacles[0])",
    ),
    (set_key(["task", 0, "pick"], "mug"), "scene.yaml: task[0].pick: 'mug' is not an object; objects: cup_1, cup_2"),
    (
        set_key(["task", 1, "place"], "bin_c"),
        "task[1].place: 'bin_c' is not a place location; place locations: bin_a, bin_b",
    ),
    (set_key(["task", 0, "pick"], "bin_a"), "task[0].pick: 'bin_a' is not an object; objects: cup_1, cup_2"),
    (set_key(["task", 1, "pick"], "cup_1"), "task[1].pick: object 'cup_1' is already picked in task[0]"),
    # planner values
    (set_key(["planner", "yaw_steps"], 0), "planner.yaw_steps: must be >= 1, got 0"),
    (set_key(["planner", "yaw_steps"], 10.5), "planner.yaw_steps: expected an integer, got 10.5"),
    (set_key(["planner", "lambda_m"], -1.0), "planner.lambda_m: must be >= 0, got -1.0"),
    (set_key(["planner", "d_max"], 0), "planner.d_max: must be > 0, got 0"),
    (set_key(["planner", "grasp_yaws"], []), "planner.grasp_yaws: expected a count or a non-empty list"),
    (set_key(["planner"], [1, 2]), "planner: expected a mapping, got a list"),
    # bounds
    (set_key(["bounds"], [0.0, 0.0, 1.0]), "bounds: expected 4 numbers, got 3"),
    (set_key(["bounds"], [7.0, -3.0, -3.0, 5.0]), "bounds: expected [xmin, ymin, xmax, ymax] with xmin < xmax"),
    (
        set_key(["robot", "start"], [20.0, 0.0, 0.0]),
        "scene.yaml: robot.start: the start position at (20, 0) is outside bounds [-3, -3, 7, 5]",
    ),
    (
        set_key(["objects", 1, "position"], [1.9, -3.5, 0.8]),
        "objects[1].position: object 'cup_2' at (1.9, -3.5) is outside bounds [-3, -3, 7, 5]",
    ),
    (
        set_key(["place_locations", 0, "position"], [8.0, 1.0, 0.9]),
        "place_locations[0].position: place location 'bin_a' at (8, 1) is outside bounds",
    ),
    (
        set_key(["bounds"], [-3, -3, 3000, 200]),
        "resolution: bounds [-3, -3, 3000, 200] at 0.1 m give a 30030 x 2030 grid",
    ),
    (set_key(["resolution"], 0.0001), "resolution: must be >= 0.01, got 0.0001"),
    (set_key(["bounds"], [0, 0, 1e300, 1]), "bounds[2]: must be within +-1e+06, got 1e+300"),
    (set_key(["planner", "lambda_m"], 1e308), "planner.lambda_m: must be <= 1e+06, got 1e+308"),
    (set_key(["planner", "threshold"], 0), "planner.threshold: must be > 0, got 0"),
    # files
    (set_key(["robot", "preset"], "pr3"), "robot.preset: unknown robot 'pr3'; built-in presets: pr2"),
    (set_key(["robot", "preset"], "robots/mine.yaml"), "robot.preset: robot preset file not found: "),
    (set_key(["occupancy_map"], "nowhere.yaml"), "occupancy_map: occupancy map not found: "),
]


@pytest.mark.parametrize("mutate, message", ERRORS, ids=[m for _, m in ERRORS])
def test_invalid_scene(mutate, message, tmp_path):
    doc = base_doc()
    mutate(doc)
    with pytest.raises(SceneError) as err:
        parse_scene(copy.deepcopy(doc), tmp_path, "scene", source="scene.yaml")
    msg = str(err.value)
    assert message in msg
    assert "\n" not in msg
    assert isinstance(err.value, PlacementError)


@pytest.mark.parametrize(
    "text, message",
    [
        (FULL_SCENE.replace("resolution: 0.1", "resolution: .nan"), "resolution: expected a finite number, got nan"),
        (
            FULL_SCENE.replace("version: 1\n", "version: 1\nversion: 1\n"),
            "invalid YAML at line 2, column 1: duplicate key 'version'",
        ),
        (FULL_SCENE.replace("yaw: 0.3", "yaw: [0.3"), "invalid YAML at line 14"),
        ("", "the scene is empty"),
        ("- 1\n- 2\n", "expected a mapping, got a list"),
        (FULL_SCENE.replace("occupancy_map: floor.yaml", "occupancy_map: floor_negate.yaml"), "occupancy_map: "),
    ],
)
def test_invalid_scene_file(text, message, tmp_path):
    write_map(tmp_path)
    write_map(tmp_path, "floor_negate", negate=2)
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert str(err.value).startswith(str(path) + ": ")
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene(tmp_path / "nope.yaml")


def test_preset_path_is_relative_to_the_scene(tmp_path):
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "mine.yaml").write_text("name: mine\n")
    doc = base_doc()
    doc["robot"]["preset"] = "robots/mine.yaml"
    s = parse_scene(doc, tmp_path, "s")
    assert s.robot_preset == str(tmp_path / "robots" / "mine.yaml")


def test_planner_keys_are_documented():
    assert set(PLANNER_KEYS) == {
        "lambda_n",
        "lambda_m",
        "lambda_nh",
        "yaw_steps",
        "threshold",
        "threshold_quantile",
        "velocity_lambda",
        "velocity_k",
        "d_max",
        "grasp_yaws",
        "footprint_padding",
        "collision_padding",
        "ik_budget_ms",
        "time_budget_s",
        "memory_budget_gib",
        "time_polish",
        "face_target",
    }
