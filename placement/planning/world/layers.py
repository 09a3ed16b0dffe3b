"""Rasterising a scene onto the navigation grid: occupancy, distance, base feasibility, speed."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.planning.arrays import BoolArray, FloatArray, IntArray, MaskArray
from placement.planning.settings import PlannerConfig
from placement.planning.world.footprints import BaseShape, YawMasks, masks_at, polygon_feasibility, pose_clear
from placement.planning.world.navigation import distance_map, speed_factor
from placement.planning.world.window import Window, route_window, serves, task_window
from placement.scene import Box, Cylinder, Obstacle, Polygon, Scene
from placement.scene.navgrid import NavGrid
from placement.scene.occupancy import rasterize_occupancy

T = TypeVar("T", bound=np.generic)

#: An obstacle's footprint shape.
Shape = Box | Cylinder | Polygon
#: How a shape is drawn into a layer: :func:`add_shape` or :func:`add_touched`.
Draw = Callable[[BoolArray, Shape, NavGrid], None]

#: [m] the squares are shrunk by this so that float rounding on a shared edge marks nothing; the
#: footprint test pads by far more (footprints.PAD_SLACK)
SHRINK = 1e-9


def _inside_polygon(px: FloatArray, py: FloatArray, pts: FloatArray) -> BoolArray:
    """Even-odd rule for points (px, py) against polygon ``pts`` (k, 2)."""
    inside = np.zeros(px.shape, dtype=bool)
    k = len(pts)
    for i in range(k):
        x1, y1 = pts[i]
        x2, y2 = pts[(i + 1) % k]
        crosses = (y1 > py) != (y2 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xi = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (px < xi)
    return inside


def shape_mask(shape: Shape, nav: NavGrid) -> BoolArray:
    """(ny, nx) bool: cells whose centre lies inside the shape's footprint."""
    out = np.zeros(nav.shape, dtype=bool)
    add_shape(out, shape, nav)
    return out


def shape_window(shape: Shape, nav: NavGrid) -> tuple[int, int, int, int]:
    """Rows j0..j1-1 and columns i0..i1-1 (j0, j1, i0, i1) holding every cell whose centre can lie in
    the shape's footprint: its bounding box plus one cell, clipped to the grid."""
    x0, y0, x1, y1 = shape.bounds_xy()
    r = nav.resolution
    i0 = max(int(np.floor((x0 - nav.origin[0]) / r)) - 1, 0)
    i1 = min(int(np.ceil((x1 - nav.origin[0]) / r)) + 1, nav.shape[1])
    j0 = max(int(np.floor((y0 - nav.origin[1]) / r)) - 1, 0)
    j1 = min(int(np.ceil((y1 - nav.origin[1]) / r)) + 1, nav.shape[0])
    return j0, j1, i0, i1


def changed_occupancy(
    occupied: BoolArray,
    nav: NavGrid,
    removed: Sequence[Obstacle],
    kept: Sequence[Obstacle],
    added: Sequence[Obstacle],
    draw: Draw | None = None,
) -> BoolArray:
    """The occupancy after obstacles changed, from the old one (no occupancy map involved): the cells
    of removed shapes are cleared and every kept shape that reaches them is drawn again, then the
    added shapes are drawn; the same grid as rasterising everything anew. ``draw``: how a shape is
    drawn (:func:`add_shape` by default, :func:`add_touched` for the touched layer)."""
    draw = draw or add_shape
    out = occupied.copy()
    windows = [shape_window(ob.shape, nav) for ob in removed]
    for j0, j1, i0, i1 in windows:
        out[j0:j1, i0:i1] = False
    for ob in kept:
        a0, a1, b0, b1 = shape_window(ob.shape, nav)
        if any(a0 < j1 and j0 < a1 and b0 < i1 and i0 < b1 for j0, j1, i0, i1 in windows):
            draw(out, ob.shape, nav)
    for ob in added:
        draw(out, ob.shape, nav)
    return out


