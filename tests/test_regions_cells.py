"""Regions kept on their cells ((G, n) over the cells any group holds) against the same operations on
whole-grid (G, ny, nx) masks, on random regions: building, reading, removing cells, comparing, taking
and stacking groups."""

from __future__ import annotations

import numpy as np
import pytest

from placement.planning.program.regions import Regions

GROUPS = (("left", "top"), ("right", "top"), ("right", "side"))


def random_dense(rng, ny, nx, G=3, density=0.2):
    masks = rng.random((G, ny, nx)) < density
    node = np.where(masks, rng.random((G, ny, nx)), 0.0)
    return masks, node


def test_a_literal_region():
    #   a 2 x 4 grid, group 0 on cells 1 and 6, group 1 on cell 6:
    #   . 0 . .
    #   . . 01 .
    masks = np.zeros((2, 2, 4), bool)
    masks[0, 0, 1] = masks[0, 1, 2] = masks[1, 1, 2] = True
    reg = Regions.of(GROUPS[:2], masks)
    assert reg.cells.tolist() == [1, 6]
    assert reg.masks.tolist() == [[True, True], [False, True]]
    assert reg.shape == (2, 4)
    assert reg.has(0, 1) and not reg.has(1, 1) and reg.has(1, 6) and not reg.has(0, 0)
    assert reg.where(6) == 1 and reg.where(7) is None
    assert reg.mask([1]).astype(int).tolist() == [[0, 0, 0, 0], [0, 0, 1, 0]]


@pytest.mark.parametrize("seed", range(12))
def test_cells_agree_with_whole_grid_masks(seed):
    rng = np.random.default_rng(seed)
    ny, nx = (int(v) for v in rng.integers(1, 12, size=2))
    masks, node = random_dense(rng, ny, nx, density=float(rng.uniform(0.0, 0.5)))
    reg = Regions.of(GROUPS, masks, node)
    assert np.array_equal(reg.dense(), masks)
    assert np.array_equal(reg.mask(), masks.any(axis=0))
    assert reg.any() == bool(masks.any())
    for groups in ([0], [2, 1], [0, 1, 2]):
        assert np.array_equal(reg.mask(groups), masks[groups].any(axis=0))
    for g in range(3):
        for f in range(ny * nx):
            assert reg.has(g, f) == bool(masks[g].flat[f])
            assert reg.node_at(g, f) == (float(node[g].flat[f]) if reg.where(f) is not None else 0.0)
    # removing a square around a cell, as a rejection does
    f, g, r = int(rng.integers(0, ny * nx)), int(rng.integers(0, 3)), int(rng.integers(0, 3))
    iy, ix = divmod(f, nx)
    want = masks.copy()
    want[g, max(iy - r, 0) : iy + r + 1, max(ix - r, 0) : ix + r + 1] = False
    less = reg.without(g, f, r)
    assert np.array_equal(less.dense(), want)
    assert less.node is reg.node  # the same node costs: a program keeps the step's layer
    assert less.within(reg) and (reg.within(less) == np.array_equal(want, masks))
    # taking groups keeps their cells, node costs and settings
    sub = Regions.of(GROUPS, masks, node, (0.0, 0.1, 0.2)).take([2, 0])
    assert sub.groups == (GROUPS[2], GROUPS[0]) and sub.settings == (0.2, 0.0)
    assert np.array_equal(sub.dense(), masks[[2, 0]])


@pytest.mark.parametrize("seed", range(8))
def test_within_is_the_subset_of_whole_grid_masks(seed):
    rng = np.random.default_rng(100 + seed)
    ny, nx = (int(v) for v in rng.integers(1, 9, size=2))
    a, _ = random_dense(rng, ny, nx)
    b = a & (rng.random(a.shape) < 0.7) if seed % 2 else a | (rng.random(a.shape) < 0.05)
    ra, rb = Regions.of(GROUPS, a), Regions.of(GROUPS, b)
    assert rb.within(ra) == (not np.any(b & ~a))
    assert ra.within(rb) == (not np.any(a & ~b))
    assert not ra.within(Regions.of(GROUPS[::-1], a[::-1]))  # other groups
    empty = Regions.of(GROUPS, np.zeros_like(a))
    assert empty.within(ra) and ra.within(empty) == (not a.any())


@pytest.mark.parametrize("seed", range(6))
def test_stacked_regions_are_the_concatenated_masks(seed):
    rng = np.random.default_rng(200 + seed)
    ny, nx = (int(v) for v in rng.integers(1, 10, size=2))
    parts, dense = [], []
    for k in range(int(rng.integers(1, 4))):
        masks, _ = random_dense(rng, ny, nx, G=int(rng.integers(0, 3)))
        parts.append(Regions.of(GROUPS[: masks.shape[0]], masks, None, (0.1 * k,) * masks.shape[0]))
        dense.append(masks)
    reg = Regions.stacked(parts, (ny, nx))
    assert np.array_equal(reg.dense(), np.concatenate(dense))
    assert reg.groups == tuple(g for p in parts for g in p.groups)
    assert reg.settings == tuple(t for p in parts for t in (p.settings or ()))
