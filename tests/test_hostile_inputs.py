"""Hostile inputs to scenes, occupancy maps, presets, footprints, xacro and ``robots init``: each is one
clean error line (exit 2 from the CLI) or a correct result, quickly and without filling memory."""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
import time
from pathlib import Path

import coal
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from robots_init_data import arm_urdf

from placement.errors import PlacementError, PresetError, RobotError
from placement.robots.footprint import MAX_FOOTPRINT_VERTICES
from placement.robots.onboarding import base as init_base
from placement.robots.onboarding import urdf as init_urdf
from placement.robots.onboarding.propose import propose
from placement.robots.preset import load_robot
from placement.scene import OccupancyMapError, SceneError, SceneObject, load_occupancy_map, load_scene
from placement.scene.checks import TOLERANCE, overlapping_objects
from placement.scene.limits import MAX_OBSTACLES, MAX_POLYGON_VERTICES

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"
PR2 = Path(__file__).resolve().parents[1] / "placement" / "robots" / "presets" / "pr2.yaml"
HUGE_DEC = "7" * 5000
HUGE_HEX = "0x" + "f" * 5000


def _one_line(exc: BaseException, *words: str) -> str:
    msg = str(exc)
    assert "\n" not in msg and len(msg) < 1000, msg
    for w in words:
        assert w in msg, msg
    return msg


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
    return _one_line(err.value, *words)


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


def test_huge_integers_in_a_preset(tmp_path):
    text = PR2.read_text().replace("v_max: 0.5", f"v_max: {HUGE_HEX}")
    assert text != PR2.read_text()
    path = tmp_path / "p.yaml"
    path.write_text(text.replace("urdf: ", "urdf: " + str(PR2.parent) + "/", 1) if "package://" not in text else text)
    with pytest.raises(PlacementError) as err:
        load_robot(path)
    _one_line(err.value, "v_max")


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
    _one_line(err.value, *words)


def test_a_huge_image_is_refused_from_its_header(tmp_path):
    """40,000 x 40,000 pixels: refused before the raster is read (the file holds only the header)."""
    path = _occupancy(
        tmp_path, "image: floor.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", b"P5\n40000 40000\n255\n" + b"\0" * 1000
    )
    t0 = time.perf_counter()
    with pytest.raises(OccupancyMapError) as err:
        load_occupancy_map(path)
    assert time.perf_counter() - t0 < 1
    msg = _one_line(err.value, "40000 x 40000", "allowed")
    assert "--" not in msg  # names no command-line option


# -- files that are not regular files -----------------------------------------------------------


@pytest.fixture
def specials(tmp_path):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.yaml"
    zero.symlink_to("/dev/zero")
    loop = tmp_path / "loop.yaml"
    loop.symlink_to(tmp_path / "loop2.yaml")
    (tmp_path / "loop2.yaml").symlink_to(loop)
    big = tmp_path / "big.yaml"
    with open(big, "wb") as f:
        f.truncate(200 * 2**20)  # sparse: 200 MB that take no disk
    return {"fifo": fifo, "zero": zero, "loop": loop, "big": big}


@pytest.mark.parametrize("kind", ["fifo", "zero", "loop", "big"])
def test_special_files_are_refused_at_once(specials, tmp_path, kind):
    path = specials[kind]
    occ = tmp_path / "occ.yaml"
    occ.write_text(f"image: {path}\nresolution: 0.05\norigin: [0, 0, 0]\n")
    urdf_preset = tmp_path / "p.yaml"
    urdf_preset.write_text(PR2.read_text().replace("urdf: ", f"urdf: {path} #", 1))
    t0 = time.perf_counter()
    for load, arg, error in (
        (load_scene, path, SceneError),
        (load_robot, path, PlacementError),
        (load_occupancy_map, occ, OccupancyMapError),
        (load_robot, urdf_preset, PlacementError),
        (propose, path, RobotError),
    ):
        with pytest.raises(error) as err:
            load(arg)
        _one_line(err.value)
    assert time.perf_counter() - t0 < 10


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


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
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


# -- presets and footprints ---------------------------------------------------------------------


def _preset(tmp_path, **replace) -> Path:
    text = PR2.read_text()
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new, 1)
    path = tmp_path / "p.yaml"
    path.write_text(text)
    return path


def _footprint_text(points) -> str:
    return "footprint: [" + ", ".join(f"[{x:.9e}, {y:.9e}]" for x, y in points) + "]"  # YAML 1.1 floats


def _footprint_line() -> str:
    return next(line for line in PR2.read_text().splitlines() if line.startswith("footprint"))


@pytest.mark.parametrize(
    "points, words",
    [
        ([(1e300, -0.3), (1e300, 0.3), (-0.3, 0.3), (-0.3, -0.3)], ["footprint[0]", "from the base frame's origin"]),
        (
            [(math.cos(t), math.sin(t)) for t in np.linspace(0, 2 * math.pi, 5_000, endpoint=False)],
            ["footprint", f"{MAX_FOOTPRINT_VERTICES} allowed"],
        ),
        ([(0.3, 0.3), (-0.3, -0.3), (0.3, -0.3), (-0.3, 0.3)], ["crosses itself"]),
    ],
)
def test_hostile_footprints(tmp_path, points, words):
    t0 = time.perf_counter()
    with pytest.raises(PresetError) as err:
        load_robot(_preset(tmp_path, **{_footprint_line(): _footprint_text(points)}))
    _one_line(err.value, *words)
    assert time.perf_counter() - t0 < 10


