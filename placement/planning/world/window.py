"""The part of a building's map that a task needs: the planning window.

A scene on a SLAM map of a whole floor (60 m across: 1.5 M cells of 5 cm) would make every cost map,
distance transform and footprint test cover the whole building, though the task happens at a few
tables. With an occupancy map and no ``bounds`` of its own, the planner works on a window of the
scene's grid instead: the task's things (start, obstacles, objects, place locations, trajectories),
and for each target the route the base would take to it from the start, grown by
:data:`WINDOW_MARGIN`.

The routes come from the map alone, at its own resolution: free cells (with the map's unknown-cell
policy), 8-connected, from the start to the cheapest such cell within :data:`TARGET_RADIUS` of each
target, over the cells clear of occupied ones by the base's outer radius (drivable at any yaw), or
where there is no such route by its inner radius (a door the base may pass turned just so). The
window holds one route to every target, not every route: a detour that would leave the window is
not planned (give the scene ``bounds`` to plan over more of the map). After the world is built on
the window, :func:`serves` checks that the base still gets near every target from the start. If
not (the map's route passed a gap too narrow for the base as the planner rasterises it), the world
is built on the whole grid and cut to the window of the planner's own cheapest routes
(:func:`route_window`): exact, at the cost of building the whole grid once.

Inside the window everything is exact: :func:`~placement.planning.world.layers.build_world` rasterises the
window grown by a halo of the base's reach and the Eq. 4 slowdown distance, then cuts the halo off,
so each window cell has the layers it has on the whole grid. A window that would keep more than
:data:`MIN_SAVING` of the grid's cells is not used.
"""

from __future__ import annotations

import math

import numpy as np

from placement.errors import PlacementError
from placement.planning.arrays import BoolArray, FloatArray
from placement.planning.world.footprints import PAD_SLACK, BaseShape
from placement.planning.world.navigation import distance_map, extract_path, navigation_cost, reachable_from
from placement.scene import OccupancyMap, Scene
from placement.scene.limits import things_extent
from placement.scene.navgrid import NavGrid

#: [m] the window reaches this far beyond the task's things and routes.
WINDOW_MARGIN = 3.0
#: [m] base cells this close to a target may serve it (farther than any arm the planner has reaches).
TARGET_RADIUS = 2.0
#: a window of more than this share of the grid's cells is not worth it.
MIN_SAVING = 0.6

#: (j0, j1, i0, i1): rows j0..j1-1 and columns i0..i1-1 of the scene's grid
Window = tuple[int, int, int, int]


def _targets(scene: Scene) -> list[tuple[float, float]]:
    """(x, y) [m] of everything the arm must reach: objects, place locations, trajectory poses."""
    out = [(float(o.position[0]), float(o.position[1])) for o in scene.objects]
    out += [(float(p.position[0]), float(p.position[1])) for p in scene.place_locations]
    for t in scene.trajectories:
        out += [(float(x), float(y)) for x, y in t.poses[:, :2]]
    return out


#: The distance transforms of the occupancy maps last used (by identity, the map kept with it): a live
#: planner asks for the window on every update, and the map does not change.
_DISTANCES: list[tuple[OccupancyMap, FloatArray]] = []


def _map_distance(occ: OccupancyMap) -> FloatArray:
    """The distance [m] from each map cell to the nearest occupied one (cached, see :data:`_DISTANCES`)."""
    for kept, dist in _DISTANCES:
        if kept is occ:
            return dist
    dist = distance_map(occ.occupied, occ.resolution)
    _DISTANCES[:] = [(occ, dist), *_DISTANCES[:3]]
    return dist


