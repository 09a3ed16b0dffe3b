"""The base's 2D inputs: map_server values, unknown cells, Nav2 keepout and speed masks, and the floor
and the 2D map in the arm's collision model."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from support.occupancy import write_map, write_pgm
from support.scenes import base_doc

from placement.planning.settings import PlannerConfig
from placement.planning.world.footprints import BaseShape
from placement.planning.world.layers import base_layers, build_world
from placement.planning.world.navigation import speed_factor
from placement.scene import SceneError, parse_scene
from placement.scene.io import scene_to_dict
from placement.scene.masks import KeepoutMask, SpeedMask
from placement.scene.navgrid import NavGrid
from placement.scene.occupancy import load_map_image, load_occupancy_map

# the 4 x 3 image of support.occupancy as nav2_map_server publishes it, row 0 = lowest y:
# 0 -> 100, 254 -> 0, 205 (p 0.19608 > free 0.196) and 100 (p 0.61) -> between the thresholds
TRINARY = [[0, 0, -1, 100], [0, 100, 0, 0], [100, 0, 0, -1]]
# scale: rint(100 (p - 0.196) / (0.65 - 0.196)): 100 -> 91, 205 -> 0
SCALE = [[0, 0, 91, 100], [0, 100, 0, 0], [100, 0, 0, 0]]
BETWEEN = [[False, False, True, False], [False, False, False, False], [False, False, False, True]]


@pytest.mark.parametrize("mode, values", [("trinary", TRINARY), ("scale", SCALE)])
def test_map_image_values_as_nav2_publishes_them(tmp_path, mode, values):
    image = load_map_image(write_map(tmp_path, mode=mode))
    assert image.values.dtype == np.int8
    assert image.values.tolist() == values
    assert image.unknown.tolist() == BETWEEN
    assert image.resolution == 0.5 and image.origin == (1.0, 2.0, 0.0) and image.mode == mode


def test_unknown_cells_free_for_the_base_when_asked(tmp_path):
    path = write_map(tmp_path)
    occupied = load_occupancy_map(path).occupied
    free = load_occupancy_map(path, unknown="free").occupied
    assert free.tolist() == [[False, False, False, True], [False, True, False, False], [True, False, False, False]]
    np.testing.assert_array_equal(occupied, free | np.array(BETWEEN))


def _mask(tmp_path, name, pixels, **overrides):
    write_pgm(tmp_path / f"{name}.pgm", pixels)
    doc = {"image": f"{name}.pgm", "resolution": 0.5, "origin": [0.0, 0.0, 0.0], "free_thresh": 0.0}
    doc.update({"occupied_thresh": 1.0, "mode": "scale"} | overrides)
    (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(doc))
    return tmp_path / f"{name}.yaml"


def test_keepout_mask_closes_what_it_overlaps(tmp_path):
    # a 2 x 2 mask of 0.5 m cells; the top-left (file order) cell is keepout (black, value 100 in trinary)
    path = _mask(tmp_path, "keep", [[0, 254], [254, 254]], mode="trinary", free_thresh=0.196, occupied_thresh=0.65)
    mask = KeepoutMask(load_map_image(path))
    # a 0.25 m planning grid over [-0.25, 1.25)^2: the keepout cell is x in [0, 0.5), y in [0.5, 1)
    closed = mask.closed((-0.25, -0.25), 0.25, (6, 6))
    expected = np.zeros((6, 6), dtype=bool)
    expected[3:5, 1:3] = True
    np.testing.assert_array_equal(closed, expected)


def test_speed_mask_percent_and_absolute(tmp_path):
    # scale mode with thresholds 0 / 1: value = rint(100 p), p = (255 - v) / 255
    path = _mask(tmp_path, "speed", [[0, 128], [255, 204]])  # values 100, 50 (p 0.498), 0, 20
    image = load_map_image(path)
    assert image.values.tolist() == [[0, 20], [100, 50]]
    # percent, limit = 10 + 0.5 v: 0 -> no limit, 20 -> 20 %, 100 -> 60 %, 50 -> 35 %
    frac = SpeedMask(image, "percent", 10.0, 0.5).fraction(v_max=0.8)
    np.testing.assert_allclose(frac, [[1.0, 0.2], [0.6, 0.35]])
    # absolute m/s, limit = 0.01 v: 20 -> 0.2 m/s of 0.8, 100 -> 1.0 m/s (above v_max: no limit)
    frac = SpeedMask(image, "absolute", 0.0, 0.01).fraction(v_max=0.8)
    np.testing.assert_allclose(frac, [[1.0, 0.25], [1.0, 0.625]])
    # a limit of 0 or less closes the cell
    assert SpeedMask(image, "percent", -20.0, 1.0).fraction(0.8).tolist() == [[1.0, 0.0], [0.8, 0.3]]


def test_speed_slowdown_is_the_slowest_overlapped_cell(tmp_path):
    path = _mask(tmp_path, "speed", [[0, 128], [255, 204]])
    mask = SpeedMask(load_map_image(path), "percent", 0.0, 1.0)
    frac = mask.fraction(1.0)
    rng = np.random.default_rng(3)
    for _ in range(20):
        res = float(rng.uniform(0.1, 0.9))
        origin = (float(rng.uniform(-1, 0.5)), float(rng.uniform(-1, 0.5)))
        shape = (int(rng.integers(1, 8)), int(rng.integers(1, 8)))
        got = mask.slowdown(origin, res, shape, 1.0)
        # naive: every planning cell against every mask cell with an open overlap
        want = np.ones(shape)
        for j in range(shape[0]):
            for i in range(shape[1]):
                x0, y0 = origin[0] + i * res, origin[1] + j * res
                for r in range(2):
                    for c in range(2):
                        if x0 < 0.5 * (c + 1) - 1e-9 and x0 + res > 0.5 * c + 1e-9:
                            if y0 < 0.5 * (r + 1) - 1e-9 and y0 + res > 0.5 * r + 1e-9:
                                want[j, i] = min(want[j, i], frac[r, c])
        np.testing.assert_allclose(got, 1.0 / want)


def _scene(tmp_path, **keys):
    doc = base_doc()
    doc.update(keys)
    return parse_scene(doc, tmp_path, source=tmp_path / "scene.yaml")


def test_scene_keys_load_the_layers_and_round_trip(tmp_path):
    write_map(tmp_path)
    _mask(tmp_path, "keep", [[0, 254], [254, 254]], mode="trinary", free_thresh=0.196, occupied_thresh=0.65)
    _mask(tmp_path, "speed", [[0, 128], [255, 204]])
    scene = _scene(
        tmp_path,
        occupancy_map={"file": "floor.yaml", "unknown": "free", "arm_height": 1.5},
        keepout_mask="keep.yaml",
        speed_mask={"file": "speed.yaml", "type": "absolute", "multiplier": 0.01},
    )
    assert scene.occupancy.unknown == "free" and scene.occupancy.arm_height == 1.5
    assert scene.keepout.source == tmp_path / "keep.yaml"
    assert (scene.speed.type, scene.speed.base, scene.speed.multiplier) == ("absolute", 0.0, 0.01)
    doc = scene_to_dict(scene, relative_to=tmp_path)
    assert doc["occupancy_map"] == {"file": "floor.yaml", "unknown": "free", "arm_height": 1.5}
    assert doc["keepout_mask"] == "keep.yaml"
    assert doc["speed_mask"] == {"file": "speed.yaml", "type": "absolute", "base": 0.0, "multiplier": 0.01}
    again = parse_scene(doc, tmp_path)
    assert again.occupancy.unknown == "free" and again.speed.multiplier == 0.01


@pytest.mark.parametrize(
    "keys, message",
    [
        (
            {"occupancy_map": {"file": "floor.yaml", "unknown": "maybe"}},
            "occupancy_map.unknown: expected occupied or free or cost",
        ),
        ({"occupancy_map": {"unknown": "free"}}, "missing required key 'occupancy_map.file'"),
        ({"occupancy_map": {"file": "floor.yaml", "height": 1}}, "unknown key 'occupancy_map.height'"),
        ({"occupancy_map": {"file": "floor.yaml", "arm_height": -1}}, "occupancy_map.arm_height: must be > 0"),
        ({"keepout_mask": "nowhere.yaml"}, "keepout_mask: occupancy map not found"),
        ({"speed_mask": {"file": "floor.yaml", "type": "fast"}}, "speed_mask.type: expected percent or absolute"),
        ({"speed_mask": {"file": "floor.yaml", "base": "1"}}, "speed_mask.base: expected a number"),
    ],
)
def test_bad_layer_keys_are_one_line(tmp_path, keys, message):
    write_map(tmp_path)
    with pytest.raises(SceneError, match=message.replace(".", r"\.")) as err:
        _scene(tmp_path, **keys)
    assert "\n" not in str(err.value)


def test_world_closes_keepout_and_slows_by_the_speed_mask(tmp_path):
    # keepout: x in [0, 0.5), y in [0.5, 1); speed 50 % on x in [0.5, 1), y in [0, 0.5)
    _mask(tmp_path, "keep", [[0, 254], [254, 254]], mode="trinary", free_thresh=0.196, occupied_thresh=0.65)
    _mask(tmp_path, "speed", [[255, 255], [255, 128]])
    scene = _scene(tmp_path, keepout_mask="keep.yaml", speed_mask="speed.yaml")
    nav = scene.nav_grid()
    closed, slowdown = base_layers(scene, nav, 1.0)
    cfg = PlannerConfig()
    world = build_world(scene, BaseShape(0.1, None, 0.0, np.zeros(1)), cfg, 1.0)
    centre = NavGrid.cell
    inside = centre(nav, 0.25, 0.75)
    assert closed[inside] and world.occupied[inside] and not world.feasible[inside]
    slow = centre(nav, 0.75, 0.25)
    assert slowdown[slow] == pytest.approx(1 / 0.5, rel=0.01)
    eq4 = speed_factor(world.distance, cfg.velocity_lambda, cfg.velocity_k, cfg.d_max)
    np.testing.assert_allclose(world.factor, eq4 * slowdown)
    far = centre(nav, 3.0, 3.0)
    assert slowdown[far] == 1.0 and not closed[far]


def test_unknown_cells_at_a_cost_are_open_and_slower(tmp_path):
    # the map of support.occupancy: 0.5 m cells from (1, 2); its unknown cells (BETWEEN) are
    # x in [2, 2.5), y in [2, 2.5) and x in [2.5, 3), y in [3, 3.5)
    write_map(tmp_path)
    occ = load_occupancy_map(tmp_path / "floor.yaml", unknown="cost", unknown_cost=4.0)
    np.testing.assert_array_equal(occ.occupied, load_occupancy_map(tmp_path / "floor.yaml", unknown="free").occupied)
    assert occ.unknown_cells.tolist() == BETWEEN and occ.unknown_cost == 4.0
    scene = _scene(tmp_path, occupancy_map={"file": "floor.yaml", "unknown": "cost", "unknown_cost": 4})
    nav = scene.nav_grid()
    closed, slowdown = base_layers(scene, nav, 1.0)
    centre = NavGrid.cell
    for x, y, want in [(2.25, 2.25, 4.0), (2.75, 3.25, 4.0), (1.25, 2.25, 1.0), (2.25, 2.75, 1.0)]:
        assert slowdown[centre(nav, x, y)] == want, (x, y)
        assert not closed[centre(nav, x, y)]
    assert closed[centre(nav, 1.75, 2.75)]  # certain occupied (100): closed whatever the policy
    outside = centre(nav, nav.origin[0] + 0.01, nav.origin[1] + 0.01)  # beyond the map: unknown too
    assert slowdown[outside] == 4.0 and not closed[outside]
    doc = scene_to_dict(scene, relative_to=tmp_path)
    assert doc["occupancy_map"] == {"file": "floor.yaml", "unknown": "cost", "unknown_cost": 4.0}
    assert parse_scene(doc, tmp_path).occupancy.unknown_cost == 4.0
    with pytest.raises(SceneError, match=r"occupancy_map\.unknown_cost: applies to unknown: cost only"):
        _scene(tmp_path, occupancy_map={"file": "floor.yaml", "unknown": "free", "unknown_cost": 4})
    with pytest.raises(SceneError, match=r"occupancy_map\.unknown_cost: must be >= 1"):
        _scene(tmp_path, occupancy_map={"file": "floor.yaml", "unknown": "cost", "unknown_cost": 0.5})
