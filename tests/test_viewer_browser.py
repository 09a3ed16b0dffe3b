"""The viewer in a real browser: headless Chromium opens the page served on loopback, and the
screenshots show the scene and the robot (not a blank canvas)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason="the viewer extra is not installed: pip install 'placement[view]'")

from placement.viewer import view_map, view_scene
from placement.viewer.screenshot import find_browser, screenshot

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"
#: [s] per screenshot try: software WebGL on a 2-core machine that runs the other test worker beside it
BROWSER_S = 120
pytestmark = pytest.mark.skipif(
    find_browser() is None, reason="no chromium on PATH (.ci/run installs Debian's chromium)"
)


def pixels(path: Path) -> np.ndarray:
    """(h, w, 3) uint8 of the 3D canvas part of a screenshot: the GUI panel (right) and the software
    rendering notice (top left) cut away."""
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB"))
    img = img[:, :930].copy()
    img[:160, :330] = 255
    return img


def robot_blue(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (b > r + 60) & (b > g + 15) & (b > 120)


def table_brown(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (r > g + 15) & (g > b + 15) & (r > 120)


@pytest.fixture(scope="module")
def shots(maps_dir, tmp_path_factory):
    """Screenshots of the example scene's first step with and without the robot."""
    out = tmp_path_factory.mktemp("shots")
    v = view_scene(EXAMPLE, maps=maps_dir, port=0)
    try:
        for box in v.content.toggles.values():  # no cost layer: its viridis blues would pass for the robot
            box.value = False
        v.content.show(0)
        # a page is drawn in steps (scene, then the robot's meshes): a shot that caught it early is
        # taken again, a few times at most
        # (the tables too: a shot of the second page once caught the room without them)
        with_robot = _shot(
            v.url,
            out / "robot.png",
            lambda im: robot_blue(im).sum() > 1500 and drawn(im) > 0.1 and table_brown(im).sum() > 1000,
        )
        v.content.robot_drawing.visible = False
        without = _shot(v.url, out / "no_robot.png", lambda im: drawn(im) > 0.1 and table_brown(im).sum() > 1000)
    finally:
        v.stop()
    return with_robot, without


def drawn(img: np.ndarray) -> float:
    """Fraction of the canvas that is not white."""
    return float((img.min(axis=2) < 200).mean())


def _shot(url: str, path: Path, ok, tries: int = 4) -> np.ndarray:
    for _ in range(tries):
        img = pixels(screenshot(url, path, timeout_s=BROWSER_S))
        if ok(img):
            break
    return img


def test_the_scene_is_drawn(shots):
    img = shots[0]
    colours = len(np.unique(img.reshape(-1, 3), axis=0))
    assert colours > 200, f"only {colours} colours: a blank or flat canvas"
    assert drawn(img) > 0.1  # the room covers a good part of the canvas (a blank page: 0)
    assert table_brown(img).sum() > 300  # the tables


def test_the_robot_is_drawn(shots):
    with_robot, without = shots
    blue_with, blue_without = robot_blue(with_robot).sum(), robot_blue(without).sum()
    # the robot's blue appears with it and goes with it (the footprint is blue too: a little stays);
    # pixel differences between two page loads are not compared (the rendering varies between loads)
    assert blue_with > 1500 and blue_without < blue_with / 3, (blue_with, blue_without)
    # the second page is as vivid as the first (a lost connection greys the whole canvas out)
    assert table_brown(without).sum() > 0.7 * table_brown(with_robot).sum()


def test_the_map_cloud_is_drawn(maps_dir, tmp_path):
    v = view_map(maps_dir, port=0)
    try:
        img = pixels(screenshot(v.url, tmp_path / "map.png", timeout_s=BROWSER_S))
    finally:
        v.stop()
    r, g, b = (img[..., i].astype(int) for i in range(3))
    coloured = (np.abs(r - g) + np.abs(g - b) > 60).sum()  # viridis points, not the white background
    assert coloured > 3000, coloured
