"""PCD point cloud files written as PCL writes them, for the cloud tests."""

from __future__ import annotations

import numpy as np


def pcd(points: np.ndarray, kind: str = "ascii", extra: bool = True, size: int = 4) -> bytes:
    """A PCD 0.7 file of ``points`` (n, 3): fields x y z (floats of ``size`` bytes) and, with
    ``extra``, an rgb float and a 3-count intensity field before and after them, as PCL writes."""
    n = len(points)
    if extra:
        fields, sizes, types, counts = "rgb x y z intensity", f"4 {size} {size} {size} 2", "F F F F U", "1 1 1 1 3"
    else:
        fields, sizes, types, counts = "x y z", f"{size} {size} {size}", "F F F", "1 1 1"
    head = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        f"FIELDS {fields}\nSIZE {sizes}\nTYPE {types}\nCOUNT {counts}\n"
        f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {kind}\n"
    ).encode()
    f = np.float32 if size == 4 else np.float64
    if kind == "ascii":
        rows = []
        for p in points:
            xyz = " ".join(repr(float(f(v))) for v in p)
            rows.append(f"0.5 {xyz} 1 2 3" if extra else xyz)
        return head + ("\n".join(rows) + "\n").encode()
    if extra:
        dt = np.dtype([("rgb", "<f4"), ("x", f), ("y", f), ("z", f), ("i", "<u2", (3,))])
    else:
        dt = np.dtype([("x", f), ("y", f), ("z", f)])
    rec = np.zeros(n, dtype=dt)
    rec["x"], rec["y"], rec["z"] = points[:, 0], points[:, 1], points[:, 2]
    return head + rec.tobytes()
