"""Map images in the formats nav2_map_server reads (PNG, BMP, PPM, ...) give the OccupancyGrid it
publishes: checked against its per-pixel rule written out plainly, on random images of every mode."""

from __future__ import annotations

import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image
from support.occupancy import PIXELS, write_map

from placement.scene.occupancy import OccupancyMapError, load_map_image, load_occupancy_map


def nav2_values(rgba: np.ndarray, alpha: bool, mode: str, negate: bool, occ_t: float, free_t: float) -> np.ndarray:
    """nav2_map_server's loadMapFromFile, pixel by pixel: (rows, cols) int8, row 0 the image's bottom.

    ``rgba``: (rows, cols, 4) 0..255, top row first; ``alpha``: whether the image has an alpha channel."""
    rows, cols, _ = rgba.shape
    out = np.zeros((rows, cols), np.int8)
    for y in range(rows):
        for x in range(cols):
            r, g, b, a = (int(v) for v in rgba[y, x])
            channels = [r, g, b]
            if mode == "trinary" and alpha:
                channels.append(a)  # map_server's MaxRGB - alphaQuantum: the opacity
            shade = sum(channels) / len(channels) / 255.0
            occ = shade if negate else 1.0 - shade
            if mode == "scale" and alpha and a != 255:
                cell = -1
            elif occ_t < occ:
                cell = 100
            elif occ < free_t:
                cell = 0
            elif mode == "trinary":
                cell = -1
            else:
                cell = int(np.rint((occ - free_t) / (occ_t - free_t) * 100.0))
            out[rows - 1 - y, x] = cell
    return out


def write(folder: Path, img: Image.Image, fmt: str, **doc: object) -> Path:
    img.save(folder / f"map.{fmt}")
    meta = {"image": f"map.{fmt}", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], **doc}
    (folder / "map.yaml").write_text(yaml.safe_dump(meta))
    return folder / "map.yaml"


levels = st.sampled_from([0, 1, 50, 100, 128, 204, 205, 206, 250, 254, 255])


@settings(max_examples=60, deadline=None)
@given(
    pixels=arrays(np.uint8, st.tuples(st.integers(1, 5), st.integers(1, 5), st.just(4)), elements=levels),
    kind=st.sampled_from(["L", "LA", "RGB", "RGBA", "P"]),
    mode=st.sampled_from(["trinary", "scale"]),
    negate=st.booleans(),
)
def test_png_of_any_mode_reads_as_nav2_map_server_publishes(pixels, kind, mode, negate):
    if kind in ("L", "LA"):
        pixels[..., 1] = pixels[..., 2] = pixels[..., 0]
    if kind in ("L", "RGB"):
        pixels[..., 3] = 255
    img = Image.fromarray(pixels, "RGBA").convert(kind)
    with tempfile.TemporaryDirectory() as tmp:
        got = load_map_image(write(Path(tmp), img, "png", mode=mode, negate=int(negate)))
        with Image.open(Path(tmp) / "map.png") as saved:  # a palette saved with alpha gets a tRNS chunk
            alpha = saved.mode in ("LA", "RGBA") or "transparency" in saved.info
    rgba = np.asarray(img.convert("RGBA"))
    want = nav2_values(rgba, alpha, mode, negate, 0.65, 0.196)
    np.testing.assert_array_equal(got.values, want)
    # the cells that are neither free nor occupied follow the unknown policy (a cost in scale mode,
    # even where the cost rounds to 0 or 100), and so do those not opaque in a scale map
    channels = rgba[..., : 4 if alpha and mode == "trinary" else 3].astype(float)
    shade = channels.sum(axis=2) / channels.shape[2] / 255.0
    p = shade if negate else 1.0 - shade
    between = (p >= 0.196) & (p <= 0.65)
    if alpha and mode == "scale":
        between |= rgba[..., 3] != 255
    assert np.array_equal(got.unknown, between[::-1])


@pytest.mark.parametrize("fmt", ["png", "bmp", "ppm", "tiff"])
def test_a_grey_image_in_any_format_is_the_same_map_as_its_pgm(tmp_path, fmt):
    pgm = load_occupancy_map(write_map(tmp_path))
    other = tmp_path / "other"
    other.mkdir()
    img = Image.fromarray(np.array(PIXELS, np.uint8), "L").convert("RGB" if fmt == "ppm" else "L")
    occ = load_occupancy_map(write(other, img, fmt, resolution=0.5, origin=[1.0, 2.0, 0.0]))
    np.testing.assert_array_equal(occ.occupied, pgm.occupied)
    assert occ.resolution == pgm.resolution and occ.origin == pgm.origin


def test_a_scale_map_saved_by_map_saver_keeps_its_unknown_cells(tmp_path):
    """map_saver writes a scale map as PNG, grey with alpha 0 where unknown: those cells are unknown
    (occupied for the base by default, free with ``unknown: free``), the others scaled."""
    rgba = np.zeros((2, 3, 4), np.uint8)
    rgba[..., :3] = [[[255] * 3, [128] * 3, [0] * 3], [[128] * 3, [255] * 3, [255] * 3]]
    rgba[..., 3] = 255
    rgba[1, 2, 3] = 0  # unknown
    path = write(tmp_path, Image.fromarray(rgba, "RGBA"), "png", mode="scale")
    image = load_map_image(path)
    # 128: occupancy 0.498, (0.498 - 0.196) / (0.65 - 0.196) = 0.665 -> 67; row 0: the image's bottom row
    assert image.values.tolist() == [[67, 0, -1], [0, 67, 100]]
    assert load_occupancy_map(path).occupied.tolist() == [[True, False, True], [False, True, True]]
    assert load_occupancy_map(path, unknown="free").occupied.tolist() == [[False, False, False], [False, False, True]]


def _png_with_size(width: int, height: int) -> bytes:
    """A 1 x 1 grey PNG whose header says ``width`` x ``height``."""
    import io

    buf = io.BytesIO()
    Image.new("L", (1, 1)).save(buf, "png")
    data = bytearray(buf.getvalue())
    ihdr = data.index(b"IHDR")
    data[ihdr + 4 : ihdr + 12] = width.to_bytes(4, "big") + height.to_bytes(4, "big")
    data[ihdr + 17 : ihdr + 21] = zlib.crc32(bytes(data[ihdr : ihdr + 17])).to_bytes(4, "big")
    return bytes(data)


@pytest.mark.parametrize(
    "data, message",
    [
        (b"not an image at all", "not an image nav2_map_server reads"),
        (None, "not an image nav2_map_server reads"),  # a PNG cut in half
        (_png_with_size(100_000, 100_000), "more pixels than the 40,000,000 allowed"),
        (b"", "not an image nav2_map_server reads"),
    ],
)
def test_a_bad_image_is_one_line_naming_it(tmp_path, data, message):
    if data is None:
        import io

        buf = io.BytesIO()
        Image.fromarray(np.arange(600, dtype=np.uint8).reshape(20, 30) % 255, "L").save(buf, "png")
        data = buf.getvalue()[: len(buf.getvalue()) // 2]
    (tmp_path / "map.png").write_bytes(data)
    (tmp_path / "map.yaml").write_text("image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(OccupancyMapError) as err:
        load_occupancy_map(tmp_path / "map.yaml")
    text = str(err.value)
    assert message in text and "map.png" in text and "\n" not in text
