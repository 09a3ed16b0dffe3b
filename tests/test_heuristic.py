"""The next-step heuristic (region_heuristic) against its plain definition, on random rooms: every
8-connected region of the whole grid labelled, its centre cell found over the whole grid, and the
whole cost map from it (navigation_cost) weighted by the region's share of the area."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from placement.planning.problems.manipulation import base_yaws
from placement.planning.settings import PlannerConfig
from placement.planning.world.footprints import BaseShape
from placement.planning.world.heuristic import region_heuristic
from placement.planning.world.layers import world_from_occupancy
from placement.planning.world.navigation import navigation_cost
from placement.scene.navgrid import NavGrid

#: 8-connected, as the base moves: the reference's structure
EIGHT = np.ones((3, 3), dtype=bool)


def plain_heuristic(region, world, min_region, reachable=None):
    if reachable is not None:
        region = region & reachable
    labels, n = ndimage.label(region, structure=EIGHT)
    total = np.zeros(world.nav.shape)
    if n == 0:
        return total
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    keep = [lab + 1 for lab in range(n) if sizes[lab] >= min_region * sizes.sum()]
    area = sum(sizes[lab - 1] for lab in keep)
    for lab in keep:
        cells = np.argwhere(labels == lab)
        centre = cells[np.argmin(((cells - cells.mean(axis=0)) ** 2).sum(axis=1))]
        cost, _ = navigation_cost(world.factor, world.feasible, centre, world.nav.resolution)
        total += (len(cells) / area) * cost
    return total


@pytest.mark.parametrize("seed", range(8))
def test_the_heuristic_is_its_plain_definition(seed):
    rng = np.random.default_rng(700 + seed)
    ny, nx = (int(v) for v in rng.integers(20, 45, size=2))
    nav = NavGrid((0.0, 0.0), 0.05, (ny, nx))
    occ = rng.random((ny, nx)) < 0.04
    world = world_from_occupancy(nav, occ, BaseShape(0.06, None, 0.0, base_yaws(8)), PlannerConfig())
    region = np.zeros((ny, nx), bool)
    for _ in range(int(rng.integers(0, 4))):  # a few blobs near each other, some below min_region
        y, x = int(rng.integers(0, ny - 6)), int(rng.integers(0, nx - 6))
        h, w = (int(v) for v in rng.integers(1, 6, size=2))
        region[y : y + h, x : x + w] = True
    region &= world.feasible
    min_region = float(rng.choice([0.0, 0.1, 0.3]))
    want = plain_heuristic(region, world, min_region)
    np.testing.assert_array_equal(region_heuristic(region, world, min_region), want)
    # the cells read only (the rest inf): the same values on them
    targets = rng.random((ny, nx)) < 0.1
    got = region_heuristic(region, world, min_region, targets)
    if region.any():
        np.testing.assert_allclose(got[targets], want[targets], rtol=1e-12, atol=0)
        assert np.isinf(got[~targets]).all()
    else:
        assert (got == 0).all()


def test_the_cached_heuristic_holds_values_on_every_cell_asked_for(tiny_maps):
    """A pick planned again with other grasps reads the next step's heuristic on other cells: the
    cached costs (computed on the first cells only, inf elsewhere) are computed again over both, and
    equal the whole map's on each cell asked for (the step-by-step methods called a re-planned pick
    unreachable)."""
    from pathlib import Path

    from placement.planning import Planner

    scene = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"
    problems = Planner(scene, "sequential", tiny_maps, warm=False).problems
    whole = problems.heuristic(1)
    finite = np.flatnonzero(np.isfinite(whole) & (whole > 0))
    assert finite.size > 20
    first, second = np.zeros(whole.shape, bool), np.zeros(whole.shape, bool)
    first.flat[finite[: finite.size // 2]] = True
    second.flat[finite[finite.size // 2 :]] = True
    for at in (first, second, first):
        got = problems.heuristic(1, at)
        np.testing.assert_allclose(got[at], whole[at], rtol=1e-12, atol=0)
