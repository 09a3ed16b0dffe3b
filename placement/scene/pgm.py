"""PGM images (binary ``P5`` and plain ``P2``, 8-bit or 16-bit), the images of ROS occupancy maps,
decoded with numpy alone: the header is checked against the size bounds before the raster is read or
anything is allocated for it. A maxval above 255 stores two bytes per pixel, the most significant
first (the Netpbm format); ``nav2_map_server`` shades such a pixel by its value over maxval too."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.validation import read_regular

#: Largest maxval of a PGM (Netpbm: below 65536; above 255, two bytes per pixel).
MAX_MAXVAL = 65535

#: Bounds checked before anything is allocated: the image's pixels (a binary P5 image; a plain P2 one
#: is text parsed in Python, so it gets fewer).
MAX_IMAGE_PIXELS = 40_000_000
MAX_PLAIN_PIXELS = 4_000_000
_HEADER_BYTES = 1 << 16


class OccupancyMapError(PlacementError):
    """A ROS occupancy map (YAML or image) that is missing, malformed or not supported."""


_WS = b" \t\n\r\x0b\x0c"
_TOKEN = re.compile(rb"[^\s#]+")


def _malformed(name: str, msg: str) -> OccupancyMapError:
    return OccupancyMapError(f"{name}: malformed PGM: {msg}")


def _pgm_header(data: bytes, name: str) -> tuple[bytes, int, int, int, int]:
    """(magic, width, height, maxval, offset of the byte after maxval) of a PGM, checked against the
    size bounds; raises :class:`OccupancyMapError` naming ``name``."""
    if data[:4] == b"\x89PNG":
        raise OccupancyMapError(f"{name}: a PNG image, not a PGM (read_map_image reads both)")
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise OccupancyMapError(f"{name}: not a PGM image (magic {magic!r}, expected b'P5' or b'P2')")
    # header: magic, width, height, maxval, separated by whitespace and '#' comments
    pos = 2
    fields: list[int] = []
    while len(fields) < 3:
        if pos >= len(data):
            raise _malformed(
                name,
                "header ends early (need width, height and maxval)"
                if len(data) < _HEADER_BYTES
                else f"header longer than {_HEADER_BYTES} bytes",
            )
        c = data[pos : pos + 1]
        if c in (b" ", b"\t", b"\n", b"\r", b"\x0b", b"\x0c"):
            pos += 1
        elif c == b"#":
            end = data.find(b"\n", pos)
            pos = len(data) if end < 0 else end + 1
        else:
            m = _TOKEN.match(data, pos)
            assert m is not None  # data[pos] is neither whitespace nor '#'
            token = m.group(0)
            if not token.isdigit():
                raise _malformed(name, f"header field {token[:20]!r} is not a positive integer")
            if len(token) > 9:
                raise _malformed(name, f"header field of {len(token)} digits (at most 9)")
            if pos == 2:
                raise _malformed(name, "no whitespace after the magic number")
            fields.append(int(token))
            pos = m.end()
    width, height, maxval = fields
    if width < 1 or height < 1:
        raise _malformed(name, f"size {width} x {height}")
    if not 1 <= maxval <= MAX_MAXVAL:
        raise _malformed(name, f"maxval {maxval} (1 .. {MAX_MAXVAL})")
    limit = MAX_IMAGE_PIXELS if magic == b"P5" else MAX_PLAIN_PIXELS
    if width * height > limit:
        raise OccupancyMapError(
            f"{name}: the image is {width} x {height} = {width * height} pixels, more than the "
            f"{limit} allowed for a{' plain (P2)' if magic == b'P2' else ''} map; crop it, or "
            "save it at a coarser resolution"
        )
    return magic, width, height, maxval, pos


def parse_pgm(data: bytes, name: str = "image") -> tuple[npt.NDArray[np.unsignedinteger[Any]], int]:
    """Decode a PGM (binary ``P5`` or plain ``P2``, maxval up to 65535) of at most
    :data:`MAX_IMAGE_PIXELS` pixels (:data:`MAX_PLAIN_PIXELS` for ``P2``).

    Returns ``(pixels, maxval)``: pixels (height, width) in file order (top row first), uint8 for a
    maxval up to 255, else uint16. Raises :class:`OccupancyMapError` naming ``name`` for anything
    malformed or unsupported.
    """
    magic, width, height, maxval, pos = _pgm_header(data, name)
    n = width * height
    wide = maxval > 255
    if magic == b"P5":
        if pos >= len(data) or data[pos : pos + 1] not in (b" ", b"\t", b"\n", b"\r", b"\x0b", b"\x0c"):
            raise _malformed(name, "no whitespace between maxval and the raster")
        raster = memoryview(data)[pos + 1 :]
        size = 2 * n if wide else n
        if len(raster) < size:
            raise _malformed(
                name, f"raster truncated: {len(raster)} bytes for {width} x {height} = {n} pixels of {size // n} bytes"
            )
        if bytes(raster[size:]).strip(_WS):
            raise _malformed(name, f"{len(raster) - size} bytes of trailing data after the raster")
        kind = np.dtype(">u2") if wide else np.dtype(np.uint8)
        pixels: np.ndarray = np.frombuffer(raster, dtype=kind, count=n).reshape(height, width).copy()
    else:
        text = re.sub(rb"#[^\n]*", b" ", data[pos:])
        tokens = text.split()
        if len(tokens) != n:
            raise _malformed(name, f"{len(tokens)} values for {width} x {height} = {n} pixels")
        if not all(t.isdigit() for t in tokens):
            raise _malformed(name, "the raster holds a value that is not a non-negative integer")
        digits = len(str(maxval))
        if any(len(t) > digits for t in tokens):
            raise _malformed(name, f"a pixel value of more than {digits} digits exceeds maxval {maxval}")
        values = np.array([int(t) for t in tokens], dtype=np.int64)
        pixels = values.reshape(height, width)
    if pixels.max(initial=0) > maxval:
        raise _malformed(name, f"pixel value {int(pixels.max())} exceeds maxval {maxval}")
    return pixels.astype(np.uint16 if wide else np.uint8), maxval


def read_pgm(path: str | Path) -> tuple[npt.NDArray[np.unsignedinteger[Any]], int]:
    """Read a PGM file: ``(pixels (height, width) uint8 or uint16, top row first, maxval)``.

    Only a regular file is read, and its header first: an image over the pixel bounds is refused
    before its raster is read or anything is allocated for it."""
    path = Path(path)
    head = read_regular(path, OccupancyMapError, f"image {path}", 2**62, "image", prefix=_HEADER_BYTES)
    magic, width, height, maxval, pos = _pgm_header(head, str(path))
    n = width * height
    most = pos + 1 + (2 if maxval > 255 else 1) * n + _HEADER_BYTES if magic == b"P5" else pos + 8 * n + 2**20
    try:
        data = read_regular(path, OccupancyMapError, f"image {path}", most, "image")
    except OccupancyMapError as exc:
        raise OccupancyMapError(f"{exc} for {width} x {height} pixels") from None
    return parse_pgm(data, str(path))