def test_a_round_footprint_of_the_most_points_loads(tmp_path):
    n = MAX_FOOTPRINT_VERTICES
    pts = [(0.4 * math.cos(t), 0.4 * math.sin(t)) for t in np.linspace(0, 2 * math.pi, n, endpoint=False)]
    robot = load_robot(_preset(tmp_path, **{_footprint_line(): _footprint_text(pts)}))
    assert len(robot.footprint) == n


# -- xacro --------------------------------------------------------------------------------------

XACRO_HEAD = '<?xml version="1.0"?>\n<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r">\n'


def test_xacro_expansions_are_bounded(tmp_path, monkeypatch):
    monkeypatch.setattr(init_urdf, "XACRO_TIMEOUT", 3.0)
    monkeypatch.setattr(init_urdf, "XACRO_MEMORY", 512 * 2**20)
    slow = tmp_path / "slow.xacro"
    slow.write_text(XACRO_HEAD + '<xacro:property name="x" value="${9**9**9}"/><link name="${x}"/></robot>')
    lines = [XACRO_HEAD, '<xacro:property name="p0" value="xxxxxxxxxxxxxxxx"/>']
    lines += [f'<xacro:property name="p{i}" value="${{p{i - 1}}}${{p{i - 1}}}"/>' for i in range(1, 40)]
    big = tmp_path / "big.xacro"
    big.write_text("\n".join(lines) + '<link name="${p39}"/></robot>')
    for path, words in ((slow, ["within 3 s"]), (big, ["does not expand"])):
        t0 = time.perf_counter()
        with pytest.raises(RobotError) as err:
            init_urdf.load_description(path)
        _one_line(err.value, *words)
        assert time.perf_counter() - t0 < 30


# -- robots init --------------------------------------------------------------------------------


def _stl(path: Path, n: int, scale: float = 0.25) -> None:
    rng = np.random.default_rng(0)
    rec = np.zeros(n, dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = (rng.random((n, 3, 3)) * 2 - 1) * scale
    path.write_bytes(b"\0" * 80 + struct.pack("<I", n) + rec.tobytes())


@pytest.mark.parametrize(
    "change, words",
    [
        (('<limit lower="-2" upper="2"', '<limit lower="2" upper="-2"'), ["would not load", "no usable limits"]),
        (('<axis xyz="0 1 0"/><limit lower="-2"', '<axis xyz="0 0 0"/><limit lower="-2"'), ["no usable axis"]),
        (('<box size="0.6 0.5 0.3"/>', '<box size="1e300 1e300 0.3"/>'), ["would not load", "footprint"]),
    ],
)
def test_init_refuses_what_check_would_refuse(tmp_path, change, words):
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(arm_urdf().replace(*change, 1))
    with pytest.raises(RobotError) as err:
        propose(urdf, tmp_path / "toy.yaml")
    _one_line(err.value, *words)


def test_init_cli_exits_2_and_writes_nothing(tmp_path):
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(arm_urdf().replace('<limit lower="-2" upper="2"', '<limit lower="2" upper="-2"', 1))
    out = tmp_path / "toy.yaml"
    run = subprocess.run(
        [sys.executable, "-m", "placement.cli.main", "robots", "init", str(urdf), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert lines[-1].startswith("error: ") and "no usable limits" in lines[-1] and "Traceback" not in run.stderr
    assert not out.exists()


@pytest.mark.parametrize("scale", ["0 0 0", "nan nan nan"])
def test_init_warns_on_a_mesh_it_leaves_out(tmp_path, scale):
    _stl(tmp_path / "base.stl", 12)
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(arm_urdf().replace('<box size="0.6 0.5 0.3"/>', f'<mesh filename="base.stl" scale="{scale}"/>'))
    p = propose(urdf)
    assert any("base_link" in w and "left out" in w for w in p.warnings), p.warnings


def test_init_bounds_mesh_triangles(tmp_path, monkeypatch):
    """A 2 M triangle base mesh (100 MB) is refused by its size before it is read; a mesh that loads
    is refused when it holds more triangles than the bound (lowered here to keep the test fast)."""
    huge = tmp_path / "huge.stl"
    with open(huge, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", 2_000_000))
        f.truncate(84 + 50 * 2_000_000)
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(arm_urdf().replace('<box size="0.6 0.5 0.3"/>', '<mesh filename="huge.stl"/>'))
    t0 = time.perf_counter()
    p = propose(urdf)
    assert time.perf_counter() - t0 < 30
    assert any("huge.stl" in w and "MiB allowed" in w for w in p.warnings), p.warnings
    monkeypatch.setattr(init_base, "MAX_COLLISION_TRIANGLES", 5_000)
    _stl(tmp_path / "base.stl", 6_000)
    urdf.write_text(arm_urdf().replace('<box size="0.6 0.5 0.3"/>', '<mesh filename="base.stl"/>'))
    with pytest.raises(RobotError) as err:
        propose(urdf)
    _one_line(err.value, "6000 triangles", "5000 allowed")
