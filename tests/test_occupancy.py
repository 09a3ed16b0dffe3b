"""ROS map_server occupancy maps: PGM parsing, thresholds, rasterisation onto the planning grid."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from support.occupancy import EXPECTED, EXPECTED_NEGATE, PIXELS, write_map, write_pgm

from placement.errors import PlacementError
from placement.scene.occupancy import (
    OccupancyMap,
    OccupancyMapError,
    load_occupancy_map,
    parse_pgm,
    rasterize_occupancy,
)


@pytest.mark.parametrize("kind", ["P5", "P2"])
def test_occupancy_map(kind, tmp_path):
    occ = load_occupancy_map(write_map(tmp_path, kind=kind))
    assert isinstance(occ, OccupancyMap)
    assert occ.occupied.dtype == bool
    np.testing.assert_array_equal(occ.occupied, EXPECTED)
    assert occ.resolution == 0.5
    assert occ.origin == (1.0, 2.0, 0.0)
    assert occ.extent == (1.0, 2.0, 3.0, 3.5)


@pytest.mark.parametrize("kind", ["P5", "P2"])
def test_occupancy_map_negate(kind, tmp_path):
    occ = load_occupancy_map(write_map(tmp_path, kind=kind, negate=1))
    np.testing.assert_array_equal(occ.occupied, EXPECTED_NEGATE)


def test_occupancy_map_thresholds_and_defaults(tmp_path):
    # free below p = 0.7: now 100 (p 0.61) and 205 (p 0.196) are free too
    occ = load_occupancy_map(write_map(tmp_path, free_thresh=0.7, occupied_thresh=0.9, mode="scale"))
    np.testing.assert_array_equal(
        occ.occupied, np.array([[False, False, False, True], [False, True, False, False], [True, False, False, False]])
    )
    # negate, thresholds and mode are optional (map_saver defaults 0.65 / 0.196, trinary)
    occ = load_occupancy_map(write_map(tmp_path, negate=None, free_thresh=None, occupied_thresh=None))
    np.testing.assert_array_equal(occ.occupied, EXPECTED)


def test_pgm_maxval_scales(tmp_path):
    # maxval 15: p = (15 - v) / 15
    pixels, maxval = parse_pgm(b"P2 3 1 15\n0 15 12\n")
    assert maxval == 15 and pixels.tolist() == [[0, 15, 12]]
    write_pgm(tmp_path / "m.pgm", [[0, 15, 12]], kind="P5", maxval=15)
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 1\norigin: [0, 0, 0]\n")
    # 12: p = 0.2 >= 0.196 -> unknown -> occupied
    assert load_occupancy_map(tmp_path / "m.yaml").occupied.tolist() == [[True, False, True]]


@pytest.mark.parametrize("kind", ["P5", "P2"])
def test_a_16_bit_pgm_is_the_map_of_its_8_bit_twin(kind, tmp_path):
    """maxval 65535: two bytes per pixel, most significant first; each 8-bit value v scaled to
    257 v (the same shade) gives the same map, and values between them shade by value / maxval."""
    eight = write_map(tmp_path, kind=kind)
    pixels = np.array(PIXELS, dtype=np.int64) * 257
    write_pgm(tmp_path / "wide.pgm", pixels.tolist(), kind=kind, maxval=65535)
    (tmp_path / "wide.yaml").write_text(eight.read_text().replace("floor.pgm", "wide.pgm"))
    got, maxval = parse_pgm((tmp_path / "wide.pgm").read_bytes())
    assert maxval == 65535 and got.dtype == np.uint16 and np.array_equal(got, pixels)
    np.testing.assert_array_equal(load_occupancy_map(tmp_path / "wide.yaml").occupied, EXPECTED)
    # 0.5 of the range: p = 0.5, between the thresholds: unknown (occupied); just below free_thresh: free
    write_pgm(tmp_path / "wide.pgm", [[32767, 65535 - int(0.19 * 65535)]], kind=kind, maxval=65535)
    (tmp_path / "wide.yaml").write_text("image: wide.pgm\nresolution: 1\norigin: [0, 0, 0]\n")
    assert load_occupancy_map(tmp_path / "wide.yaml").occupied.tolist() == [[True, False]]


def test_a_rotated_origin_is_read_as_nav2_reads_it(tmp_path, caplog):
    """Nav2's costmap and AMCL place the image unrotated at the origin's x and y: the same map as with
    yaw 0, and a warning naming the file and the yaw."""
    flat = load_occupancy_map(write_map(tmp_path, origin=[1.0, 2.0, 0.0]))
    with caplog.at_level("WARNING"):
        turned = load_occupancy_map(write_map(tmp_path, origin=[1.0, 2.0, 0.3]))
    np.testing.assert_array_equal(turned.occupied, flat.occupied)
    assert turned.origin == flat.origin == (1.0, 2.0, 0.0)
    assert "origin yaw 0.3 rad ignored, as Nav2's costmap and AMCL ignore it" in caplog.text
    assert "floor.yaml" in caplog.text


@pytest.mark.parametrize(
    "data, message",
    [
        (b"P5\n4 3\n255\n" + bytes(11), "raster truncated: 11 bytes for 4 x 3 = 12 pixels"),
        (b"P5\n4 3\n255\n" + bytes(12) + b"junk", "4 bytes of trailing data"),
        (b"P5\n4 3\n", "header ends early"),
        (b"P5\n4 x3\n255\n" + bytes(12), "header field b'x3' is not a positive integer"),
        (b"P5\n0 3\n255\n", "size 0 x 3"),
        (b"P5\n2 1\n65535\n" + bytes(3), "raster truncated: 3 bytes for 2 x 1 = 2 pixels of 2 bytes"),
        (b"P5\n2 1\n65536\n" + bytes(4), "maxval 65536 (1 .. 65535)"),
        (b"P2\n2 1\n1000\n1 10000\n", "more than 4 digits exceeds maxval 1000"),
        (b"P6\n1 1\n255\n" + bytes(3), "not a PGM image"),
        (b"\x89PNG\r\n\x1a\n", "a PNG image, not a PGM"),
        (b"P2\n2 2\n255\n1 2 3\n", "3 values for 2 x 2 = 4 pixels"),
        (b"P2\n2 1\n100\n1 200\n", "pixel value 200 exceeds maxval 100"),
        (b"P2\n2 1\n255\n1 -2\n", "not a non-negative integer"),
    ],
)
def test_malformed_pgm(data, message):
    with pytest.raises(OccupancyMapError) as err:
        parse_pgm(data, "floor.pgm")
    assert message in str(err.value)
    assert str(err.value).startswith("floor.pgm: ")


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"image": "missing.pgm"}, "image 'missing.pgm' not found"),
        ({"image": None}, "missing key 'image'"),
        ({"resolution": 0}, "'resolution' must be > 0"),
        ({"origin": [1.0, 2.0]}, "'origin' must be [x, y, yaw]"),
        ({"negate": 2}, "'negate' must be 0 or 1"),
        ({"mode": "raw"}, "mode 'raw' is not supported; supported: trinary, scale"),
        ({"free_thresh": 0.8}, "0 <= free_thresh <= occupied_thresh <= 1"),
    ],
)
def test_invalid_occupancy_map(overrides, message, tmp_path):
    with pytest.raises(OccupancyMapError) as err:
        load_occupancy_map(write_map(tmp_path, **overrides))
    assert message in str(err.value)
    assert isinstance(err.value, PlacementError)


def test_occupancy_map_not_found(tmp_path):
    with pytest.raises(OccupancyMapError, match="occupancy map not found"):
        load_occupancy_map(tmp_path / "floor.yaml")


def test_rasterize_occupancy_nearest_cell():
    occ = OccupancyMap(EXPECTED, 0.5, (1.0, 2.0, 0.0))
    # target centres x: 0.85 (outside), 1.35, 1.85, 2.35, 2.85, 3.35 (outside)
    #                y: 1.65 (outside), 2.15, 2.65, 3.15, 3.65 (outside)
    out = rasterize_occupancy(occ, (0.6, 1.4), 0.5, (5, 6))
    np.testing.assert_array_equal(
        out,
        np.array(
            [
                [False, False, False, False, False, False],
                [False, False, False, True, True, False],
                [False, False, True, False, False, False],
                [False, True, False, False, True, False],
                [False, False, False, False, False, False],
            ]
        ),
    )


def test_rasterize_occupancy_coarser_grid():
    occ = OccupancyMap(EXPECTED, 0.5, (1.0, 2.0, 0.0))
    # 1 m cells: x [0, 1] (left of the map, only touching it), [1, 2], [2, 3]; y [2, 3], [3, 4]
    centre = rasterize_occupancy(occ, (0.0, 2.0), 1.0, (2, 3))
    np.testing.assert_array_equal(centre, np.array([[False, True, False], [False, False, False]]))
    any_cell = rasterize_occupancy(occ, (0.0, 2.0), 1.0, (2, 3), conservative=True)
    np.testing.assert_array_equal(any_cell, np.array([[False, True, True], [False, True, True]]))
    # same grid: both modes agree with the map itself
    for conservative in (False, True):
        np.testing.assert_array_equal(rasterize_occupancy(occ, (1.0, 2.0), 0.5, (3, 4), conservative), EXPECTED)


def test_rasterize_occupancy_outside_is_occupied_when_asked():
    occ = OccupancyMap(np.zeros((3, 4), bool), 0.5, (1.0, 2.0, 0.0))  # free map: x 1 .. 3, y 2 .. 3.5
    # 0.5 m cells from (0.5, 1.5): the first row and column and the last row and column lie outside
    # (or, conservatively, only partly inside) the map: unknown space, occupied for the planner
    for conservative in (False, True):
        out = rasterize_occupancy(occ, (0.5, 1.5), 0.5, (5, 6), conservative, outside_occupied=True)
        np.testing.assert_array_equal(
            out,
            np.array(
                [[1, 1, 1, 1, 1, 1], [1, 0, 0, 0, 0, 1], [1, 0, 0, 0, 0, 1], [1, 0, 0, 0, 0, 1], [1, 1, 1, 1, 1, 1]],
                bool,
            ),
        )


@settings(max_examples=80, deadline=None)
@given(
    data=st.data(),
    maxval=st.sampled_from([1, 15, 255, 256, 1000, 65535]),
    kind=st.sampled_from(["P5", "P2"]),
    shape=st.tuples(st.integers(1, 6), st.integers(1, 6)),
)
def test_any_pgm_parses_to_its_pixels(data, maxval, kind, shape):
    """Random rasters of any maxval (one byte per pixel up to 255, two above) come back as written."""
    pixels = data.draw(arrays(np.int64, shape, elements=st.integers(0, maxval)))
    with tempfile.TemporaryDirectory() as tmp:
        got, top = parse_pgm(write_pgm(Path(tmp) / "m.pgm", pixels.tolist(), kind=kind, maxval=maxval).read_bytes())
    assert top == maxval and got.dtype == (np.uint16 if maxval > 255 else np.uint8)
    np.testing.assert_array_equal(got, pixels)


def test_a_16_bit_pgm_pillow_writes_parses_to_its_pixels(tmp_path):
    """An independent writer: Pillow's 16-bit PGM of random grey values."""
    Image = pytest.importorskip("PIL.Image")
    values = np.random.default_rng(5).integers(0, 65536, (7, 9)).astype(np.uint16)
    Image.fromarray(values).save(tmp_path / "m.pgm")  # mode I;16: P5 with maxval 65535
    got, top = parse_pgm((tmp_path / "m.pgm").read_bytes())
    assert top == 65535
    np.testing.assert_array_equal(got, values)
