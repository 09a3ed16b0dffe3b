"""A reachability map in the viewer: reached cells as a point cloud coloured by value, a threshold
slider, a TCP direction choice, and the robot at home (the map's base frame is the world frame)."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, cast

import numpy as np
import numpy.typing as npt

from placement.maps.grid import pose_from_zyx
from placement.viewer.colors import Scale
from placement.viewer.robot_view import RobotDrawing, home_config

if TYPE_CHECKING:
    import viser

    from placement.maps.grid import Grid
    from placement.maps.rmap import ReachabilityMap
    from placement.robots import Robot

#: A TCP approach direction (3,) in the base frame, or None for every orientation.
Direction = tuple[int, int, int] | None

# approach (TCP z) directions in the base frame; "best" takes every orientation
DIRECTIONS: dict[str, Direction] = {
    "best": None,
    "down": (0, 0, -1),
    "up": (0, 0, 1),
    "forward": (1, 0, 0),
    "backward": (-1, 0, 0),
    "left": (0, 1, 0),
    "right": (0, -1, 0),
}
DIRECTION_TOLERANCE = math.radians(30)  # orientation bins whose approach is this close count as the direction
DEFAULT_POINTS = 200_000  # more points than this are subsampled: the browser stays responsive
BELOW = (205, 205, 205)  # cells whose value is under the colour scale (below the planner's threshold): light grey
BELOW_SIZE = 0.2  # their points' size [cell edges]
SIZES = (0.3, 0.45, 0.6, 0.75)  # point sizes [cell edges] of the colour scale's quarters, weakest first
TOP_PERCENTILE = 99  # the scale's top: a few outliers do not push every other cell to the dark end


def value_scale(values: npt.ArrayLike, label: str) -> Scale:
    """The colour scale of a map cloud's ``values`` (> 0): from the planner's default threshold (cells
    below it are no placement; a raw minimum can be 1e-19, which spent the dark end of the colour map on
    the unusable boundary shell) to the 99th percentile; the smallest value when all are below it."""
    from placement import PlannerConfig

    v = np.asarray(values, dtype=float)
    v = v[v > 0]
    if not len(v):
        return Scale(label, "dimensionless", 0.0, 1.0)
    top = float(np.percentile(v, TOP_PERCENTILE))
    threshold = float(PlannerConfig().threshold)
    lo = threshold if top > threshold else float(v.min())
    return Scale(label, "dimensionless", lo, max(top, lo))


def approach_bins(grid: Grid, direction: Direction) -> npt.NDArray[np.bool_]:
    """(n_yaw, n_pitch, n_roll) bool: orientation bins whose TCP approach axis (z) lies within
    DIRECTION_TOLERANCE of ``direction`` (3,) (the nearest bins if none does); all bins for None."""
    n_yaw, n_pitch, n_roll = grid.shape[3:]
    if direction is None:
        return np.ones((n_yaw, n_pitch, n_roll), dtype=bool)
    dyaw, dpitch, droll = grid.angle_steps
    y, p, r = np.meshgrid(
        np.arange(n_yaw) * dyaw,
        -math.pi / 2 + (np.arange(n_pitch) + 0.5) * dpitch,
        np.arange(n_roll) * droll,
        indexing="ij",
    )
    z = pose_from_zyx(np.zeros((y.size, 3)), y.ravel(), p.ravel(), r.ravel())[:, :3, 2]
    angle = np.arccos(np.clip(z @ np.asarray(direction, dtype=float), -1, 1)).reshape(y.shape)
    return cast("npt.NDArray[np.bool_]", angle <= max(DIRECTION_TOLERANCE, float(angle.min()) + 1e-9))


def best_values(values: npt.NDArray[np.floating], bins: npt.NDArray[np.bool_]) -> npt.NDArray[np.float32]:
    """(nx, ny, nz) best value over the selected orientation ``bins`` of a 6D map array."""
    out = np.zeros(values.shape[:3], dtype=np.float32)
    for iy, ip, ir in zip(*np.nonzero(bins)):
        np.maximum(out, values[:, :, :, iy, ip, ir], out=out)
    return out


def best_per_direction(
    rmap: ReachabilityMap, directions: Mapping[str, Direction], workers: int | None = None
) -> dict[str, npt.NDArray[np.floating]]:
    """{name: (nx, ny, nz) best value over the orientation bins of that TCP direction} for every
    direction of ``directions`` (name -> (3,) or None for all bins), in one pass over the map.

    A map not yet in memory is streamed one z layer at a time (every chunk checked against its CRC),
    each layer reduced to its per-direction maxima in a thread pool; the 6D array is never assembled.
    A 5 cm PR2 arm (1.2 GB of values) opens in a few seconds instead of reading everything and then
    reducing 3,600 strided slices."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    g = rmap.grid
    bins = {name: approach_bins(g, d) for name, d in directions.items()}
    if rmap.in_memory:
        return {name: best_values(rmap.values, b) for name, b in bins.items()}

    def reduce(iz: int) -> dict[str, npt.NDArray[np.floating]]:
        slab = rmap.store.read_slab(rmap.arm, iz)  # (nx, ny, n_yaw, n_pitch, n_roll)
        return {name: slab.max(axis=(2, 3, 4)) if b.all() else slab[:, :, b].max(axis=2) for name, b in bins.items()}

    with ThreadPoolExecutor(max_workers=workers or min(4, os.cpu_count() or 1)) as pool:
        layers = list(pool.map(reduce, range(g.shape[2])))
    return {name: np.stack([layer[name] for layer in layers], axis=2) for name in bins}