def _route_costs(scene: Scene, clearance: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Travel costs and predecessors on the map's own grid from the start over the cells at least
    ``clearance`` [m] from an occupied one, or None when the start is off the map or not that clear."""
    occ = scene.occupancy
    assert occ is not None
    res = occ.resolution
    rows, cols = occ.occupied.shape
    clear: BoolArray = _map_distance(occ) >= clearance
    c0 = math.floor((scene.start[0] - occ.origin[0]) / res)
    r0 = math.floor((scene.start[1] - occ.origin[1]) / res)
    if not (0 <= r0 < rows and 0 <= c0 < cols) or not clear[r0, c0]:
        return None
    return navigation_cost(np.ones(clear.shape), clear, (r0, c0), res)


def routes_extent(scene: Scene, clearances: tuple[float, ...]) -> tuple[float, float, float, float] | None:
    """(xmin, ymin, xmax, ymax) [m] of the map routes from the start to every target (see the module
    doc): for each target the route of the first of ``clearances`` [m] that has one; None when the
    start is not clear by the last of them (or off the map)."""
    occ = scene.occupancy
    if occ is None:
        return None
    res, (ox, oy) = occ.resolution, (occ.origin[0], occ.origin[1])
    rows, cols = occ.occupied.shape
    searches = [_route_costs(scene, c) for c in clearances]
    if searches[-1] is None:
        return None
    xs, ys = [scene.start[0]], [scene.start[1]]
    reach = int(math.ceil(TARGET_RADIUS / res))
    for tx, ty in _targets(scene):
        tc, tr = math.floor((tx - ox) / res), math.floor((ty - oy) / res)
        a0, a1, b0, b1 = max(tr - reach, 0), min(tr + reach + 1, rows), max(tc - reach, 0), min(tc + reach + 1, cols)
        if a0 >= a1 or b0 >= b1:
            continue
        rr, cc = np.mgrid[a0:a1, b0:b1]
        near = ((rr + 0.5) * res + oy - ty) ** 2 + ((cc + 0.5) * res + ox - tx) ** 2 <= TARGET_RADIUS**2
        for found in searches:
            if found is None:
                continue
            cost, pred = found
            local = np.where(near, cost[a0:a1, b0:b1], np.inf)
            k = int(np.argmin(local))
            if np.isfinite(local.flat[k]):
                path = extract_path(pred, (a0 + k // local.shape[1], b0 + k % local.shape[1]))
                xs += [ox + float(path[:, 1].min()) * res, ox + float(path[:, 1].max() + 1) * res]
                ys += [oy + float(path[:, 0].min()) * res, oy + float(path[:, 0].max() + 1) * res]
                break
    return min(xs), min(ys), max(xs), max(ys)


def _near(nav: NavGrid, x: float, y: float) -> tuple[slice, slice, BoolArray]:
    """The rows and columns of ``nav`` around (x, y) [m] and the (h, w) mask of the cells there whose
    centre lies within :data:`TARGET_RADIUS` of it."""
    r = nav.resolution
    reach = int(math.ceil(TARGET_RADIUS / r)) + 1
    j, i = math.floor((y - nav.origin[1]) / r), math.floor((x - nav.origin[0]) / r)
    j0, j1 = max(j - reach, 0), max(min(j + reach + 1, nav.shape[0]), 0)
    i0, i1 = max(i - reach, 0), max(min(i + reach + 1, nav.shape[1]), 0)
    ys = nav.origin[1] + (np.arange(j0, j1) + 0.5) * r
    xs = nav.origin[0] + (np.arange(i0, i1) + 0.5) * r
    mask: BoolArray = ((ys[:, None] - y) ** 2 + (xs[None, :] - x) ** 2) <= TARGET_RADIUS**2
    return slice(j0, j1), slice(i0, i1), mask


def serves(feasible: BoolArray, nav: NavGrid, scene: Scene) -> bool:
    """Whether the base, from the start, can get within :data:`TARGET_RADIUS` of every target over the
    ``feasible`` (ny, nx) cells of ``nav`` (a window that cut the only drivable route would not)."""
    reachable = reachable_from(feasible, nav, scene.start[0], scene.start[1])
    for tx, ty in _targets(scene):
        rows, cols, near = _near(nav, tx, ty)
        if not (near & reachable[rows, cols]).any():
            return False
    return True


def route_window(feasible: BoolArray, factor: np.ndarray, nav: NavGrid, scene: Scene) -> Window | None:
    """The window of ``nav`` (the whole scene grid, with its ``feasible`` and ``factor`` layers) that
    holds the task's things and the base's cheapest routes from the start to within
    :data:`TARGET_RADIUS` of every target, grown by :data:`WINDOW_MARGIN`; None when it would save
    too little or the start is not on a feasible cell. Exact: the routes are the planner's own."""
    try:
        start = nav.cell(scene.start[0], scene.start[1])
    except PlacementError:
        return None
    if not feasible[start]:
        return None
    cost, pred = navigation_cost(factor, feasible, start, nav.resolution)
    r = nav.resolution
    ys = nav.origin[1] + (np.arange(nav.shape[0]) + 0.5) * r
    xs = nav.origin[0] + (np.arange(nav.shape[1]) + 0.5) * r
    x0, y0, x1, y1 = things_extent(scene)
    for tx, ty in _targets(scene):
        rows, cols, near = _near(nav, tx, ty)
        local = np.where(near, cost[rows, cols], np.inf)
        if not local.size or not np.isfinite(local).any():
            continue
        k = int(np.argmin(local))
        path = extract_path(pred, (rows.start + k // local.shape[1], cols.start + k % local.shape[1]))
        x0, x1 = min(x0, float(xs[path[:, 1]].min())), max(x1, float(xs[path[:, 1]].max()))
        y0, y1 = min(y0, float(ys[path[:, 0]].min())), max(y1, float(ys[path[:, 0]].max()))
    return _cells(nav, (x0, y0, x1, y1))


def _cells(nav: NavGrid, box: tuple[float, float, float, float]) -> Window | None:
    """The rows and columns of ``nav`` covering ``box`` (x0, y0, x1, y1) [m] grown by
    :data:`WINDOW_MARGIN`, or None when that would save too little."""
    x0, y0, x1, y1 = (box[0] - WINDOW_MARGIN, box[1] - WINDOW_MARGIN, box[2] + WINDOW_MARGIN, box[3] + WINDOW_MARGIN)
    ny, nx = nav.shape
    r = nav.resolution
    i0 = max(int(math.floor((x0 - nav.origin[0]) / r)), 0)
    i1 = min(int(math.ceil((x1 - nav.origin[0]) / r)), nx)
    j0 = max(int(math.floor((y0 - nav.origin[1]) / r)), 0)
    j1 = min(int(math.ceil((y1 - nav.origin[1]) / r)), ny)
    if j1 <= j0 or i1 <= i0 or (j1 - j0) * (i1 - i0) > MIN_SAVING * ny * nx:
        return None
    return j0, j1, i0, i1


def task_window(scene: Scene, nav: NavGrid, base: BaseShape) -> Window | None:
    """The window of ``nav`` (the scene's grid) the task needs (see the module doc), or None to plan
    on the whole grid: no occupancy map, ``bounds`` given in the scene file, or too little saved."""
    if scene.occupancy is None or scene.bounds_given:
        return None
    # a route clear by the base's outer radius is drivable at any yaw; one clear by its inner radius
    # only perhaps (a door the base passes turned just so): the first that exists
    sure = base.radius + base.padding + PAD_SLACK + nav.resolution
    try:
        routes = routes_extent(scene, (sure, base.clearance))
    except PlacementError:
        return None
    if routes is None:
        return None
    things = things_extent(scene)
    box = (min(routes[0], things[0]), min(routes[1], things[1]), max(routes[2], things[2]), max(routes[3], things[3]))
    return _cells(nav, box)
