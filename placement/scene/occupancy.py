"""ROS map_server occupancy maps (YAML + 8-bit PGM) and their rasterisation onto a planning grid.

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
**Unknown cells are treated as occupied** (the base must not drive where nobody has looked), so in
the boolean map a cell is free exactly when ``p < free_thresh``; ``mode: scale`` therefore gives the
same boolean map as ``trinary``.

The image is stored top row first (the top row is the largest y); :class:`OccupancyMap` flips it so
that row 0 is the lowest y, like every other planar grid of the package (row = y, column = x).
Only PGM images (binary ``P5`` and plain ``P2``, maxval <= 255) are read, with numpy alone; a
rotated origin (yaw != 0) is rejected (not supported yet).
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from placement.errors import PlacementError
from placement.validation import parse_yaml, read_regular, read_text, show

log = logging.getLogger(__name__)

#: Defaults of the optional keys (those that ROS ``map_saver`` writes).
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196
_MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
_MODES = ("trinary", "scale")
#: Bounds checked before anything is allocated: the map YAML's size [bytes], the image's pixels (a
#: binary P5 image; a plain P2 one is text parsed in Python, so it gets fewer), the resolution [m] and
#: the coordinates of the map's corners [m].
MAX_MAP_YAML_BYTES = 2**20
MAX_IMAGE_PIXELS = 40_000_000
MAX_PLAIN_PIXELS = 4_000_000
RESOLUTION_RANGE = (1e-3, 100.0)
MAX_COORD = 1e6
_HEADER_BYTES = 1 << 16


class OccupancyMapError(PlacementError):
    """A ROS occupancy map (YAML or image) that is missing, malformed or not supported."""


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
    """

    occupied: np.ndarray
    resolution: float
    origin: tuple[float, float, float]
    source: Path | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return self.occupied.shape

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) [m] covered by the map."""
        rows, cols = self.occupied.shape
        x0, y0 = self.origin[0], self.origin[1]
        return (x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution)


# ---------------------------------------------------------------------------------------------------
# PGM


_WS = b" \t\n\r\x0b\x0c"


def _pgm_header(data: bytes, name: str) -> tuple[bytes, int, int, int, int]:
    """(magic, width, height, maxval, offset of the byte after maxval) of a PGM, checked against the
    size bounds; raises :class:`OccupancyMapError` naming ``name``."""

    def bad(msg: str) -> OccupancyMapError:
        return OccupancyMapError(f"{name}: malformed PGM: {msg}")

    if data[:4] == b"\x89PNG":
        raise OccupancyMapError(f"{name}: PNG images are not supported; convert the map to an 8-bit PGM (P5 or P2)")
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise OccupancyMapError(
            f"{name}: not a PGM image (magic {magic!r}, expected b'P5' or b'P2'); only 8-bit PGM maps are supported"
        )
    # header: magic, width, height, maxval, separated by whitespace and '#' comments
    pos, fields = 2, []
    while len(fields) < 3:
        if pos >= len(data):
            raise bad(
                "header ends early (need width, height and maxval)"
                if len(data) < _HEADER_BYTES
                else f"header longer than {_HEADER_BYTES} bytes"
            )
        c = data[pos : pos + 1]
        if c in (b" ", b"\t", b"\n", b"\r", b"\x0b", b"\x0c"):
            pos += 1
        elif c == b"#":
            end = data.find(b"\n", pos)
            pos = len(data) if end < 0 else end + 1
        else:
            m = re.compile(rb"[^\s#]+").match(data, pos)
            token = m.group(0)
            if not token.isdigit():
                raise bad(f"header field {token[:20]!r} is not a positive integer")
            if len(token) > 9:
                raise bad(f"header field of {len(token)} digits (at most 9)")
            if pos == 2:
                raise bad("no whitespace after the magic number")
            fields.append(int(token))
            pos = m.end()
    width, height, maxval = fields
    if width < 1 or height < 1:
        raise bad(f"size {width} x {height}")
    if not 1 <= maxval <= 255:
        if maxval > 255:
            raise OccupancyMapError(
                f"{name}: {maxval + 1}-level (16-bit) PGM is not supported; only 8-bit (maxval <= 255)"
            )
        raise bad(f"maxval {maxval}")
    limit = MAX_IMAGE_PIXELS if magic == b"P5" else MAX_PLAIN_PIXELS
    if width * height > limit:
        raise OccupancyMapError(
            f"{name}: the image is {width} x {height} = {width * height} pixels, more than the "
            f"{limit} allowed for a{' plain (P2)' if magic == b'P2' else ''} map; crop it, or "
            "save it at a coarser resolution"
        )
    return magic, width, height, maxval, pos


def parse_pgm(data: bytes, name: str = "image") -> tuple[np.ndarray, int]:
    """Decode an 8-bit PGM (binary ``P5`` or plain ``P2``) of at most :data:`MAX_IMAGE_PIXELS` pixels
    (:data:`MAX_PLAIN_PIXELS` for ``P2``).

    Returns ``(pixels, maxval)``: pixels (height, width) uint8 in file order (top row first).
    Raises :class:`OccupancyMapError` naming ``name`` for anything malformed or unsupported.
    """

    def bad(msg: str) -> OccupancyMapError:
        return OccupancyMapError(f"{name}: malformed PGM: {msg}")

    magic, width, height, maxval, pos = _pgm_header(data, name)
    n = width * height
    if magic == b"P5":
        if pos >= len(data) or data[pos : pos + 1] not in (b" ", b"\t", b"\n", b"\r", b"\x0b", b"\x0c"):
            raise bad("no whitespace between maxval and the raster")
        raster = memoryview(data)[pos + 1 :]
        if len(raster) < n:
            raise bad(f"raster truncated: {len(raster)} bytes for {width} x {height} = {n} pixels")
        if bytes(raster[n:]).strip(_WS):
            raise bad(f"{len(raster) - n} bytes of trailing data after the raster")
        pixels = np.frombuffer(raster, dtype=np.uint8, count=n).reshape(height, width).copy()
    else:
        text = re.sub(rb"#[^\n]*", b" ", data[pos:])
        tokens = text.split()
        if len(tokens) != n:
            raise bad(f"{len(tokens)} values for {width} x {height} = {n} pixels")
        if not all(t.isdigit() for t in tokens):
            raise bad("the raster holds a value that is not a non-negative integer")
        if any(len(t) > 3 for t in tokens):
            raise bad(f"a pixel value of more than 3 digits exceeds maxval {maxval}")
        values = np.array([int(t) for t in tokens], dtype=np.int64)
        pixels = values.reshape(height, width)
    if pixels.max(initial=0) > maxval:
        raise bad(f"pixel value {int(pixels.max())} exceeds maxval {maxval}")
    return pixels.astype(np.uint8), maxval


def read_pgm(path: str | Path) -> tuple[np.ndarray, int]:
    """Read an 8-bit PGM file: ``(pixels (height, width) uint8, top row first, maxval)``.

    Only a regular file is read, and its header first: an image over the pixel bounds is refused
    before its raster is read or anything is allocated for it."""
    path = Path(path)
    head = read_regular(path, OccupancyMapError, f"image {path}", 2**62, "image", prefix=_HEADER_BYTES)
    magic, width, height, _, pos = _pgm_header(head, str(path))
    n = width * height
    most = pos + 1 + n + _HEADER_BYTES if magic == b"P5" else pos + 8 * n + 2**20
    try:
        data = read_regular(path, OccupancyMapError, f"image {path}", most, "image")
    except OccupancyMapError as exc:
        raise OccupancyMapError(f"{exc} for {width} x {height} pixels") from None
    return parse_pgm(data, str(path))


# ---------------------------------------------------------------------------------------------------
# map_server YAML


def occupancy_from_pixels(
    pixels: np.ndarray,
    maxval: int = 255,
    *,
    negate: bool = False,
    occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
    free_thresh: float = DEFAULT_FREE_THRESH,
) -> np.ndarray:
    """map_server semantics on an image (top row first) -> (rows, cols) bool, row 0 = lowest y.

    ``p = (maxval - v) / maxval`` (``v / maxval`` if ``negate``); True where ``p >= free_thresh``,
    i.e. occupied (``p > occupied_thresh``) or unknown (in between), which is treated as occupied.
    ``occupied_thresh`` only separates occupied from unknown and so does not change the result.
    """
    pixels = np.asarray(pixels)
    # the rule on each of the maxval + 1 values, then looked up: the same floats as per pixel, without
    # a float64 copy of a large image
    v = np.arange(max(maxval, int(pixels.max(initial=0))) + 1, dtype=np.float64)
    p = v / maxval if negate else (maxval - v) / maxval
    occupied = p > occupied_thresh
    free = p < free_thresh
    unknown = ~occupied & ~free
    lut = occupied | unknown
    return np.ascontiguousarray(lut[pixels.astype(np.intp, copy=False)][::-1])


def _number(doc: dict, key: str, where: str, lo: float | None = None, hi: float | None = None) -> float:
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


def load_occupancy_map(path: str | Path) -> OccupancyMap:
    """Load a ROS map_server map (YAML + 8-bit PGM); see the module docstring for the semantics.

    Raises :class:`OccupancyMapError` for a missing or malformed YAML or image, an unsupported
    mode or image format, or a rotated origin (yaw != 0, not supported yet).
    """
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
    if oyaw != 0.0:
        raise OccupancyMapError(
            f"{where}: origin yaw {oyaw} rad is not supported yet (only 0); rotate the image instead"
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
    pixels, maxval = read_pgm(image)
    rows, cols = pixels.shape
    far = max(abs(ox), abs(oy), abs(ox + cols * resolution), abs(oy + rows * resolution))
    if far > MAX_COORD:
        raise OccupancyMapError(
            f"{where}: the map's {cols} x {rows} cells of {resolution:g} m from origin "
            f"({ox:g}, {oy:g}) reach {far:.3g} m from the world origin, beyond +-{MAX_COORD:g} m"
        )
    occupied = occupancy_from_pixels(pixels, maxval, negate=bool(negate), occupied_thresh=occ_t, free_thresh=free_t)
    occupied.setflags(write=False)
    return OccupancyMap(occupied, resolution, (ox, oy, 0.0), path)


# ---------------------------------------------------------------------------------------------------
# rasterisation


def _span(lo: np.ndarray, hi: np.ndarray, origin: float, res: float, n: int):
    """Indices [first, last] of the occupancy cells that overlap the open intervals (lo, hi)."""
    eps = 1e-9
    first = np.floor((lo - origin) / res + eps).astype(np.int64)
    last = np.ceil((hi - origin) / res - eps).astype(np.int64) - 1
    valid = (last >= 0) & (first <= n - 1) & (last >= first)
    return np.clip(first, 0, n - 1), np.clip(last, 0, n - 1), valid


def rasterize_occupancy(
    occ: OccupancyMap, origin_xy, resolution: float, shape, conservative: bool = False, outside_occupied: bool = False
) -> np.ndarray:
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
        return _conservative(occ, ox, oy, resolution, ny, nx) | ~covered
    return _conservative(occ, ox, oy, resolution, ny, nx)


def _conservative(occ: OccupancyMap, ox: float, oy: float, resolution: float, ny: int, nx: int) -> np.ndarray:
    """Occupied if any overlapping occupancy cell is occupied; cells outside the map are free."""
    rows, cols = occ.occupied.shape
    mx, my, mres = occ.origin[0], occ.origin[1], occ.resolution
    x0 = ox + np.arange(nx) * resolution
    y0 = oy + np.arange(ny) * resolution
    c0, c1, vc = _span(x0, x0 + resolution, mx, mres, cols)
    r0, r1, vr = _span(y0, y0 + resolution, my, mres, rows)
    sat = np.zeros((rows + 1, cols + 1), dtype=np.int64)  # summed-area table of occupied cells
    sat[1:, 1:] = np.cumsum(np.cumsum(occ.occupied, axis=0, dtype=np.int64), axis=1)
    R0, R1, C0, C1 = r0[:, None], r1[:, None] + 1, c0[None, :], c1[None, :] + 1
    count = sat[R1, C1] - sat[R0, C1] - sat[R1, C0] + sat[R0, C0]
    return (count > 0) & vr[:, None] & vc[None, :]