def cloud(
    grid: Grid, best: npt.NDArray[np.floating], max_points: int, seed: int = 0
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.floating], int]:
    """(points (k, 3) cell centres [m], values (k,), reached cell count) of the cells with a value > 0,
    a seeded uniform subsample when more than ``max_points`` are reached."""
    flat = np.flatnonzero(best > 0)
    reached = len(flat)
    if reached > max_points:
        flat = np.sort(np.random.default_rng(seed).choice(flat, max_points, replace=False))
    idx = np.stack(np.unravel_index(flat, best.shape), axis=-1)
    pts = np.asarray(grid.origin) + (idx + 0.5) * grid.resolution
    return pts.astype(np.float32), best.ravel()[flat], reached


class MapView:
    """Draws one arm's map (a :class:`~placement.maps.rmap.ReachabilityMap`) and ``robot`` in ``server``.

    Attributes: scale (the current colour :class:`Scale`), shown (points drawn now), reached (cells
    with a value for the direction), update_ms (the last redraw [ms]).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        rmap: ReachabilityMap,
        robot: Robot,
        direction: str = "best",
        max_points: int = DEFAULT_POINTS,
    ) -> None:
        self.server, self.rmap, self.robot, self.max_points = server, rmap, robot, max_points
        self.update_ms = float("nan")
        self.robot_drawing = RobotDrawing(server, robot)
        self.robot_drawing.show((0.0, 0.0, 0.0), home_config(robot))
        gui = server.gui
        g = rmap.grid
        gui.add_markdown(
            f"**map {rmap.path.name}, {rmap.arm} arm**  \n{'x'.join(map(str, g.shape[:3]))} positions "
            f"of {g.resolution * 100:.0f} cm, {'x'.join(map(str, g.shape[3:]))} orientations"
        )
        self.direction = gui.add_dropdown("TCP direction", tuple(DIRECTIONS), initial_value=direction)
        self.threshold = gui.add_slider("threshold", 0.0, 1.0, 0.001, 0.0)
        # a cut through the cloud: cells nearer the default camera (lower y) hidden, to see inside
        y0, y1 = g.origin[1], g.origin[1] + g.shape[1] * g.resolution
        self.section = gui.add_slider("hide y < [m]", round(y0, 2), round(y1, 2), g.resolution / 2, round(y0, 2))
        self.info = gui.add_markdown("")
        self.scale_html = gui.add_html("")
        self.clouds: dict[str, viser.PointCloudHandle] = {}
        self._best: dict[str, npt.NDArray[np.floating]] | None = None
        self.select(direction)
        self.direction.on_update(lambda _: self.select(self.direction.value))
        self.threshold.on_update(lambda _: self.draw())
        self.section.on_update(lambda _: self.draw())

    def select(self, direction: str) -> None:
        """Recompute the best values for a TCP ``direction`` (a key of DIRECTIONS) and redraw."""
        if self._best is None:  # every direction at once: switching directions reads nothing again
            self._best = best_per_direction(self.rmap, DIRECTIONS)
        best = self._best[direction]
        self.all_points, self.all_values, self.reached = cloud(self.rmap.grid, best, self.max_points)
        self.scale = value_scale(self.all_values, f"manipulability ({direction})")
        top = float(self.all_values.max()) if len(self.all_values) else 0.0
        if top > 0:
            self.threshold.max = top
            self.threshold.step = top / 200
        self.scale_html.content = self.scale.html() + (
            f"<div style='font-size:0.8em'>small grey points: below {self.scale.lo:.3g} (the planner's threshold)</div>"
            if float(self.all_values.min(initial=np.inf)) < self.scale.lo
            else ""
        )
        self.draw()

    def draw(self) -> None:
        t = time.perf_counter()
        keep = (self.all_values >= float(self.threshold.value)) & (self.all_points[:, 1] >= float(self.section.value))
        pts, vals = self.all_points[keep], self.all_values[keep]
        self.shown = len(pts)
        # one cloud per quarter of the colour scale, weaker cells drawn smaller, and one of small grey points
        # below it: the weak cells of the reach's boundary shell do not hide the strong cells inside
        group = np.where(vals < self.scale.lo, -1, np.minimum(self.scale.normalise(vals) * len(SIZES), len(SIZES) - 1))
        group = group.astype(int)
        edge = float(self.rmap.grid.resolution)
        self.clouds = {}
        for g in range(-1, len(SIZES)):
            name = "/map/below" if g < 0 else f"/map/cells/{g}"
            part = group == g
            p, v = pts[part], vals[part]
            if not len(p):  # viser needs a point; an invisible one at the origin
                p, v = np.zeros((1, 3), np.float32), np.full(1, self.scale.lo)
            colors = np.tile(np.array(BELOW, np.uint8), (len(p), 1)) if g < 0 else self.scale.rgb(v)
            self.clouds[name] = self.server.scene.add_point_cloud(
                name,
                p,
                colors,
                point_size=edge * (BELOW_SIZE if g < 0 else SIZES[g]),
                point_shape="square",
                visible=bool(part.any()),
            )
        sub = f" (a uniform sample of {len(self.all_points):,})" if self.reached > len(self.all_points) else ""
        self.info.content = (
            f"{self.reached:,} position cells reached{sub}; {self.shown:,} shown at value "
            f">= {float(self.threshold.value):.3g}"
        )
        self.update_ms = (time.perf_counter() - t) * 1e3
