"""The storage interface shared by the Zarr and HDF5 backends.

Layout (both backends): one group per robot; root attribute ``placement_map``
holds the robot-level metadata and ``complete: true``, written last; one
float32 array per arm, shape (nx, ny, nz, n_yaw, n_pitch, n_roll), chunked
(nx, ny, 1, n_yaw, 1, 1) so one inverse-reachability query (fixed z, pitch,
roll) reads exactly one chunk; the arm's metadata in the array's attributes.

Writes are atomic: everything goes to a sibling ``.partial`` path that is
renamed over the target only when complete, so an interrupted build leaves
either the old map or no map, never one that opens as complete.
"""

from __future__ import annotations

import os
import shutil
import zlib
from abc import ABC, abstractmethod
from pathlib import Path

import numpy as np

from ..errors import MapError

ROOT_KEY = "placement_map"


def chunk_shape(shape) -> tuple[int, ...]:
    nx, ny, _, n_yaw, _, _ = shape
    return (nx, ny, 1, n_yaw, 1, 1)


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (for one-line errors)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def checksum(values: np.ndarray) -> str:
    """CRC32 of the array bytes (C order, float32), as hex."""
    return f"{zlib.crc32(np.ascontiguousarray(values, dtype=np.float32).data) & 0xFFFFFFFF:08x}"


class StoredMap(ABC):
    """An opened map file or directory: metadata now, data on demand."""

    path: Path
    root: dict

    @abstractmethod
    def arm_meta(self, arm: str) -> dict:
        """The metadata of ``arm`` (as written by :func:`placement.build_map`)."""

    @abstractmethod
    def _array(self, arm: str):
        """The backend's array object of ``arm`` (sliceable); MapError if missing."""

    def read_chunk(self, arm: str, iz: int, ip: int, ir: int) -> np.ndarray:
        """Values (nx, ny, n_yaw) float32 of the slice z = iz, pitch = ip, roll = ir."""
        return self._read(arm, f"chunk ({iz}, {ip}, {ir})", lambda a: a[:, :, iz, :, ip, ir])

    def read_all(self, arm: str) -> np.ndarray:
        """The whole 6D float32 array of ``arm``."""
        return self._read(arm, "data", lambda a: a[...])

    def _read(self, arm: str, what: str, take) -> np.ndarray:
        array = self._array(arm)
        try:
            return np.asarray(take(array))
        except Exception as exc:  # codec and I/O errors of either library
            raise MapError(f"{self.path}: {what} of arm '{arm}' is corrupt ({first_line(exc)})") from None

    @abstractmethod
    def chunks_present(self, arm: str) -> int | None:
        """How many chunks are stored (None if the backend cannot tell cheaply)."""

    def close(self) -> None:  # noqa: B027 - optional
        pass


class Backend(ABC):
    name: str
    suffix: str

    @abstractmethod
    def is_map(self, path: Path) -> bool:
        """Whether ``path`` looks like a map of this backend (complete or not)."""

    @abstractmethod
    def write(self, path: Path, root: dict, arms: dict[str, tuple[np.ndarray, dict]]) -> None:
        """Write a complete map to ``path`` (a fresh path; not atomic by itself)."""

    @abstractmethod
    def open(self, path: Path) -> StoredMap:
        """Open ``path`` for reading (raises MapError if it is not a readable map)."""


def atomic_replace(backend: Backend, target: Path, root: dict, arms: dict) -> None:
    """Write via a sibling partial path, then swap it in; the old map survives a failure."""
    target = Path(target)
    partial = target.with_name(f".{target.name}.partial-{os.getpid()}")
    old = target.with_name(f".{target.name}.old-{os.getpid()}")
    _remove(partial)
    try:
        backend.write(partial, root, arms)
        if target.exists():
            os.replace(target, old)
        os.replace(partial, target)
    except BaseException:
        _remove(partial)
        if old.exists() and not target.exists():
            os.replace(old, target)
        raise
    _remove(old)


def _remove(path: Path) -> None:
    if path.is_dir():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists():
        path.unlink()
