"""Reading a map's chunks directly, in parallel, each into a buffer of its exact size.

Every chunk of a map is one (z, pitch, roll) slice (nx, ny, n_yaw), stored compressed with a
byte checksum by the backend (zarr: blosc + crc32c; HDF5: shuffle + deflate (zlib's Adler-32) +
fletcher32). A backend's :class:`ChunkReader` returns a chunk's decoded bytes after checking its
stored size against the bound of its shape and its byte checksum; this module assembles chunks
into z layers and whole arrays on a small thread pool (the decompressors release the GIL) and
computes every chunk's CRC32 from the contiguous decoded bytes, for the caller to compare with
the table in the arm's metadata.
"""

from __future__ import annotations

import os
import zlib
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor, wait
from typing import TypeVar

import numpy as np
import numpy.typing as npt

_POOLS: list[ThreadPoolExecutor] = []
T = TypeVar("T")


def _pool() -> ThreadPoolExecutor:
    """The threads that decode a layer's chunks (made on first use, and again in a forked child: the
    parent's threads do not exist there, and its pool would wait for them forever)."""
    if not _POOLS:
        _POOLS.append(
            ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 1), thread_name_prefix="placement-chunks")
        )
    return _POOLS[0]


if hasattr(os, "register_at_fork"):  # POSIX only; elsewhere nothing forks
    os.register_at_fork(after_in_child=_POOLS.clear)


def each_of(task: Callable[[T], None], items: Iterable[T]) -> None:
    """``task(item)`` for every item (a save's z layers, a planner's slices) on the chunk threads (the
    codecs release the GIL). The first exception is raised here once no task runs any more: after a
    failed item none has started, the others have ended (a failed save's caller removes what they
    wrote, and nothing writes there after it)."""
    futures = [_pool().submit(task, item) for item in items]
    try:
        for done in futures:
            done.result()
    except BaseException:
        for f in futures:
            f.cancel()
        wait(futures)
        raise


class ChunkReader(ABC):
    """The chunks of one array of ``shape`` (nx, ny, nz, n_yaw, n_pitch, n_roll) and ``dtype``; ``fill`` is
    the value of a chunk that is not stored."""

    def __init__(self, shape: tuple[int, ...], dtype: npt.DTypeLike, fill: float | np.generic) -> None:
        self.shape = tuple(int(s) for s in shape)
        self.dtype = np.dtype(dtype).newbyteorder("<")
        nx, ny, _, n_yaw, _, _ = self.shape
        self.chunk = (nx, ny, n_yaw)
        self.raw = nx * ny * n_yaw * self.dtype.itemsize
        # no codec here stores a chunk in more than this (blosc: raw + 16 bytes; deflate: ~raw * 1.001 + 12)
        self.limit = self.raw + self.raw // 16 + 4096
        self.fill = np.full(self.chunk, fill, dtype=self.dtype)

    @abstractmethod
    def decoded(self, iz: int, ip: int, ir: int) -> bytes | npt.NDArray[np.uint8] | None:
        """The decoded bytes (``raw`` of them, C order) of chunk (iz, ip, ir), None if it is not stored;
        any exception if its stored bytes are damaged, too large or unreadable."""

    def read(self, iz: int, ip: int, ir: int, out: np.ndarray | None = None) -> tuple[np.ndarray, int]:
        """Chunk (iz, ip, ir) (nx, ny, n_yaw) (also written into ``out`` if given) and the CRC32 of its bytes."""
        data = self.decoded(iz, ip, ir)
        chunk: np.ndarray
        if data is None:
            chunk = self.fill
        else:
            chunk = np.frombuffer(data, dtype=np.uint8) if isinstance(data, bytes) else data
            if chunk.nbytes != self.raw:
                raise ValueError(f"decoded to {chunk.nbytes} bytes, not {self.raw}")
            chunk = chunk.view(self.dtype).reshape(self.chunk)
        if out is not None:
            out[...] = chunk
        return chunk, zlib.crc32(chunk.data) & 0xFFFFFFFF

    def layer(self, iz: int, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """z layer ``iz`` (nx, ny, n_yaw, n_pitch, n_roll) (into ``out`` if given) and its chunks' CRC32s."""
        n_pitch, n_roll = self.shape[4:]
        if out is None:
            out = np.empty((*self.chunk, n_pitch, n_roll), dtype=self.dtype)
        crcs = np.empty((n_pitch, n_roll), dtype=np.uint32)

        def row(ip: int) -> None:  # one task per pitch row: few enough tasks for the pool's overhead not to count
            for ir in range(n_roll):
                crcs[ip, ir] = self.read(iz, ip, ir, out=out[:, :, :, ip, ir])[1]

        each_of(row, range(n_pitch))
        return out, crcs

    def whole(self) -> tuple[np.ndarray, np.ndarray]:
        """The whole array and its chunks' CRC32s (nz, n_pitch, n_roll)."""
        out = np.empty(self.shape, dtype=self.dtype)
        return out, np.stack([self.layer(iz, out[:, :, iz])[1] for iz in range(self.shape[2])])
