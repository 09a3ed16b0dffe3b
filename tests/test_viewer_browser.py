"""The viewer in a real browser: headless Chromium opens the page served on loopback, and the
screenshots show the scene and the robot (not a blank canvas)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason="the viewer extra is not installed: pip install 'placement[view]'")

from support.browser import Browser, image

from placement.viewer import view_map, view_scene
from placement.viewer.screenshot import find_browser, panel_filled, screenshot

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"
#: [s] per screenshot try of the package's ``screenshot``
BROWSER_S = 120
#: [s] for a page to be drawn (45 s on the busy development machine)
PAGE_S = 240
#: [s] for a drawn page to show a change sent by the server (5 s on the busy development machine)
UPDATE_S = 120
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(find_browser() is None, reason="no chromium on PATH (.ci/run installs Debian's chromium)"),
]


def pixels(path: Path) -> np.ndarray:
    """(h, w, 3) uint8 of the 3D canvas part of a screenshot: the GUI panel (right) and the software
    rendering notice (top left) cut away."""
    img = image(path)[:, :930].copy()
    img[:160, :330] = 255
    return img


def robot_blue(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (b > r + 60) & (b > g + 15) & (b > 120)


def table_brown(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (r > g + 15) & (g > b + 15) & (r > 120)


def drawn(img: np.ndarray) -> float:
    """Fraction of the canvas that is not white."""
    return float((img.min(axis=2) < 200).mean())


def loaded(ok: Callable[[np.ndarray], bool]) -> Callable[[Path], bool]:
    """``ok`` of a screenshot's canvas, on a loaded page still connected to its server (see ``panel_filled``)."""
    return lambda path: panel_filled(path) and ok(pixels(path))


@pytest.fixture(scope="module")
def browser():
    """One headless Chromium for the file's pages (a launch and a fresh profile per picture cost more)."""
    b = Browser()
    try:
        yield b
    finally:
        b.close()


@pytest.fixture(scope="module")
def shots(browser, maps_dir, tmp_path_factory):
    """Screenshots of the example scene's first step with the robot, then of the same page after the
    server hid the robot: one page load (a page takes tens of seconds to draw in software
    WebGL), each picture taken as soon as the page shows what it waits for."""
    out = tmp_path_factory.mktemp("shots")
    v = view_scene(EXAMPLE, maps=maps_dir, port=0)
    try:
        for box in v.content.toggles.values():  # no cost layer: its viridis blues would pass for the robot
            box.value = False
        v.content.show(0)
        with browser.page(v.url) as page:
            # a page is drawn in steps (scene, then the robot's meshes): wait for the robot and the tables
            robot = page.wait_for(
                out / "robot.png",
                loaded(lambda im: robot_blue(im).sum() > 1500 and drawn(im) > 0.1 and table_brown(im).sum() > 1000),
                PAGE_S,
            )
            with_robot = pixels(robot)
            blue = robot_blue(with_robot).sum()
            v.content.robot_drawing.visible = False
            # until the hidden robot is gone from the page (the test then says whether it went)
            without = pixels(
                page.wait_for(
                    out / "no_robot.png",
                    loaded(
                        lambda im: robot_blue(im).sum() < blue / 3 and drawn(im) > 0.1 and table_brown(im).sum() > 1000
                    ),
                    UPDATE_S,
                )
            )
    finally:
        v.stop()
    return with_robot, without


def test_the_scene_is_drawn(shots):
    img = shots[0]
    rgb = img.astype(np.uint32)
    colours = len(np.unique(rgb[..., 0] << 16 | rgb[..., 1] << 8 | rgb[..., 2]))  # a colour as one int: fast
    assert colours > 200, f"only {colours} colours: a blank or flat canvas"
    assert drawn(img) > 0.1  # the room covers a good part of the canvas (a blank page: 0)
    assert table_brown(img).sum() > 300  # the tables


def test_the_robot_is_drawn(shots):
    with_robot, without = shots
    blue_with, blue_without = robot_blue(with_robot).sum(), robot_blue(without).sum()
    # the robot's blue appears with it and goes with it (the footprint is blue too: a little stays);
    # pixel differences between two pictures are not compared (the rendering varies between frames)
    assert blue_with > 1500 and blue_without < blue_with / 3, (blue_with, blue_without)
    # the page is as vivid after the change as before (a lost connection greys the whole canvas out)
    assert table_brown(without).sum() > 0.7 * table_brown(with_robot).sum()


def coloured(img: np.ndarray) -> int:
    """Pixels of the viridis points (not the white background or the grey robot)."""
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return int((np.abs(r - g) + np.abs(g - b) > 60).sum())


def test_the_map_cloud_is_drawn(browser, maps_dir, tmp_path):
    v = view_map(maps_dir, port=0)
    try:
        with browser.page(v.url) as page:
            img = pixels(page.wait_for(tmp_path / "map.png", loaded(lambda im: coloured(im) > 3000), PAGE_S))
    finally:
        v.stop()
    assert coloured(img) > 3000, coloured(img)


def test_screenshot_writes_the_page_at_its_size(tmp_path):
    """The package's screenshot (the documentation's pictures): a browser of its own writes a PNG of the
    page at the size asked; a page without the viewer's panel is taken again (tries) and the last kept."""
    page = "data:text/html,<body style='margin:0;background:rgb(200,30,40)'></body>"
    path = screenshot(page, tmp_path / "red.png", size=(640, 400), budget_ms=500, timeout_s=BROWSER_S, tries=2)
    img = image(path)
    assert img.shape == (400, 640, 3), img.shape
    red = (np.abs(img.astype(int) - [200, 30, 40]).max(axis=2) < 10).mean()
    assert red > 0.95 and not panel_filled(path), red
