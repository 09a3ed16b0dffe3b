"""Hostile scenes and occupancy maps: each is one clean error line or a correct result, quickly and without
filling memory (numbers of any size and spelling, cost bounds, overlapping objects)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import coal
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.hostile import HUGE_DEC, HUGE_HEX, one_line

from placement.scene import OccupancyMapError, SceneError, SceneObject, load_occupancy_map, load_scene
from placement.scene.checks import TOLERANCE, overlapping_objects
from placement.scene.limits import MAX_OBSTACLES, MAX_POLYGON_VERTICES

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"


# -- numbers of any size and spelling ------------------------------------------------------------


def _scene_doc() -> dict:
    doc = yaml.safe_load(EXAMPLE.read_text())
    doc.pop("maps")
    return doc


def _scene_text(doc: dict | None = None, **replace) -> str:
    text = yaml.safe_dump(_scene_doc() if doc is None else doc, sort_keys=False, default_flow_style=None)
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def _scene_error(tmp_path, text: str, *words: str) -> str:
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    return one_line(err.value, *words)


# -- numbers of any size and spelling ------------------------------------------------------------


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("version: 1", f"version: {HUGE_DEC}", ["4300 digits"]),
        ("version: 1", f"version: {HUGE_HEX}", ["version", "integer of about"]),
        ("resolution: 0.05", f"resolution: {HUGE_HEX}", ["resolution", "too large"]),
        ("name: cup_1", f"name: {HUGE_HEX}", ["objects[0].name", "integer of about"]),
        ("version: 1", f"version: 1\n? {HUGE_HEX}\n: 3", ["unknown key", "integer of about"]),
        ("task:", f"planner: {{yaw_steps: {HUGE_HEX}}}\ntask:", ["planner.yaw_steps", "integer of about"]),
    ],
)
def test_huge_integers_in_a_scene(tmp_path, old, new, words):
    _scene_error(tmp_path, _scene_text(**{old: new}), *words)


def _occupancy(tmp_path, yaml_text: str, image: bytes = b"P5\n2 2\n255\n\xff\xff\xff\x00") -> Path:
    (tmp_path / "floor.pgm").write_bytes(image)
    path = tmp_path / "floor.yaml"
    path.write_text(yaml_text)
    return path


@pytest.mark.parametrize(
    "text, words",
    [
        ("image: floor.pgm\nresolution: 1.0e+307\norigin: [0, 0, 0]\n", ["resolution", "within"]),
        ("image: floor.pgm\nresolution: 0.05\norigin: [1.0e+300, 0, 0]\n", ["origin", "within"]),
        ("image: floor.pgm\nresolution: 1e307\norigin: [0, 0, 0]\n", ["resolution", "finite number"]),  # a string
        (f"image: floor.pgm\nresolution: {HUGE_HEX}\norigin: [0, 0, 0]\n", ["resolution", "integer of about"]),
        (f"image: floor.pgm\nresolution: 0.05\norigin: [0, {HUGE_HEX}, 0]\n", ["origin", "integer of about"]),
        (f"image: floor.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: {HUGE_HEX}\n", ["negate"]),
        (f"image: floor.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: {HUGE_HEX}\n", ["mode"]),
        (f"image: {HUGE_HEX}\nresolution: 0.05\norigin: [0, 0, 0]\n", ["image"]),
        (f"image: floor.pgm\nresolution: {HUGE_DEC}\norigin: [0, 0, 0]\n", ["4300 digits"]),
        ("image: floor.pgm\nresolution: 0x10\norigin: [0, 0, 0]\n", None),  # a hex 16 m: a valid map
        ("a: " + "[" * 100_000 + "]" * 100_000 + "\n", ["invalid YAML"]),
        ("a: " + "[" * 900 + "]" * 900 + "\n", ["missing key 'image'"]),  # deep, yet within libyaml's depth
    ],
)
def test_occupancy_map_numbers(tmp_path, text, words):
    path = _occupancy(tmp_path, text)
    if words is None:
        assert load_occupancy_map(path).resolution == 16.0
        return
    with pytest.raises(OccupancyMapError) as err:
        load_occupancy_map(path)
    one_line(err.value, *words)


def test_a_huge_image_is_refused_from_its_header(tmp_path):
    """40,000 x 40,000 pixels: refused before the raster is read (the file holds only the header)."""
    path = _occupancy(
        tmp_path, "image: floor.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", b"P5\n40000 40000\n255\n" + b"\0" * 1000
    )
    t0 = time.perf_counter()
    with pytest.raises(OccupancyMapError) as err:
        load_occupancy_map(path)
    assert time.perf_counter() - t0 < 1
    msg = one_line(err.value, "40000 x 40000", "allowed")
    assert "--" not in msg  # names no command-line option


# -- cost bounds --------------------------------------------------------------------------------


def test_too_many_obstacles_and_vertices(tmp_path):
    """Counted before any item is parsed: the items need not even be obstacles."""
    t0 = time.perf_counter()
    _scene_error(
        tmp_path,
        _scene_text(**{"obstacles:\n": "obstacles:\n" + "- 0\n" * (MAX_OBSTACLES + 1)}),
        "obstacles",
        f"entries, more than the {MAX_OBSTACLES} allowed",
    )
    pts = ", ".join(["[0, 0]"] * (MAX_POLYGON_VERTICES + 1))
    _scene_error(
        tmp_path,
        _scene_text(**{"obstacles:\n": f"obstacles:\n- {{name: round, polygon: [{pts}]}}\n"}),
        "polygon",
        f"more than the {MAX_POLYGON_VERTICES} allowed",
    )
    assert time.perf_counter() - t0 < 10


def test_a_large_round_polygon_is_accepted_quickly(tmp_path):
    n = MAX_POLYGON_VERTICES
    pts = [[9 + 0.3 * math.cos(2 * math.pi * i / n), 7 + 0.3 * math.sin(2 * math.pi * i / n)] for i in range(n)]
    path = tmp_path / "s.yaml"
    path.write_text(_scene_text(**{"obstacles:\n": f"obstacles:\n- {{name: round, polygon: {pts}}}\n"}))
    t0 = time.perf_counter()
    scene = load_scene(path)
    assert time.perf_counter() - t0 < 15
    assert len(scene.obstacle("round").shape.points) == n


def test_a_self_crossing_polygon_with_unequal_lobes_is_refused(tmp_path):
    _scene_error(
        tmp_path,
        _scene_text(
            **{"obstacles:\n": "obstacles:\n- {name: lobes, polygon: [[8, 6], [9, 6], [9, 7], [7.5, 5.5], [7.5, 6]]}\n"}
        ),
        "obstacles[0].polygon",
        "crosses or touches itself",
    )


# -- overlapping objects ------------------------------------------------------------------------


def test_overlapping_objects_are_refused_naming_both(tmp_path):
    doc = _scene_doc()
    doc["objects"][1]["position"] = [4.03, 4.1, 0.8]  # into cup_1 by 3 cm
    _scene_error(tmp_path, _scene_text(doc), "objects[1]", "'box_2' overlaps object 'cup_1'")
    doc["objects"][1]["position"] = [4.0, 4.1, 0.9]  # standing on the cup: touching is fine
    (tmp_path / "ok.yaml").write_text(_scene_text(doc))
    load_scene(tmp_path / "ok.yaml")


def _coal_distance(a: SceneObject, b: SceneObject) -> float:
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    req.enable_signed_distance = True
    return coal.distance(
        coal.Box(*a.size),
        coal.Transform3s(a.pose[:3, :3], a.pose[:3, 3]),
        coal.Box(*b.size),
        coal.Transform3s(b.pose[:3, :3], b.pose[:3, 3]),
        req,
        res,
    )


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1))
def test_object_overlap_agrees_with_coal(seed):
    """Away from the tolerance band, two boxes overlap exactly when coal's signed distance is negative."""
    rng = np.random.default_rng(seed)
    objs = []
    for k in range(2):
        q = rng.normal(size=4)
        upright = rng.random() < 0.3
        objs.append(
            SceneObject(
                f"o{k}",
                rng.uniform(-0.15, 0.15, 3),
                float(rng.uniform(-3, 3)),
                rng.uniform(0.02, 0.2, 3),
                None if upright else q / np.linalg.norm(q),
            )
        )
    d = _coal_distance(*objs)
    if abs(d) < 3 * TOLERANCE:
        return
    assert (overlapping_objects(objs) is not None) == (d < 0)
