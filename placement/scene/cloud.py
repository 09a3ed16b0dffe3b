"""A 3D source for the arm's collision model: a point cloud of the room, as boxes.

A 2D map says nothing about height; a point cloud does (a depth camera's or a 3D lidar's, saved by
PCL or ``pcl_ros`` as a ``.pcd`` file, in the map frame). The scene key::

    obstacle_cloud: room.pcd                            # voxels of 0.05 m
    obstacle_cloud: {file: room.pcd, voxel: 0.03}       # [m], 0.01 .. 1

The points are binned into cubic voxels of ``voxel`` [m] (aligned with the world origin); a voxel
holding a point is occupied, except those wholly below :data:`FLOOR_IGNORE` (the floor itself, which
the collision check models exactly). The occupied voxels of each (x, y) column are merged into runs,
and each run is one box of the arm's collision model, named ``cloud[i]``. Voxels that meet a scene
object's bounding box are left out: a camera's cloud holds the objects themselves, which the scene
gives exactly (at their positions in the file; a cloud is a snapshot). The arm, the carried object
and the robot's other parts are checked against them as against the scene's boxes. The cloud is not
the base's: the base keeps to the occupancy map and the scene's obstacles.

PCD files (PCL's format 0.7, and the older 0.6): the header's ``FIELDS`` must hold ``x``, ``y`` and
``z`` (float, 4 or 8 bytes, count 1); ``DATA`` ``ascii`` or ``binary`` (``binary_compressed`` is
refused: save the cloud uncompressed). Points with a non-finite coordinate are skipped (PCL writes NaN
for missing depth). Everything is checked before it is used; a bad file is one line naming it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.validation import read_regular

#: Bounds checked before the points are read: the file [bytes], the points, the boxes made of them.
MAX_CLOUD_BYTES = 256 * 2**20
MAX_CLOUD_POINTS = 20_000_000
#: An ascii cloud is parsed line by line in Python (about 1 s per 500,000 points): fewer of them.
MAX_ASCII_POINTS = 2_000_000
MAX_CLOUD_BOXES = 200_000
#: [m] the voxel edge's range and default.
VOXEL_RANGE = (0.01, 1.0)
DEFAULT_VOXEL = 0.05
#: [m] voxels whose top is at most this high are the floor, not an obstacle.
FLOOR_IGNORE = 0.02
#: [m] coordinates beyond this are refused (as for scenes and maps).
MAX_COORD = 1e6
_HEADER_KEYS = ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA")
_HEADER_BYTES = 1 << 16


class CloudError(PlacementError):
    """A point cloud file that is missing, malformed or not supported."""


@dataclass(frozen=True, eq=False)
class VoxelCloud:
    """A point cloud as boxes: ``boxes`` (k, 6) world-frame (x0, y0, z0, x1, y1, z1) [m], one per run of
    occupied voxels of ``voxel`` [m] in a column; ``points``: the points read; ``source``: the file."""

    boxes: npt.NDArray[np.float64]
    voxel: float
    points: int
    source: Path | None = None


def _fail(name: str, msg: str) -> CloudError:
    return CloudError(f"{name}: {msg}")


def parse_pcd(data: bytes, name: str = "cloud") -> npt.NDArray[np.float64]:
    """The points (n, 3) [m] of a PCD file's bytes (see the module doc), non-finite ones skipped.
    Raises :class:`CloudError` naming ``name`` for anything malformed or unsupported."""
    header: dict[str, list[str]] = {}
    pos = 0
    while "DATA" not in header:
        end = data.find(b"\n", pos)
        if end < 0 or end > _HEADER_BYTES:
            raise _fail(name, "not a PCD file: no DATA line in its header")
        line = data[pos:end].strip()
        pos = end + 1
        if not line or line.startswith(b"#"):
            continue
        try:
            words = line.decode("ascii").split()
        except UnicodeDecodeError:
            raise _fail(name, "not a PCD file: its header is not ASCII text") from None
        key = words[0].upper()
        if key not in _HEADER_KEYS:
            raise _fail(name, f"not a PCD file: unknown header line {words[0][:20]!r}")
        header[key] = words[1:]
    for key in ("FIELDS", "SIZE", "TYPE", "POINTS"):
        if key not in header:
            raise _fail(name, f"the PCD header has no {key} line")
    fields = header["FIELDS"]
    n_fields = len(fields)
    counts = header.get("COUNT", ["1"] * n_fields)
    if not (len(header["SIZE"]) == len(header["TYPE"]) == len(counts) == n_fields) or n_fields == 0:
        raise _fail(name, "the PCD header's FIELDS, SIZE, TYPE and COUNT lines differ in length")
    try:
        sizes = [int(v) for v in header["SIZE"]]
        counts_i = [int(v) for v in counts]
        points_word = header["POINTS"][0] if header["POINTS"] else ""
        if not points_word.isdigit() or len(points_word) > 12:
            raise ValueError
        n = int(points_word)
    except ValueError:
        raise _fail(name, "the PCD header's SIZE, COUNT and POINTS must be non-negative integers") from None
    types = [t.upper() for t in header["TYPE"]]
    if any(s not in (1, 2, 4, 8) for s in sizes) or any(t not in ("F", "I", "U") for t in types):
        raise _fail(name, "the PCD header's SIZE must be 1, 2, 4 or 8 and TYPE F, I or U")
    if any(c < 1 or c > 1024 for c in counts_i):
        raise _fail(name, "the PCD header's COUNT must be 1 .. 1024")
    if n > MAX_CLOUD_POINTS:
        raise _fail(name, f"{n} points, more than the {MAX_CLOUD_POINTS} allowed: downsample the cloud")
    for axis in ("x", "y", "z"):
        if fields.count(axis) != 1:
            raise _fail(name, f"the PCD fields {', '.join(fields)[:80]} must hold '{axis}' once")
        k = fields.index(axis)
        if types[k] != "F" or sizes[k] not in (4, 8) or counts_i[k] != 1:
            raise _fail(name, f"the PCD field '{axis}' must be a float (TYPE F, SIZE 4 or 8, COUNT 1)")
    kind = (header["DATA"] or [""])[0].lower()
    if kind == "binary_compressed":
        raise _fail(name, "binary_compressed PCD is not supported: save the cloud as binary or ascii")
    if kind == "binary":
        dtype = np.dtype(
            [
                (f"f{k}", f"<{'f' if t == 'F' else 'i' if t == 'I' else 'u'}{s}", (c,) if c > 1 else ())
                for k, (t, s, c) in enumerate(zip(types, sizes, counts_i))
            ]
        )
        need = n * dtype.itemsize
        if len(data) - pos < need:
            raise _fail(name, f"binary data truncated: {len(data) - pos} bytes for {n} points of {dtype.itemsize}")
        rec = np.frombuffer(data, dtype=dtype, count=n, offset=pos)
        xyz = np.stack([rec[f"f{fields.index(a)}"].astype(np.float64) for a in ("x", "y", "z")], axis=1)
    elif kind == "ascii":
        if n > MAX_ASCII_POINTS:
            raise _fail(name, f"{n} ascii points, more than the {MAX_ASCII_POINTS} allowed: save the cloud as binary")
        width = sum(counts_i)
        columns = [sum(counts_i[:k]) for k in (fields.index("x"), fields.index("y"), fields.index("z"))]
        lines = data[pos:].split(b"\n")
        rows = [ln.split() for ln in lines if ln.strip()]
        if len(rows) < n:
            raise _fail(name, f"ascii data has {len(rows)} points, the header says {n}")
        xyz = np.empty((n, 3))
        for i, row in enumerate(rows[:n]):
            if len(row) != width:
                raise _fail(name, f"ascii point {i} has {len(row)} values, the fields need {width}")
            try:
                xyz[i] = [float(row[c]) for c in columns]
            except ValueError:
                raise _fail(name, f"ascii point {i} is not numbers") from None
    else:
        raise _fail(name, f"PCD DATA must be ascii or binary, got {kind[:20]!r}")
    with np.errstate(invalid="ignore"):
        keep = np.all(np.isfinite(xyz), axis=1)
    xyz = xyz[keep]
    if xyz.size and float(np.abs(xyz).max()) > MAX_COORD:
        raise _fail(name, f"a point lies beyond +-{MAX_COORD:g} m of the origin")
    return xyz


def voxel_boxes(points: npt.ArrayLike, voxel: float, exclude: npt.ArrayLike | None = None) -> npt.NDArray[np.float64]:
    """(k, 6) boxes (x0, y0, z0, x1, y1, z1) [m]: per (x, y) column of cubic voxels of ``voxel`` [m],
    each run of consecutive occupied voxels (a voxel holds a point; those whose top is at most
    :data:`FLOOR_IGNORE` high are left out, and those that meet one of the ``exclude`` (m, 2, 3) boxes
    (min, max corners [m]: the scene's objects, whose own points the cloud holds)), sorted by column
    then height."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(P):
        return np.zeros((0, 6))
    keys = np.floor(P / voxel).astype(np.int64)
    keys = keys[(keys[:, 2] + 1) * voxel > FLOOR_IGNORE]
    for lo, hi in np.asarray(exclude if exclude is not None else np.zeros((0, 2, 3)), dtype=float).reshape(-1, 2, 3):
        meets = np.all((keys * voxel <= hi) & ((keys + 1) * voxel >= lo), axis=1)
        keys = keys[~meets]
    if not len(keys):
        return np.zeros((0, 6))
    keys = np.unique(keys, axis=0)  # sorted by x, then y, then z
    # a run starts where the column changes or z does not follow the voxel below
    new = np.ones(len(keys), dtype=bool)
    new[1:] = (keys[1:, 0] != keys[:-1, 0]) | (keys[1:, 1] != keys[:-1, 1]) | (keys[1:, 2] != keys[:-1, 2] + 1)
    starts = np.flatnonzero(new)
    ends = np.append(starts[1:], len(keys)) - 1
    lo = keys[starts].astype(np.float64) * voxel
    hi = (keys[ends].astype(np.float64) + 1.0) * voxel
    return np.concatenate([lo, hi], axis=1)


def load_cloud(path: str | Path, voxel: float = DEFAULT_VOXEL, exclude: npt.ArrayLike | None = None) -> VoxelCloud:
    """The cloud of a PCD file as boxes (see the module doc; ``exclude``: (m, 2, 3) boxes whose voxels
    are left out, see :func:`voxel_boxes`); :class:`CloudError` for a bad file or too many boxes."""
    path = Path(path)
    if not (VOXEL_RANGE[0] <= voxel <= VOXEL_RANGE[1]) or not math.isfinite(voxel):
        raise CloudError(f"{path}: voxel must be within {VOXEL_RANGE[0]:g} .. {VOXEL_RANGE[1]:g} m, got {voxel:g}")
    data = read_regular(path, CloudError, f"point cloud {path}", MAX_CLOUD_BYTES, "point cloud")
    points = parse_pcd(data, str(path))
    boxes = voxel_boxes(points, voxel, exclude)
    if len(boxes) > MAX_CLOUD_BOXES:
        raise CloudError(
            f"{path}: {len(boxes)} boxes of {voxel:g} m voxels, more than the {MAX_CLOUD_BOXES} allowed: "
            "give a coarser voxel or crop the cloud"
        )
    boxes.setflags(write=False)
    return VoxelCloud(boxes, float(voxel), len(points), path)
