"""ROS map_server occupancy maps (YAML + image) and their rasterisation onto a planning grid.

A map is a YAML file in the ROS ``map_server`` / nav2 format::

    image: floor.pgm          # relative to the YAML file, or absolute
    resolution: 0.05          # [m] per pixel
    origin: [-10.0, -10.0, 0.0]   # pose (x [m], y [m], yaw [rad]) of the lower-left pixel corner
    negate: 0                 # optional, default 0
    occupied_thresh: 0.65     # optional, default 0.65 (map_saver's default)
    free_thresh: 0.196        # optional, default 0.196 (map_saver's default)
    mode: trinary             # optional: trinary (default) or scale; raw is not supported

Semantics (as ``map_server``): a pixel value ``v`` (0..maxval, 255 for the usual 8-bit image) has
occupancy probability ``p = (maxval - v) / maxval`` (``p = v / maxval`` with ``negate``); it is
occupied if ``p > occupied_thresh``, free if ``p < free_thresh`` and unknown otherwise.
By default **unknown cells are treated as occupied** (the base must not drive where nobody has
looked), so in the boolean map a cell is free exactly when ``p < free_thresh``; ``mode: scale``
therefore gives the same boolean map as ``trinary``. ``unknown="free"`` frees them instead (SLAM
specks and unmapped corners, where the user knows the floor is clear), as Nav2's planners do with
``allow_unknown``.

The same files carry Nav2's costmap filter masks (keepout and speed limit): :func:`load_map_image`
reads one into OccupancyGrid values (-1 unknown, 0..100) exactly as ``nav2_map_server`` publishes
it, and :mod:`placement.scene.masks` gives them their meaning.

The image is stored top row first (the top row is the largest y); :class:`OccupancyMap` flips it so
that row 0 is the lowest y, like every other planar grid of the package (row = y, column = x).
PGM images (binary ``P5`` and plain ``P2``, 8-bit or 16-bit) are read with numpy alone, PNG, BMP and
the other formats map_server reads through Pillow (:mod:`placement.scene.map_images`: colour
channels averaged, transparency as map_server reads it). A rotated origin (yaw != 0): map_server
publishes it, but Nav2's costmap and AMCL place the image unrotated at the origin's x and y, and so
the robot localises in that frame; the planner does the same, and a warning says so.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.scene.map_images import read_map_image
from placement.scene.pgm import MAX_IMAGE_PIXELS as MAX_IMAGE_PIXELS
from placement.scene.pgm import MAX_PLAIN_PIXELS as MAX_PLAIN_PIXELS
from placement.scene.pgm import OccupancyMapError as OccupancyMapError
from placement.scene.pgm import parse_pgm as parse_pgm
from placement.validation import parse_yaml, read_text, show

log = logging.getLogger(__name__)

#: Defaults of the optional keys (those that ROS ``map_saver`` writes).
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196
_MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
_MODES = ("trinary", "scale")
#: What unknown cells of an occupancy map are for the base: closed, open, or open at a travel cost
#: (``unknown_cost`` times a free cell's, as Nav2's costmaps may track unknown space).
UNKNOWN_POLICIES = ("occupied", "free", "cost")
#: The default travel cost multiplier of an unknown cell under ``unknown: cost``.
DEFAULT_UNKNOWN_COST = 3.0
#: The largest one.
MAX_UNKNOWN_COST = 1000.0
#: Bounds checked before anything is allocated: the map YAML's size [bytes], the resolution [m] and
#: the coordinates of the map's corners [m] (the image's: see placement/scene/pgm.py).
MAX_MAP_YAML_BYTES = 2**20
RESOLUTION_RANGE = (1e-3, 100.0)
MAX_COORD = 1e6


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """A boolean occupancy grid in the world frame.

    Attributes:
        occupied: (rows, cols) bool, True = occupied or unknown. Row 0 is the lowest y, column 0
            the lowest x: cell (r, c) covers ``x in [ox + c res, ox + (c+1) res)``,
            ``y in [oy + r res, oy + (r+1) res)``.
        resolution: cell size [m].
        origin: (x, y, yaw) of the lower-left corner of cell (0, 0) [m, m, rad]; yaw is 0.
        source: the map YAML it was loaded from, if any.
        unknown: what the unknown cells (and cells outside the map) are for the base: ``occupied``,
            ``free`` or ``cost`` (open, at ``unknown_cost`` times a free cell's travel cost).
        unknown_cells: (rows, cols) bool, the map's unknown cells (kept for ``cost``; None otherwise).
        unknown_cost: travel cost multiplier of an unknown cell (>= 1) under ``cost``.
        arm_height: None (the default): the map is the base's alone, as a 2D map says nothing about
            height; else the occupied cells are also boxes this tall [m] from the floor in the arm's
            collision model (for a map of things the user knows to be that tall).
    """

    occupied: npt.NDArray[np.bool_]
    resolution: float
    origin: tuple[float, float, float]
    source: Path | None = None
    unknown: str = "occupied"
    arm_height: float | None = None
    unknown_cells: npt.NDArray[np.bool_] | None = None
    unknown_cost: float = DEFAULT_UNKNOWN_COST

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        rows, cols = self.occupied.shape
        return rows, cols

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) [m] covered by the map."""
        rows, cols = self.occupied.shape
        x0, y0 = self.origin[0], self.origin[1]
        return (x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution)


# ---------------------------------------------------------------------------------------------------
# map_server YAML


def _probabilities(pixels: npt.NDArray[Any], maxval: int, negate: bool) -> npt.NDArray[np.float64]:
    """The occupancy probability of each pixel value 0 .. max(maxval, the image's largest)."""
    # a rule is applied to each value, then looked up: the same floats as per pixel, without a float64
    # copy of a large image
    v = np.arange(max(maxval, int(pixels.max(initial=0))) + 1, dtype=np.float64)
    out: npt.NDArray[np.float64] = v / maxval if negate else (maxval - v) / maxval
    return out


def _looked_up(lut: npt.NDArray[Any], pixels: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """``lut`` of each pixel, the image flipped so that row 0 is the lowest y."""
    return np.ascontiguousarray(lut[pixels.astype(np.intp, copy=False)][::-1])


def grid_values(
    pixels: npt.ArrayLike,
    maxval: int = 255,
    *,
    negate: bool = False,
    occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
    free_thresh: float = DEFAULT_FREE_THRESH,
    mode: str = "trinary",
) -> npt.NDArray[np.int8]:
    """``nav2_map_server``'s OccupancyGrid values of an image (top row first) -> (rows, cols) int8,
    row 0 = lowest y: 0 where ``p < free_thresh``, 100 where ``p > occupied_thresh``, and in between
    -1 (``trinary``) or ``rint(100 (p - free_thresh) / (occupied_thresh - free_thresh))`` (``scale``)."""
    pixels = np.asarray(pixels)
    p = _probabilities(pixels, maxval, negate)
    lut = np.full(p.shape, -1, dtype=np.int8)
    if mode == "scale":
        span = occupied_thresh - free_thresh
        with np.errstate(divide="ignore", invalid="ignore"):
            scaled = np.rint(100.0 * (p - free_thresh) / span) if span > 0 else np.full(p.shape, 100.0)
        lut[:] = np.clip(scaled, 0, 100).astype(np.int8)
    lut[p > occupied_thresh] = 100
    lut[p < free_thresh] = 0
    values: npt.NDArray[np.int8] = _looked_up(lut, pixels)
    return values


@dataclass(frozen=True, eq=False)
class MapImage:
    """A map_server image as the OccupancyGrid it publishes.

    Attributes:
        values: (rows, cols) int8, row 0 the lowest y: -1 unknown, 0 free .. 100 occupied
            (see :func:`grid_values`).
        unknown: (rows, cols) bool, cells whose probability lies between the thresholds (unknown in
            ``trinary`` mode, a cost in ``scale`` mode).
        resolution: cell size [m]. origin: (x [m], y [m], yaw [rad]) of cell (0, 0)'s lower-left corner.
        mode: ``trinary`` or ``scale``. source: the map YAML.
    """

    values: npt.NDArray[np.int8]
    unknown: npt.NDArray[np.bool_]
    resolution: float
    origin: tuple[float, float, float]
    mode: str
    source: Path


def _number(doc: dict[str, Any], key: str, where: str, lo: float | None = None, hi: float | None = None) -> float:
    """``doc[key]`` as a finite float within [lo, hi] (any size, spelling or type refused in one line)."""
    v = doc[key]
    try:
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(float(v))
    except OverflowError:  # an integer beyond the float range (YAML 0x... of 5,000 digits)
        ok = False
    if not ok:
        raise OccupancyMapError(f"{where}: '{key}' must be a finite number, got {show(v)}")
    v = float(v)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise OccupancyMapError(f"{where}: '{key}' must be within [{lo:g}, {hi:g}], got {v:g}")
    return v


def load_occupancy_map(
    path: str | Path,
    unknown: str = "occupied",
    arm_height: float | None = None,
    unknown_cost: float = DEFAULT_UNKNOWN_COST,
) -> OccupancyMap:
    """Load a ROS map_server map (YAML + image); see the module docstring for the semantics.

    ``unknown``: what unknown cells are for the base, ``occupied`` (default), ``free`` or ``cost``
    (open at ``unknown_cost`` times a free cell's travel cost); ``arm_height``: see
    :class:`OccupancyMap` [m].
    Raises :class:`OccupancyMapError` for a missing or malformed YAML or image, an unsupported
    mode or image format. A rotated origin (yaw != 0) is read as Nav2's costmap and AMCL read it: the
    image unrotated at the origin's x and y (a warning says so).
    """
    if unknown not in UNKNOWN_POLICIES:
        raise OccupancyMapError(f"unknown cells may be {' or '.join(UNKNOWN_POLICIES)}, got {show(unknown)}")
    image = load_map_image(path)
    # occupied: p > occupied_thresh; unknown: in between (a cost in scale mode); free below
    certain = (image.values == 100) & ~image.unknown
    occupied = certain | image.unknown if unknown == "occupied" else certain
    occupied.setflags(write=False)
    cells = None
    if unknown == "cost":
        cells = image.unknown & ~certain
        cells.setflags(write=False)
    return OccupancyMap(
        occupied, image.resolution, image.origin, image.source, unknown, arm_height, cells, unknown_cost
    )


def load_map_image(path: str | Path) -> MapImage:
    """Read a map_server YAML and its image into the OccupancyGrid values ``nav2_map_server`` would
    publish (see :class:`MapImage`); the checks of :func:`load_occupancy_map`."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise OccupancyMapError(f"occupancy map not found: {path}")
    doc = parse_yaml(
        read_text(path, OccupancyMapError, where, MAX_MAP_YAML_BYTES, "map YAML"), where, OccupancyMapError
    )
    if not isinstance(doc, dict):
        raise OccupancyMapError(f"{where}: a map YAML must be a mapping with keys {', '.join(_MAP_KEYS)}")
    unknown = sorted(show(k) for k in doc if k not in _MAP_KEYS)
    if unknown:  # map_server ignores them too; warn rather than refuse a map written by another tool
        log.warning("%s: ignoring unknown map keys: %s", where, ", ".join(unknown))
    for key in ("image", "resolution", "origin"):
        if key not in doc:
            raise OccupancyMapError(f"{where}: missing key '{key}'")
    if not isinstance(doc["image"], str) or not doc["image"]:
        raise OccupancyMapError(f"{where}: 'image' must be a file name, got {show(doc['image'])}")
    resolution = _number(doc, "resolution", where)
    if resolution <= 0:
        raise OccupancyMapError(f"{where}: 'resolution' must be > 0, got {resolution:g}")
    resolution = _number(doc, "resolution", where, *RESOLUTION_RANGE)
    origin = doc["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        raise OccupancyMapError(f"{where}: 'origin' must be [x, y, yaw] (3 finite numbers), got {show(origin)}")
    ox, oy, oyaw = (_number({"origin": v}, "origin", where, -MAX_COORD, MAX_COORD) for v in origin)
    if oyaw != 0.0:  # map_server publishes it; Nav2's costmap and AMCL place the image unrotated
        log.warning(
            "%s: origin yaw %g rad ignored, as Nav2's costmap and AMCL ignore it: the image lies unrotated with "
            "its lower-left corner at (%g, %g)",
            where,
            oyaw,
            ox,
            oy,
        )
    negate = doc.get("negate", 0)
    if isinstance(negate, float) or negate not in (0, 1):
        raise OccupancyMapError(f"{where}: 'negate' must be 0 or 1, got {show(negate)}")
    occ_t = _number(doc, "occupied_thresh", where, 0.0, 1.0) if "occupied_thresh" in doc else DEFAULT_OCCUPIED_THRESH
    free_t = _number(doc, "free_thresh", where, 0.0, 1.0) if "free_thresh" in doc else DEFAULT_FREE_THRESH
    if not 0.0 <= free_t <= occ_t <= 1.0:
        raise OccupancyMapError(
            f"{where}: thresholds must satisfy 0 <= free_thresh <= occupied_thresh <= 1, "
            f"got free_thresh {free_t}, occupied_thresh {occ_t}"
        )
    mode = doc.get("mode", "trinary")
    if not isinstance(mode, str) or mode not in _MODES:
        raise OccupancyMapError(f"{where}: mode '{show(mode)}' is not supported; supported: {', '.join(_MODES)}")
    try:
        image = Path(doc["image"]).expanduser()
        image = image if image.is_absolute() else path.parent / image
        found = image.is_file()
    except (OSError, ValueError, RuntimeError):  # NUL bytes, an unknown ~user, a name too long
        found = False
    if not found:
        raise OccupancyMapError(f"{where}: image '{show(doc['image'])}' not found ({show(str(image))})")
    pixels, maxval, clear = read_map_image(image, mode)
    rows, cols = pixels.shape
    far = max(abs(ox), abs(oy), abs(ox + cols * resolution), abs(oy + rows * resolution))
    if far > MAX_COORD:
        raise OccupancyMapError(
            f"{where}: the map's {cols} x {rows} cells of {resolution:g} m from origin "
            f"({ox:g}, {oy:g}) reach {far:.3g} m from the world origin, beyond +-{MAX_COORD:g} m"
        )
    values = grid_values(pixels, maxval, negate=bool(negate), occupied_thresh=occ_t, free_thresh=free_t, mode=mode)
    # between the thresholds: the same cells in both modes (trinary's -1, scale's costs 1..99 and any 0/100 the
    # rounding made of them)
    p = _probabilities(pixels, maxval, bool(negate))
    undecided: npt.NDArray[np.bool_] = _looked_up((p >= free_t) & (p <= occ_t), pixels)
    if clear is not None and mode == "scale":  # a pixel not fully opaque: unknown, as map_server says
        values[clear[::-1]] = -1
        undecided |= clear[::-1]
    values.setflags(write=False)
    undecided.setflags(write=False)
    return MapImage(values, undecided, resolution, (ox, oy, 0.0), mode, path)


# ---------------------------------------------------------------------------------------------------
# rasterisation


def cell_span(
    lo: npt.NDArray[np.floating], hi: npt.NDArray[np.floating], origin: float, res: float, n: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
    """Indices [first, last] of the occupancy cells that overlap the open intervals (lo, hi)."""
    eps = 1e-9
    first = np.floor((lo - origin) / res + eps).astype(np.int64)
    last = np.ceil((hi - origin) / res - eps).astype(np.int64) - 1
    valid = (last >= 0) & (first <= n - 1) & (last >= first)
    return np.clip(first, 0, n - 1), np.clip(last, 0, n - 1), valid


def rasterize_occupancy(
    occ: OccupancyMap,
    origin_xy: Iterable[float],
    resolution: float,
    shape: Iterable[int],
    conservative: bool = False,
    outside_occupied: bool = False,
) -> npt.NDArray[np.bool_]:
    """Occupancy of a target grid: (ny, nx) bool.

    The target grid has its lower-left corner at ``origin_xy`` [m], square cells of ``resolution``
    [m] and ``shape`` (ny, nx); cell (i, j) has its centre at
    ``origin_xy + ((j + 0.5) res, (i + 0.5) res)``.

    By default each target cell takes the value of the occupancy cell that contains its centre
    (nearest-cell sampling). With ``conservative=True`` it is occupied if any occupancy cell that
    overlaps it is occupied, so that one-pixel walls of a finer map are never skipped.
    Target cells outside the occupancy map are free, or with ``outside_occupied`` occupied (the
    map says nothing there: unknown, which the planner treats as occupied); with ``conservative``
    a cell only partly covered by the map counts as outside.
    """
    if occ.origin[2] != 0.0:
        raise OccupancyMapError(f"occupancy map origin yaw {occ.origin[2]} rad is not supported yet (only 0)")
    resolution = float(resolution)
    if not resolution > 0:
        raise OccupancyMapError(f"target grid resolution must be > 0, got {resolution}")
    ny, nx = (int(s) for s in shape)
    ox, oy = (float(v) for v in origin_xy)
    rows, cols = occ.occupied.shape
    mx, my, mres = occ.origin[0], occ.origin[1], occ.resolution
    out = np.full((ny, nx), bool(outside_occupied))
    if ny == 0 or nx == 0 or rows == 0 or cols == 0:
        return out
    if not conservative:
        xs = ox + (np.arange(nx) + 0.5) * resolution
        ys = oy + (np.arange(ny) + 0.5) * resolution
        c = np.floor((xs - mx) / mres).astype(np.int64)
        r = np.floor((ys - my) / mres).astype(np.int64)
        vc = (c >= 0) & (c < cols)
        vr = (r >= 0) & (r < rows)
        out[np.ix_(vr, vc)] = occ.occupied[np.ix_(r[vr], c[vc])]
        return out
    if outside_occupied:
        eps = 1e-9
        x0 = ox + np.arange(nx) * resolution
        y0 = oy + np.arange(ny) * resolution
        covered = ((y0 >= my - eps) & (y0 + resolution <= my + rows * mres + eps))[:, None] & (
            (x0 >= mx - eps) & (x0 + resolution <= mx + cols * mres + eps)
        )[None, :]
        blocked: npt.NDArray[np.bool_] = _conservative(occ, ox, oy, resolution, ny, nx) | ~covered
        return blocked
    return _conservative(occ, ox, oy, resolution, ny, nx)


def _conservative(
    occ: OccupancyMap, ox: float, oy: float, resolution: float, ny: int, nx: int
) -> npt.NDArray[np.bool_]:
    """Occupied if any overlapping occupancy cell is occupied; cells outside the map are free."""
    rows, cols = occ.occupied.shape
    mx, my, mres = occ.origin[0], occ.origin[1], occ.resolution
    x0 = ox + np.arange(nx) * resolution
    y0 = oy + np.arange(ny) * resolution
    c0, c1, vc = cell_span(x0, x0 + resolution, mx, mres, cols)
    r0, r1, vr = cell_span(y0, y0 + resolution, my, mres, rows)
    sat = np.zeros((rows + 1, cols + 1), dtype=np.int64)  # summed-area table of occupied cells
    sat[1:, 1:] = np.cumsum(np.cumsum(occ.occupied, axis=0, dtype=np.int64), axis=1)
    R0, R1, C0, C1 = r0[:, None], r1[:, None] + 1, c0[None, :], c1[None, :] + 1
    count = sat[R1, C1] - sat[R0, C1] - sat[R1, C0] + sat[R0, C0]
    return (count > 0) & vr[:, None] & vc[None, :]
