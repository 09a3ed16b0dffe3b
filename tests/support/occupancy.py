"""ROS map_server occupancy maps written by the tests: a 4 x 3 PGM image and its YAML."""

from __future__ import annotations

import numpy as np
import yaml

# A 4 x 3 image, file order (top row = largest y). With p = (255 - v) / 255 and the default
# thresholds (0.65 / 0.196): 0 -> occupied, 254 -> free, 205 (p 0.196) and 100 (p 0.61) -> unknown.
PIXELS = [[0, 254, 254, 205], [254, 0, 254, 254], [254, 254, 100, 0]]
# row 0 = lowest y = the image's bottom row; unknown counts as occupied
EXPECTED = np.array([[False, False, True, True], [False, True, False, False], [True, False, False, True]])
# negate: p = v / 255: 0 -> free, 254 and 205 -> occupied, 100 (p 0.39) -> unknown
EXPECTED_NEGATE = np.array([[True, True, True, False], [True, False, True, True], [False, True, True, True]])


def write_pgm(path, pixels=PIXELS, kind="P5", maxval=255):
    h, w = len(pixels), len(pixels[0])
    if kind == "P5":  # above maxval 255: two bytes per pixel, most significant first
        width = 2 if maxval > 255 else 1
        raster = b"".join(int(v).to_bytes(width, "big") for row in pixels for v in row)
        path.write_bytes(f"P5\n# written by the test\n{w} {h}\n{maxval}\n".encode() + raster)
    else:
        body = "\n".join(" ".join(str(v) for v in row) for row in pixels)
        path.write_text(f"P2\n# plain PGM\n{w} {h}\n# maxval next\n{maxval}\n{body}\n")
    return path


def write_map(tmp_path, name="floor", kind="P5", **overrides):
    """Write NAME.pgm and NAME.yaml; an override None drops the key."""
    write_pgm(tmp_path / f"{name}.pgm", kind=kind)
    doc = {
        "image": f"{name}.pgm",
        "resolution": 0.5,
        "origin": [1.0, 2.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    doc.update(overrides)
    doc = {k: v for k, v in doc.items() if v is not None}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path
