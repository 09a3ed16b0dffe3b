"""The heuristic towards the next step (paper section IV-C): area-weighted costs to its regions."""

from __future__ import annotations

import numpy as np

from placement.kernels.navigation import components8
from placement.planning.world.layers import World
from placement.planning.world.navigation import costs_at, navigation_cost


def region_heuristic(
    region: np.ndarray,
    world: World,
    min_region: float,
    targets: np.ndarray | None = None,
    reachable: np.ndarray | None = None,
) -> np.ndarray:
    """Navigation cost [m] towards the connected regions of ``region`` (ny, nx) bool.

    ``reachable``: optional (ny, nx) bool, the cells the base can get to
    (:func:`~placement.planning.world.navigation.reachable_from`); the
    region's other cells are left out, since a region in a pocket of floor the base cannot reach
    would make the cost infinite everywhere. Each 8-connected region contributes the cost map from its centre cell (the region cell nearest
    its centroid), weighted by its share of the area. Regions under ``min_region`` of the total
    area would add a full cost map each for a negligible weight: they are dropped and the weights
    renormalised. ``targets``: optional (ny, nx) bool of the cells that will be read (the cost maps
    then stop once those are settled; other cells are inf). All zeros when ``region`` is empty.
    """
    if reachable is not None:
        region = region & reachable
    total = np.zeros(world.nav.shape)
    ys, xs = np.nonzero(region)
    if ys.size == 0:
        return total
    # the regions are labelled within their bounding box (a step's regions lie near its target): the
    # same components, numbered in the same raster order, without passes over the whole grid
    y0, x0 = int(ys.min()), int(xs.min())
    labels, boxes = components8(np.ascontiguousarray(region[y0 : int(ys.max()) + 1, x0 : int(xs.max()) + 1]))
    n = len(boxes)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    keep = [lab + 1 for lab in range(n) if sizes[lab] >= min_region * sizes.sum()]
    area = sum(sizes[lab - 1] for lab in keep)
    at = None if targets is None else np.flatnonzero(targets)
    if at is not None:  # as the whole maps have it: inf off the cells read
        total = np.full(world.nav.shape, np.inf)
        total.flat[at] = 0.0
    for lab in keep:
        r0, r1, c0, c1 = (int(v) for v in boxes[lab - 1])
        cells = np.argwhere(labels[r0:r1, c0:c1] == lab) + (y0 + r0, x0 + c0)
        centroid = cells.mean(axis=0)
        centre = cells[np.argmin(((cells - centroid) ** 2).sum(axis=1))]
        if at is None:
            cost, _ = navigation_cost(world.factor, world.feasible, centre, world.nav.resolution)
            total += (len(cells) / area) * cost
        else:  # the cells read only
            cost, _ = costs_at(world.factor, world.feasible, centre, world.nav.resolution, at)
            total.flat[at] += (len(cells) / area) * cost
    return total
