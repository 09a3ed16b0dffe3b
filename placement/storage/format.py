"""The stored map format, shared by the builder and the reader without either importing the other.

Layout (both backends): one group per robot; root attribute :data:`ROOT_KEY`
holds the robot-level metadata and ``complete: true``, written last; one
float32 array per arm, shape (nx, ny, nz, n_yaw, n_pitch, n_roll), chunked
(nx, ny, 1, n_yaw, 1, 1) so one inverse-reachability query (fixed z, pitch,
roll) reads exactly one chunk; the arm's metadata in the array's attributes,
including ``chunk_crc32``: the CRC32 of every decoded chunk (see :func:`chunk_crcs`).
Beside it, the array ``<arm>.witness`` of the same shape and chunking holds the
cells' witnesses (uint32 or int64, see placement/maps/witness.py), with its own
per-chunk CRC32 table ``witness_crc32`` in the arm's metadata, and ``value_stats``: the fill and
value statistics of the values (placement/storage/stats.py; optional, a map saved before them has
none, so no new version). The root's ``digests``
entry seals the root and every arm's metadata (placement/storage/digest.py).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from placement.storage.grid import Grid

# 2: per-chunk CRC32 of the decoded data, crc32c (zarr) / fletcher32 (HDF5) on the stored bytes
# 3: a witness array per arm (the sample behind every cell's value), chunked and CRC-checked alike
# 4: SHA-256 digests of the root and every arm's metadata in the root (see digest.py)
FORMAT_VERSION = 4
#: read with a warning: the last version without metadata digests
UNSEALED_VERSION = 3
READABLE_VERSIONS = (UNSEALED_VERSION, FORMAT_VERSION)
ROOT_KEY = "placement_map"
CRC_KEY = "chunk_crc32"
WITNESS_CRC_KEY = "witness_crc32"
#: the arm metadata key of the fill and value statistics (placement/storage/stats.py)
STATS_KEY = "value_stats"
WITNESS_SUFFIX = ".witness"


def witness_name(arm: str) -> str:
    """The name of the witness array of ``arm`` in a stored map."""
    return arm + WITNESS_SUFFIX


@dataclass
class BuiltMap:
    """An arm's map in memory: values (6D float32, 0 = unreachable), metadata and witnesses
    (same shape, uint32 or int64, see placement/maps/witness.py; None for a map that has none, e.g. a
    convergence snapshot: such a map cannot be saved)."""

    values: np.ndarray
    meta: dict[str, Any]
    witness: np.ndarray | None = None

    @property
    def grid(self) -> Grid:
        return Grid.from_dict(self.meta["grid"])


def chunk_shape(shape: tuple[int, ...]) -> tuple[int, ...]:
    """Chunk of a (nx, ny, nz, n_yaw, n_pitch, n_roll) array: one (z, pitch, roll) slice."""
    nx, ny, _, n_yaw, _, _ = shape
    return (nx, ny, 1, n_yaw, 1, 1)


def chunk_crc(chunk: np.ndarray) -> int:
    """CRC32 of one decoded chunk (nx, ny, n_yaw) in C order, in its own dtype (float32 values or witnesses)."""
    return zlib.crc32(np.ascontiguousarray(chunk).data) & 0xFFFFFFFF


def chunk_crcs(values: np.ndarray) -> np.ndarray:
    """CRC32 of every chunk of a 6D map (values or witnesses) -> (nz, n_pitch, n_roll) uint32."""
    nx, ny, nz, n_yaw, n_pitch, n_roll = values.shape
    out = np.empty((nz, n_pitch * n_roll), dtype=np.uint32)
    # one z slab at a time in chunk order makes every chunk a contiguous run of bytes without a
    # second copy of the whole map (and the slab stays in cache)
    slab = np.empty((n_pitch, n_roll, nx, ny, n_yaw), dtype=values.dtype)
    for iz in range(nz):
        np.copyto(slab, values[:, :, iz].transpose(3, 4, 0, 1, 2))
        out[iz] = [zlib.crc32(run.data) for run in slab.reshape(n_pitch * n_roll, -1)]
    return out.reshape(nz, n_pitch, n_roll)
