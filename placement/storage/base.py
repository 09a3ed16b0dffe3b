"""The storage interface shared by the Zarr and HDF5 backends (layout: see format.py).

Integrity: every chunk's decoded data has a CRC32 in the arm's metadata; every
read (:meth:`StoredMap.read_chunk`, :meth:`StoredMap.read_all`) compares it, so
a chunk whose bytes changed, one swapped with another chunk or one deleted
(which the libraries read back as the fill value) fails with a MapError instead
of giving an answer. The backends' own byte checks (zarr crc32c, HDF5
fletcher32) catch damage before decompression.

Writes are atomic: everything goes to a sibling ``.partial`` path that is
renamed over the target only when complete, so an interrupted build leaves
either the old map or no map, never one that opens as complete.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from abc import ABC, abstractmethod
from pathlib import Path

import numpy as np

from ..errors import MapError
from .format import CRC_KEY, ROOT_KEY, WITNESS_CRC_KEY, chunk_crc, chunk_crcs, chunk_shape, witness_name

__all__ = ["ROOT_KEY", "Backend", "StoredMap", "atomic_replace", "chunk_shape", "first_line"]


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (for one-line errors)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def opened(path: Path, kind: str, open_fn):
    """``open_fn()``, with any failure turned into one MapError line naming ``path`` and ``kind``."""
    try:
        return open_fn()
    except Exception as exc:  # codec and I/O errors of either library
        raise MapError(f"{path}: not a readable {kind} map ({first_line(exc)})") from None


class StoredMap(ABC):
    """An opened map file or directory: metadata now, data on demand, every read checked."""

    path: Path
    root: dict

    @abstractmethod
    def arm_meta(self, arm: str) -> dict:
        """The metadata of ``arm`` (as written by :func:`placement.build_map` and :func:`placement.save_maps`)."""

    @abstractmethod
    def _get(self, name: str):
        """The backend's array object called ``name`` (sliceable); any exception if it is missing."""

    def _array(self, arm: str, witness: bool = False):
        """The backend's array object of ``arm`` (its values, or its witnesses); MapError if missing or unreadable."""
        what = "witness array" if witness else "array"
        try:
            return self._get(witness_name(arm) if witness else arm)
        except Exception as exc:
            raise MapError(f"{self.path}: {what} for arm '{arm}' is missing or corrupt ({first_line(exc)}); "
                           f"rebuild the map") from None

    def expected_crcs(self, arm: str, witness: bool = False) -> np.ndarray:
        """The stored CRC32 of every chunk of ``arm``'s values (or witnesses), (nz, n_pitch, n_roll) uint32;
        MapError if malformed."""
        cache = self.__dict__.setdefault("_crcs", {})
        key = WITNESS_CRC_KEY if witness else CRC_KEY
        if (arm, key) not in cache:
            meta = self.arm_meta(arm)
            try:
                shape = tuple(int(s) for s in meta["grid"]["shape"])
                crcs = np.asarray(meta[key], dtype=np.int64)
                ok = crcs.shape == (shape[2], shape[4], shape[5]) and bool(np.all((crcs >= 0) & (crcs < 2 ** 32)))
            except (KeyError, TypeError, ValueError, IndexError, OverflowError):
                ok = False
            if not ok:
                what = "witness" if witness else "chunk"
                raise MapError(f"{self.path}: the {what} checksums of arm '{arm}' are missing or malformed "
                               f"(corrupt); rebuild the map")
            cache[(arm, key)] = crcs.astype(np.uint32)
        return cache[(arm, key)]

    def read_chunk(self, arm: str, iz: int, ip: int, ir: int, witness: bool = False) -> np.ndarray:
        """Values (nx, ny, n_yaw) float32 (or witnesses) of the slice z = iz, pitch = ip, roll = ir,
        checked against its CRC32."""
        want = self.expected_crcs(arm, witness)[iz, ip, ir]
        chunk = self._read(arm, f"chunk ({iz}, {ip}, {ir})", lambda a: a[:, :, iz, :, ip, ir], witness)
        if chunk_crc(chunk) != want:
            raise self._damaged(arm, (iz, ip, ir), witness=witness)
        return chunk

    def read_slab(self, arm: str, iz: int, witness: bool = False) -> np.ndarray:
        """Values (nx, ny, n_yaw, n_pitch, n_roll) float32 (or witnesses) at z bin ``iz``: the chunks of one
        z layer in one read (far fewer library calls than chunk by chunk), each checked against its CRC32."""
        want = self.expected_crcs(arm, witness)[iz]
        data = self._read(arm, f"z layer {iz}", lambda a: a[:, :, iz], witness)
        bad = np.argwhere(chunk_crcs(data[:, :, None])[0] != want)
        if len(bad):
            raise self._damaged(arm, (int(iz), *(int(i) for i in bad[0])), len(bad), witness)
        return data

    def read_all(self, arm: str, witness: bool = False) -> np.ndarray:
        """The whole 6D float32 array of ``arm`` (or its witnesses), every chunk checked against its CRC32."""
        want = self.expected_crcs(arm, witness)
        data = self._read(arm, "data", lambda a: a[...], witness)
        bad = np.argwhere(chunk_crcs(data) != want)
        if len(bad):
            raise self._damaged(arm, tuple(int(i) for i in bad[0]), len(bad), witness)
        return data

    def _damaged(self, arm: str, chunk: tuple[int, int, int], count: int = 1, witness: bool = False) -> MapError:
        more = f" (and {count - 1} more)" if count > 1 else ""
        what = "witness chunk" if witness else "chunk"
        return MapError(f"{self.path}: {what} (z, pitch, roll) = {chunk} of arm '{arm}'{more} does not match its "
                        f"checksum (changed, swapped or missing chunk data: corrupt); rebuild the map")

    def _read(self, arm: str, what: str, take, witness: bool = False) -> np.ndarray:
        array = self._array(arm, witness)
        try:
            with self._read_settings():
                data = np.asarray(take(array))
            if witness:
                if data.dtype not in (np.uint32, np.int64):
                    raise ValueError(f"witness dtype {data.dtype}")
                return data
            return np.asarray(data, dtype=np.float32)
        except Exception as exc:  # codec and I/O errors of either library
            self._settle()
            raise MapError(f"{self.path}: {what} of arm '{arm}' is corrupt ({first_line(exc)}); "
                           f"rebuild the map") from None

    def _read_settings(self):
        """Context in which the library reads (a backend may tune it)."""
        return contextlib.nullcontext()

    def _settle(self) -> None:  # noqa: B027 - optional
        """Let the library finish work a failed read left running (zarr: sibling chunk reads)."""

    @abstractmethod
    def chunks_present(self, name: str) -> int | None:
        """How many chunks of array ``name`` (an arm, or its witness array) are stored (None if the backend
        cannot tell cheaply)."""

    def close(self) -> None:  # noqa: B027 - optional
        pass


class Backend(ABC):
    name: str
    suffix: str

    @abstractmethod
    def is_map(self, path: Path) -> bool:
        """Whether ``path`` looks like a map of this backend (complete or not)."""

    @abstractmethod
    def write(self, path: Path, root: dict, arms: dict[str, tuple[np.ndarray, dict, np.ndarray]]) -> None:
        """Write a complete map to ``path`` (a fresh path; not atomic by itself); ``arms`` maps each arm
        to (values, metadata, witnesses)."""

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
