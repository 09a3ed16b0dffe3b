"""Rasterising shapes: the bounding-box-limited marking equals testing every cell centre."""

from __future__ import annotations

import numpy as np
import pytest

from placement.planning.world.layers import add_shape
from placement.scene import Box, Cylinder, Polygon
from placement.scene.navgrid import NavGrid


def _every_cell(shape, nav: NavGrid) -> np.ndarray:
    xs, ys = nav.centres()
    X, Y = np.meshgrid(xs, ys)
    if isinstance(shape, Box):
        c, s = np.cos(shape.yaw), np.sin(shape.yaw)
        lx = c * (X - shape.center[0]) + s * (Y - shape.center[1])
        ly = -s * (X - shape.center[0]) + c * (Y - shape.center[1])
        return (np.abs(lx) <= shape.size[0] / 2) & (np.abs(ly) <= shape.size[1] / 2)
    if isinstance(shape, Cylinder):
        return (X - shape.center[0]) ** 2 + (Y - shape.center[1]) ** 2 <= shape.radius**2
    from matplotlib.path import Path  # an independent point-in-polygon test

    return Path(np.asarray(shape.points)).contains_points(np.c_[X.ravel(), Y.ravel()]).reshape(X.shape)


@pytest.mark.parametrize("seed", range(40))
def test_add_shape_equals_testing_every_cell(seed):
    rng = np.random.default_rng(seed)
    nav = NavGrid((rng.uniform(-1, 1), rng.uniform(-1, 1)), 0.05, (60, 80))
    kind = seed % 3
    centre = [rng.uniform(-1, 5), rng.uniform(-1, 4), 0.5]  # partly or wholly off the grid too
    if kind == 0:
        shape = Box(centre, [rng.uniform(0.05, 2), rng.uniform(0.05, 2), 1.0], rng.uniform(-3, 3))
    elif kind == 1:
        shape = Cylinder(centre, rng.uniform(0.02, 1.0), 1.0)
    else:
        angles = np.sort(rng.uniform(0, 2 * np.pi, 6))
        radii = rng.uniform(0.2, 1.2, 6)
        shape = Polygon(np.c_[centre[0] + radii * np.cos(angles), centre[1] + radii * np.sin(angles)])
    got = np.zeros(nav.shape, bool)
    add_shape(got, shape, nav)
    want = _every_cell(shape, nav)
    if kind == 2:  # cell centres exactly on an edge may go either way between the two tests
        assert (got != want).sum() <= 2
    else:
        assert np.array_equal(got, want)
