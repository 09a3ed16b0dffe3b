"""Hostile presets, footprints, xacro, ``robots init`` and files that are not regular files: each is one clean
error line (exit 2 from the CLI) or a correct result, quickly and without filling memory."""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from support.hostile import HUGE_HEX, one_line
from support.toy_robot import arm_urdf

from placement.errors import PlacementError, PresetError, RobotError
from placement.robots import description
from placement.robots.footprint import MAX_FOOTPRINT_VERTICES
from placement.robots.onboarding import base as init_base
from placement.robots.onboarding import urdf as init_urdf
from placement.robots.onboarding.propose import propose
from placement.robots.onboarding.render import render
from placement.robots.preset import load_robot
from placement.scene import OccupancyMapError, SceneError, load_occupancy_map, load_scene

PR2 = Path(__file__).resolve().parents[1] / "placement" / "robots" / "presets" / "pr2.yaml"


# -- numbers of any size and spelling ------------------------------------------------------------


def test_huge_integers_in_a_preset(tmp_path):
    text = PR2.read_text().replace("v_max: 0.5", f"v_max: {HUGE_HEX}")
    assert text != PR2.read_text()
    path = tmp_path / "p.yaml"
    path.write_text(text.replace("urdf: ", "urdf: " + str(PR2.parent) + "/", 1) if "package://" not in text else text)
    with pytest.raises(PlacementError) as err:
        load_robot(path)
    one_line(err.value, "v_max")


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
        one_line(err.value)
    assert time.perf_counter() - t0 < 10


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
    one_line(err.value, *words)
    assert time.perf_counter() - t0 < 10


def test_a_round_footprint_of_the_most_points_loads(tmp_path):
    n = MAX_FOOTPRINT_VERTICES
    pts = [(0.4 * math.cos(t), 0.4 * math.sin(t)) for t in np.linspace(0, 2 * math.pi, n, endpoint=False)]
    robot = load_robot(_preset(tmp_path, **{_footprint_line(): _footprint_text(pts)}))
    assert len(robot.footprint) == n


# -- xacro --------------------------------------------------------------------------------------

XACRO_HEAD = '<?xml version="1.0"?>\n<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r">\n'


@pytest.mark.slow
def test_xacro_expansions_are_bounded(tmp_path, monkeypatch):
    monkeypatch.setattr(description, "XACRO_TIMEOUT", 3.0)
    monkeypatch.setattr(description, "XACRO_MEMORY", 512 * 2**20)
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
        one_line(err.value, *words)
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
    one_line(err.value, *words)


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
def test_init_warns_on_a_mesh_it_leaves_out(tmp_path, scale, capfd):
    """One warning line of ours, and no C++ parser errors on the process's stderr (urdfdom prints
    one for every shape it cannot parse; the kinematic model is built without the shapes)."""
    _stl(tmp_path / "base.stl", 12)
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(arm_urdf().replace('<box size="0.6 0.5 0.3"/>', f'<mesh filename="base.stl" scale="{scale}"/>'))
    p = propose(urdf)
    assert any("base_link" in w and "left out" in w for w in p.warnings), p.warnings
    preset = tmp_path / "toy.yaml"
    preset.write_text(render(p))
    load_robot(preset)
    assert capfd.readouterr().err == ""


def test_init_bounds_mesh_triangles(tmp_path, monkeypatch):
    """A 2 M triangle base mesh (100 MB) is refused by its size before it is read; meshes that load
    but hold more triangles than the bound (lowered here to keep the test fast) are replaced by their
    convex hulls, heaviest first, with a warning giving the triangles before and after; only when the
    hulls are still too heavy is the robot refused."""
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
    p = propose(urdf)
    said = [w for w in p.warnings if "convex hulls" in w]
    assert len(said) == 1 and "6000 triangles" in said[0] and "5000" in said[0] and "base_link" in said[0], p.warnings
    after = int(said[0].split(" -> ")[1].split(" triangles")[0])
    assert 0 < after <= 5_000
    preset = tmp_path / "toy.yaml"
    preset.write_text(render(p))
    load_robot(preset)  # the proposal loads as it is
    monkeypatch.setattr(init_base, "MAX_COLLISION_TRIANGLES", 10)
    with pytest.raises(RobotError) as err:
        propose(urdf)
    one_line(err.value, "toy.urdf", "6000 triangles", "10 allowed", "convex hulls")