def add_shape(occupied: BoolArray, shape: Shape, nav: NavGrid) -> None:
    """Mark in ``occupied`` (ny, nx) the cells whose centre lies inside the shape's footprint.

    Only the cells of the footprint's bounding box (plus one) are tested: the same decisions as
    testing every cell, at the cost of the shape's size rather than the grid's.
    """
    xs, ys = nav.centres()
    j0, j1, i0, i1 = shape_window(shape, nav)
    if i0 >= i1 or j0 >= j1:
        return
    X, Y = np.meshgrid(xs[i0:i1], ys[j0:j1])
    if isinstance(shape, Box):
        c, s = np.cos(shape.yaw), np.sin(shape.yaw)
        dx, dy = X - shape.center[0], Y - shape.center[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        inside = (np.abs(lx) <= shape.size[0] / 2) & (np.abs(ly) <= shape.size[1] / 2)
    elif isinstance(shape, Cylinder):
        inside = (X - shape.center[0]) ** 2 + (Y - shape.center[1]) ** 2 <= shape.radius**2
    elif isinstance(shape, Polygon):
        inside = _inside_polygon(X, Y, np.asarray(shape.points))
    else:
        raise TypeError(f"unknown shape {type(shape).__name__}")
    occupied[j0:j1, i0:i1] |= inside


def add_touched(touched: BoolArray, shape: Shape, nav: NavGrid) -> None:
    """Mark in ``touched`` (ny, nx) every cell whose open square meets the shape's footprint.

    Cells an obstacle only touches along an edge stay free: the marked squares still cover the
    obstacle (every point of it is a limit of interior points, which lie in marked squares), and a
    table edge on a cell boundary then costs no clearance. See ``planning/world/footprints.py``.
    """
    j0, j1, i0, i1 = shape_window(shape, nav)
    if i0 >= i1 or j0 >= j1:
        return
    xs, ys = nav.centres()
    X, Y = np.meshgrid(xs[i0:i1], ys[j0:j1])
    h = nav.resolution / 2
    if isinstance(shape, Cylinder):
        qx = np.clip(shape.center[0], X - h, X + h)
        qy = np.clip(shape.center[1], Y - h, Y + h)
        hit = np.hypot(qx - shape.center[0], qy - shape.center[1]) < shape.radius
    elif isinstance(shape, (Box, Polygon)):
        pts = shape.corners_xy() if isinstance(shape, Box) else np.asarray(shape.points, dtype=float)
        hit = _inside_polygon(X, Y, pts)
        for a, b in zip(pts, np.roll(pts, -1, axis=0)):
            hit |= _segment_meets_square(a, b, X, Y, h - SHRINK)
    else:
        raise TypeError(f"unknown shape {type(shape).__name__}")
    touched[j0:j1, i0:i1] |= hit


def _segment_meets_square(a: FloatArray, b: FloatArray, X: FloatArray, Y: FloatArray, h: float) -> BoolArray:
    """Whether segment a-b meets the squares of centres (X, Y) and half-size ``h`` (Liang-Barsky)."""
    d = b - a
    t0, t1 = np.zeros(X.shape), np.ones(X.shape)
    for p0, dp, c in ((a[0], d[0], X), (a[1], d[1], Y)):
        lo, hi = c - h - p0, c + h - p0  # need lo <= t dp <= hi
        if dp == 0:
            ok = (lo <= 0) & (0 <= hi)
            t1 = np.where(ok, t1, -1.0)
        else:
            ta, tb = lo / dp, hi / dp
            t0 = np.maximum(t0, np.minimum(ta, tb))
            t1 = np.minimum(t1, np.maximum(ta, tb))
    return t0 <= t1


@dataclass(frozen=True)
class World:
    """The static navigation layers of a scene, all (ny, nx) over ``nav``.

    Attributes:
        nav: the grid. occupied: bool (obstacles by cell centre, occupancy-map cells that are
        occupied or unknown, and with an occupancy map every cell outside it). distance: distance to
        the nearest occupied cell centre [m]. feasible: bool, the base may stand on the cell at some
        yaw (round base: distance >= radius; polygon: see footprints.py); the base travels through
        these cells. factor: slowdown of Eq. 4 (travel cost per metre, >= 1), from ``distance``.
        base: the base shape and yaws. touched: bool, cells an obstacle reaches into (polygon
        bases; None for round ones). masks: the allowed yaws of the band cells (None for round bases).
        slowdown: (ny, nx) the speed mask's travel cost multiplier (>= 1), or None without one.
        window: the rows and columns (j0, j1, i0, i1) of the scene's grid that ``nav`` covers, or None
            for the whole grid (see :mod:`placement.planning.world.window`); requested: the map routes'
            window it was made for (the same as ``window`` unless that one cut the base off a target).
    """

    nav: NavGrid
    occupied: BoolArray
    distance: FloatArray
    feasible: BoolArray
    factor: FloatArray
    base: BaseShape
    touched: BoolArray | None = None
    masks: YawMasks | None = None
    slowdown: FloatArray | None = None
    window: Window | None = None
    requested: Window | None = None

    def __post_init__(self) -> None:
        # the layers a search reads are never written: read-only, a shortest-path search may keep
        # their padded copy and its work arrays for the next one (placement.planning.world.navigation)
        for layer in (self.feasible, self.factor):
            layer.flags.writeable = False

    def yaw_masks(self, cells: IntArray) -> MaskArray:
        """(N, W) uint64 packed masks of the base yaws allowed on flat ``cells`` (N,) (bit k of word
        k >> 6 is yaw k; a round base allows every yaw on feasible cells)."""
        return masks_at(self.base, self.feasible, self.masks, cells)

    def pose_clear(self, x: float, y: float, yaw: float) -> bool:
        """Whether the base fits at (x, y) [m] with ``yaw`` [rad] (a round base: on a feasible cell)."""
        if self.base.polygon is None or self.touched is None:
            try:
                return bool(self.feasible[self.nav.cell(x, y)])
            except PlacementError:
                return False
        return pose_clear(self.base, self.touched, self.nav, x, y, yaw)

    def crop(self, j0: int, j1: int, i0: int, i1: int, window: Window | None) -> World:
        """The world on rows j0..j1-1 and columns i0..i1-1 of its grid (each cell as it was), recorded
        as covering ``window`` of the scene's grid."""
        r = self.nav.resolution
        nav = NavGrid((self.nav.origin[0] + i0 * r, self.nav.origin[1] + j0 * r), r, (j1 - j0, i1 - i0))

        def cut(a: npt.NDArray[T]) -> npt.NDArray[T]:
            return np.ascontiguousarray(a[j0:j1, i0:i1])

        masks = None
        if self.masks is not None:
            nx = self.nav.shape[1]
            rows, cols = self.masks.cells // nx, self.masks.cells % nx
            keep = (rows >= j0) & (rows < j1) & (cols >= i0) & (cols < i1)
            cells = (rows[keep] - j0) * (i1 - i0) + (cols[keep] - i0)
            masks = YawMasks(np.ascontiguousarray(cells), np.ascontiguousarray(self.masks.bits[keep]))
        return World(
            nav,
            cut(self.occupied),
            cut(self.distance),
            cut(self.feasible),
            cut(self.factor),
            self.base,
            None if self.touched is None else cut(self.touched),
            masks,
            None if self.slowdown is None else cut(self.slowdown),
            window,
        )


def base_layers(scene: Scene, nav: NavGrid, v_max: float) -> tuple[BoolArray | None, FloatArray | None]:
    """The scene's 2D inputs on ``nav``: the cells closed to the base, conservatively (occupancy map
    cells that are occupied, or unknown when the map closes them, cells outside the map likewise,
    keepout cells, and cells a speed limit of 0 closes), or None without any; and the travel cost
    multiplier (>= 1) of the speed mask times that of unknown cells under ``unknown: cost``, or None
    without either. ``v_max``: the robot's top speed [m/s]."""
    closed = None
    slowdown = None
    occ = scene.occupancy
    if occ is not None:
        outside = occ.unknown == "occupied"
        closed = rasterize_occupancy(
            occ, nav.origin, nav.resolution, nav.shape, conservative=True, outside_occupied=outside
        )
        if occ.unknown == "cost" and occ.unknown_cells is not None:
            # a planning cell that overlaps an unknown map cell (or the outside of the map) costs more
            unknown = replace(occ, occupied=occ.unknown_cells)
            costly = rasterize_occupancy(
                unknown, nav.origin, nav.resolution, nav.shape, conservative=True, outside_occupied=True
            )
            slowdown = np.where(costly, occ.unknown_cost, 1.0)
    if scene.keepout is not None:
        keep = scene.keepout.closed(nav.origin, nav.resolution, nav.shape)
        closed = keep if closed is None else closed | keep
    if scene.speed is not None:
        speed = scene.speed.slowdown(nav.origin, nav.resolution, nav.shape, v_max)
        stopped = ~np.isfinite(speed)
        if stopped.any():
            closed = stopped if closed is None else closed | stopped
            speed = np.where(stopped, 1.0, speed)
        slowdown = speed if slowdown is None else slowdown * speed  # a speed limit in unknown space: both
    return closed, slowdown


def halo_cells(base: BaseShape, config: PlannerConfig, resolution: float) -> int:
    """Cells around a window whose obstacles can change a window cell's layers: the base's reach
    (footprint and padding) and the Eq. 4 slowdown distance, plus slack."""
    reach = base.radius + base.padding + config.d_max
    return int(math.ceil(reach / resolution)) + 2


def build_world(
    scene: Scene, base: BaseShape, config: PlannerConfig, v_max: float = 1.0, window: Window | None = None
) -> World:
    """Occupancy from the scene's obstacles and 2D inputs (occupancy map, keepout and speed masks), then
    distance, feasibility, speed.

    ``base``: the robot's base shape and yaws; the velocity model's parameters come from ``config``;
    ``v_max``: the robot's top speed [m/s] (for a speed mask in m/s); ``window``: (j0, j1, i0, i1) of
    the scene's grid to build (with a halo, cut off after, so that its cells are exact), or None.
    """
    nav = scene.nav_grid()
    if window is None:
        return _build(scene, nav, base, config, v_max)
    j0, j1, i0, i1 = window
    halo = halo_cells(base, config, nav.resolution)
    g0, g1 = max(j0 - halo, 0), min(j1 + halo, nav.shape[0])
    h0, h1 = max(i0 - halo, 0), min(i1 + halo, nav.shape[1])
    r = nav.resolution
    grown = NavGrid((nav.origin[0] + h0 * r, nav.origin[1] + g0 * r), r, (g1 - g0, h1 - h0))
    return _build(scene, grown, base, config, v_max).crop(j0 - g0, j1 - g0, i0 - h0, i1 - h0, window)


def windowed_world(scene: Scene, base: BaseShape, config: PlannerConfig, v_max: float = 1.0) -> World:
    """The world of ``scene`` on the window its task needs (see :mod:`placement.planning.world.window`): the
    map routes' window, else the whole grid cut to the planner's own routes, else the whole grid."""
    window = task_window(scene, scene.nav_grid(), base)
    if window is None and (scene.occupancy is None or scene.bounds_given):
        return build_world(scene, base, config, v_max)
    if window is not None:
        world = build_world(scene, base, config, v_max, window)
        if serves(world.feasible, world.nav, scene):
            return replace(world, requested=window)
    full = build_world(scene, base, config, v_max)
    exact = route_window(full.feasible, full.factor, full.nav, scene)
    return replace(full if exact is None else full.crop(*exact, exact), requested=window)


def world_still_serves(world: World, scene: Scene) -> bool:
    """Whether ``world`` (made by :func:`windowed_world`) serves ``scene`` as a new one would: the same
    map routes' window, and the base still gets near every target (after objects or the start moved)."""
    return task_window(scene, scene.nav_grid(), world.base) == world.requested and serves(
        world.feasible, world.nav, scene
    )


def _build(scene: Scene, nav: NavGrid, base: BaseShape, config: PlannerConfig, v_max: float) -> World:
    occ = np.zeros(nav.shape, dtype=bool)
    for ob in scene.obstacles:
        add_shape(occ, ob.shape, nav)
    raster, slowdown = base_layers(scene, nav, v_max)
    if raster is not None:
        occ |= raster
    touched = None
    if base.polygon is not None:
        # the conservative raster already marks every cell a map cell reaches into
        touched = np.zeros(nav.shape, dtype=bool) if raster is None else raster.copy()
        for ob in scene.obstacles:
            add_touched(touched, ob.shape, nav)
    return world_from_occupancy(nav, occ, base, config, touched, slowdown=slowdown)


def world_from_occupancy(
    nav: NavGrid,
    occ: BoolArray,
    base: BaseShape,
    config: PlannerConfig,
    touched: BoolArray | None = None,
    previous: World | None = None,
    slowdown: FloatArray | None = None,
) -> World:
    """Distance, feasibility and speed from an occupancy grid (ny, nx) bool (and, for a polygon
    base, the touched layer (ny, nx) bool). ``previous``: the world of the same grid and base before
    an obstacle change (the yaw masks far from the change, and the speed mask's ``slowdown`` when
    none is given, are taken from it). ``slowdown``: (ny, nx) the speed mask's multiplier (>= 1)."""
    if slowdown is None and previous is not None:
        slowdown = previous.slowdown
    dist = distance_map(occ, nav.resolution)
    factor = speed_factor(dist, config.velocity_lambda, config.velocity_k, config.d_max)
    if slowdown is not None:
        factor = factor * slowdown
    if base.polygon is None:
        return World(nav, occ, dist, dist >= base.radius, factor, base, slowdown=slowdown)
    if touched is None:
        raise PlacementError("world_from_occupancy: a polygon base needs the touched layer")
    before = None
    if previous is not None and previous.touched is not None and previous.masks is not None and previous.base is base:
        before = (previous.touched, previous.masks)
    feasible, masks = polygon_feasibility(base, touched, distance_map(touched, nav.resolution), nav.resolution, before)
    return World(nav, occ, dist, feasible, factor, base, touched, masks, slowdown)
