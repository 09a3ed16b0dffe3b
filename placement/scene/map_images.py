"""The image of a ROS map in any format ``nav2_map_server`` reads: PGM with numpy alone
(:mod:`placement.scene.pgm`), PNG, BMP and the others Pillow decodes (``map_saver`` writes a
``scale`` map as PNG, its alpha channel marking unknown cells).

``nav2_map_server`` makes one shade of each pixel: the mean of its red, green and blue channels and,
in ``trinary`` mode when the image has an alpha channel, its opacity as a fourth channel; in
``scale`` mode a pixel that is not opaque is unknown. :func:`read_map_image` returns what that rule
needs as integers: per pixel the sum of the channels it averages, their largest possible sum, and
the pixels that are not opaque. A grey image is its own shade.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.scene.pgm import MAX_IMAGE_PIXELS, OccupancyMapError, read_pgm
from placement.validation import read_regular

#: Largest image file read [bytes] in a compressed format (PNG of 40 M pixels compresses well).
MAX_IMAGE_BYTES = 256 * 2**20
#: Image modes (Pillow's names) and the channels ``nav2_map_server`` averages: grey, or red, green, blue.
_GREY = ("1", "L", "I;16", "I;16B", "I;16L", "I")
_COLOUR = ("RGB", "RGBA", "LA", "P", "PA", "CMYK", "YCbCr", "La", "RGBa")


def read_map_image(
    path: str | Path, mode: str = "trinary"
) -> tuple[npt.NDArray[np.unsignedinteger[Any]], int, npt.NDArray[np.bool_] | None]:
    """The pixels of a map image as ``nav2_map_server`` shades them (see the module docstring).

    Returns ``(sums (height, width) uint8 or uint16, top row first; their largest possible value; the pixels
    that are not fully opaque (height, width) bool, or None without an alpha channel)``: the shade
    of a pixel is ``sum / maxval``. A PGM is read by :func:`~placement.scene.pgm.read_pgm`.
    Raises :class:`OccupancyMapError` for an image that is not a regular file, too large
    (:data:`~placement.scene.pgm.MAX_IMAGE_PIXELS`), or that no decoder reads.
    """
    path = Path(path)
    head = read_regular(path, OccupancyMapError, f"image {path}", 2**62, "image", prefix=16)
    if head[:2] in (b"P2", b"P5"):
        pixels, maxval = read_pgm(path)
        return pixels, maxval, None
    data = read_regular(path, OccupancyMapError, f"image {path}", MAX_IMAGE_BYTES, "image")
    from PIL import Image, UnidentifiedImageError

    too_large = f"{path}: the image has more pixels than the {MAX_IMAGE_PIXELS:,} allowed"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            img = Image.open(io.BytesIO(data))
            width, height = img.size
            if width * height > MAX_IMAGE_PIXELS:
                raise OccupancyMapError(f"{too_large} ({width} x {height})")
            img.load()
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):  # Pillow's own bound, met on opening
        raise OccupancyMapError(too_large) from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise OccupancyMapError(
            f"{path}: not an image nav2_map_server reads ({' '.join(str(exc).split()) or type(exc).__name__}); "
            "save the map as PGM or PNG"
        ) from None
    return _shades(img, mode, str(path))


def _shades(
    img: object, mode: str, name: str
) -> tuple[npt.NDArray[np.unsignedinteger[Any]], int, npt.NDArray[np.bool_] | None]:
    """:func:`read_map_image` of a decoded Pillow image ``img``."""
    from PIL import Image

    assert isinstance(img, Image.Image)
    if img.mode in _GREY:
        grey = np.asarray(img.convert("I") if img.mode == "1" else img)
        if img.mode == "1":
            return (grey > 0).astype(np.uint8), 1, None
        top = 65535 if img.mode.startswith("I") else 255
        if grey.min(initial=0) < 0 or grey.max(initial=0) > top:
            raise OccupancyMapError(f"{name}: grey values outside 0 .. {top}")
        return grey.astype(np.uint16 if top > 255 else np.uint8), top, None
    if img.mode not in _COLOUR:
        raise OccupancyMapError(f"{name}: image mode {img.mode} is not supported (grey, RGB or RGBA images are)")
    alpha = img.mode in ("RGBA", "LA", "PA", "La", "RGBa") or (img.mode == "P" and "transparency" in img.info)
    rgba = np.asarray(img.convert("RGBA" if alpha else "RGB"))  # uint8: sums of four fit in uint16
    sums = rgba[..., :3].sum(axis=2, dtype=np.uint16)
    if not alpha:
        return sums, 3 * 255, None
    opacity = rgba[..., 3]
    clear = opacity != 255
    if mode == "trinary":  # the opacity is averaged in as a fourth channel
        return sums + opacity, 4 * 255, clear  # (uint16 + uint8: uint16)
    return sums, 3 * 255, clear
