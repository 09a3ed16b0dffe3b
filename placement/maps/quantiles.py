"""The distribution of a map's reached values: quantiles recorded at build, read (or estimated) when used.

A map value means different things on different arms (a wheeled humanoid's isotropy peaks near 0.08,
the PR2's near 0.28, a rank-5 arm's ``sigma_5/sigma_1`` has its own scale), so the planner's threshold
is by default a *quantile* of the arm's own non-zero values (``planner.threshold_quantile``): the same
fraction of every arm's reached cells is infeasible. A build records the quantiles of the non-zero
values at every 0.1 % (:func:`value_quantiles`, metadata key ``value_quantiles``); a map built before
that has them estimated at open from every 8th stored chunk (:func:`estimate_quantiles`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from placement.errors import MapError

if TYPE_CHECKING:
    from placement.storage.base import StoredMap

#: Quantiles are recorded at levels k / LEVELS, k = 0 .. LEVELS (every 0.1 %).
LEVELS = 1000
#: An old map's quantiles are estimated from every ESTIMATE_STRIDE-th chunk in storage order
#: (on the 5 cm PR2 maps: 1.0 s per arm instead of 14 s for all; within 0.3 % of the exact
#: quantiles at levels 0.05 .. 0.99, 0.03 % at the default threshold_quantile).
ESTIMATE_STRIDE = 8


def levels() -> npt.NDArray[np.float64]:
    """(LEVELS + 1,) the recorded levels k / LEVELS (dimensionless, 0 .. 1)."""
    return np.arange(LEVELS + 1, dtype=np.float64) / LEVELS


def value_quantiles(values: npt.NDArray[np.floating[Any]], source: str = "all cells") -> dict[str, Any]:
    """The metadata record of the distribution of ``values``' non-zero entries (any shape).

    Returns ``{"of": "non-zero cell values", "source": source, "count": n, "levels": LEVELS,
    "values": [...]}``: ``values[k]`` is ``numpy.quantile(nonzero, levels())[k]`` (linear
    interpolation in float64, the levels being float64), an empty list when no cell is reached.
    """
    flat = np.asarray(values).ravel()
    nz = flat[flat > 0]
    q = np.quantile(nz, levels()).tolist() if nz.size else []
    return {"of": "non-zero cell values", "source": source, "count": int(nz.size), "levels": LEVELS, "values": q}


def estimate_quantiles(store: StoredMap, arm: str, shape: tuple[int, ...]) -> dict[str, Any]:
    """:func:`value_quantiles` of every ``ESTIMATE_STRIDE``-th stored chunk of ``arm`` (a map built
    without the record; each chunk read is checked against its CRC32). ``shape``: the grid's 6D shape."""
    _, _, nz, _, n_pitch, n_roll = shape
    parts = []
    for flat in range(0, nz * n_pitch * n_roll, ESTIMATE_STRIDE):
        iz, rest = divmod(flat, n_pitch * n_roll)
        chunk = store.read_chunk(arm, iz, *divmod(rest, n_roll))
        parts.append(chunk[chunk > 0])
    source = f"every {ESTIMATE_STRIDE}th chunk (estimated at open: the map has no recorded quantiles)"
    return value_quantiles(np.concatenate(parts) if parts else np.zeros(0, np.float32), source)


def quantile_value(record: dict[str, Any], q: float, where: str) -> float:
    """The map value at quantile ``q`` (0 .. 1) of a :func:`value_quantiles` record: linear
    interpolation between the recorded levels (exact at k / LEVELS). MapError naming ``where``
    when the map has no reached cell."""
    vals = record["values"]
    if not vals:
        raise MapError(f"{where}: the map has no reached cell, so threshold_quantile has no value; rebuild the map")
    k = min(max(float(q), 0.0), 1.0) * (len(vals) - 1)
    lo = min(int(np.floor(k + 1e-9)), len(vals) - 1)
    frac = k - lo
    if frac <= 1e-9:  # a recorded level: its value exactly
        return float(vals[lo])
    return float(vals[lo] + frac * (vals[lo + 1] - vals[lo]))


__all__ = ["ESTIMATE_STRIDE", "LEVELS", "estimate_quantiles", "levels", "quantile_value", "value_quantiles"]
