"""Fill and value statistics of a stored array, computed from the values when a map is saved.

``placement maps info`` prints, per array, how many cells are reached (value > 0), the largest and
the mean reached value, and a histogram of the reached values over :data:`HISTOGRAM_EDGES`. Saving
a map stores exactly that record in every array's metadata under :data:`STATS_KEY` (sealed by the
metadata digests like the rest), so info answers from the metadata without reading a chunk; a map
saved before the record existed has none, and its statistics are computed by reading it
(:func:`read_stats`: :class:`Tally` over its z layers, the same arithmetic as at save time, so the
two agree bit for bit).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from placement.storage.format import STATS_KEY

if TYPE_CHECKING:
    from placement.storage.base import StoredMap

#: bin edges of the value histogram (dimensionless map values; the last bin includes 1.0)
HISTOGRAM_EDGES = (0.0, 0.01, 0.0235, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0)


class Tally:
    """The statistics of a 6D values array (nx, ny, nz, n_yaw, n_pitch, n_roll), one z layer at a time."""

    def __init__(self, cells: int) -> None:
        """``cells``: the number of cells of the whole array."""
        self.cells = int(cells)
        self.counts = np.zeros(len(HISTOGRAM_EDGES) - 1, dtype=np.int64)
        self.filled = 0
        self.total = 0.0  # float64 sum of the reached values, layer by layer in z order
        self.high = 0.0

    def add(self, layer: np.ndarray) -> None:
        """Count z layer ``layer`` (nx, ny, n_yaw, n_pitch, n_roll) float32, the layers in z order."""
        reached = layer[layer > 0]  # C order of the layer: the same sum whether it was read or built
        self.counts += np.histogram(reached, bins=HISTOGRAM_EDGES)[0]
        self.filled += reached.size
        self.total += float(reached.sum(dtype=np.float64))
        self.high = max(self.high, float(reached.max(initial=0.0)))

    def record(self) -> dict[str, Any]:
        """The statistics as stored and printed: ``cells``, ``filled_cells``, ``fill_ratio`` (filled / cells),
        ``value`` {``max``, ``mean`` (of the reached values; 0 if none), ``histogram`` {``edges``, ``counts``}}."""
        return {
            "cells": self.cells,
            "filled_cells": self.filled,
            "fill_ratio": self.filled / self.cells,
            "value": {
                "max": self.high,
                "mean": self.total / self.filled if self.filled else 0.0,
                "histogram": {"edges": list(HISTOGRAM_EDGES), "counts": self.counts.tolist()},
            },
        }


def array_stats(values: np.ndarray) -> dict[str, Any]:
    """The statistics record (:meth:`Tally.record`) of a whole 6D values array (memory: one z layer)."""
    tally = Tally(values.size)
    for iz in range(values.shape[2]):
        tally.add(values[:, :, iz])
    return tally.record()


def read_stats(store: StoredMap, array: str, progress: Callable[[int], object] | None = None) -> dict[str, Any]:
    """The statistics record of stored array ``array`` with ``chunks_checked``, reading every chunk of its
    values and witnesses (each checked against its CRC32, MapError if one differs) one z layer at a time
    (memory: two layers, not the whole map); ``progress(1)`` after each layer."""
    shape = [int(n) for n in store.arm_meta(array)["grid"]["shape"]]
    tally = Tally(math.prod(shape))
    for iz in range(shape[2]):
        tally.add(store.read_slab(array, iz))
        store.read_slab(array, iz, witness=True)
        if progress is not None:
            progress(1)
    return {"chunks_checked": 2 * shape[2] * shape[4] * shape[5], **tally.record()}  # one per (z, pitch, roll)


def stored_stats(meta: dict[str, Any]) -> dict[str, Any] | None:
    """An array's stored statistics record, or None if it has none over :data:`HISTOGRAM_EDGES` (a map saved
    before the record existed, or with other bins): then they are computed by reading the array."""
    stats = meta.get(STATS_KEY)
    if not isinstance(stats, dict) or stats["value"]["histogram"]["edges"] != list(HISTOGRAM_EDGES):
        return None
    return stats


def stats_difference(stored: dict[str, Any], read: dict[str, Any]) -> str | None:
    """The first field where two statistics records differ, as ``field: stored X, read Y``; None if they
    agree (counts and the maximum exactly; the mean to a relative 1e-9: its float64 sum may be taken in
    another order)."""
    fields = [
        ("cells", stored["cells"], read["cells"]),
        ("filled_cells", stored["filled_cells"], read["filled_cells"]),
        ("fill_ratio", stored["fill_ratio"], read["fill_ratio"]),
        ("value.histogram.counts", stored["value"]["histogram"]["counts"], read["value"]["histogram"]["counts"]),
        ("value.max", stored["value"]["max"], read["value"]["max"]),
    ]
    for name, have, want in fields:
        if have != want:
            return f"{name}: stored {have}, read {want}"
    mean, want_mean = stored["value"]["mean"], read["value"]["mean"]
    if not abs(mean - want_mean) <= 1e-9 * max(abs(want_mean), 1e-300):
        return f"value.mean: stored {mean!r}, read {want_mean!r}"
    return None


__all__ = ["HISTOGRAM_EDGES", "STATS_KEY", "Tally", "array_stats", "read_stats", "stats_difference", "stored_stats"]
