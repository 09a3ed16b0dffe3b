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

import os
import shutil
import threading
import warnings
from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from placement.errors import MapError
from placement.storage.chunks import ChunkReader
from placement.storage.digest import check_arm_digest, check_root_digest
from placement.storage.files import FileRefused
from placement.storage.format import (
    CRC_KEY,
    READABLE_VERSIONS,
    ROOT_KEY,
    UNSEALED_VERSION,
    WITNESS_CRC_KEY,
    chunk_shape,
    witness_name,
)
from placement.storage.schema import check_arm_types, check_arms, check_root_types

__all__ = [
    "ROOT_KEY",
    "ArmArrays",
    "Backend",
    "StoredMap",
    "atomic_replace",
    "chunk_shape",
    "first_line",
    "partial_path",
]

T = TypeVar("T")
#: what a backend writes of one arm: (values, metadata, witnesses)
ArmArrays = tuple[np.ndarray, dict[str, Any], np.ndarray]


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (for one-line errors)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def opened(path: Path, kind: str, open_fn: Callable[[], T]) -> T:
    """``open_fn()``, with any failure turned into one MapError line naming ``path`` and ``kind``."""
    try:
        return open_fn()
    except Exception as exc:  # codec and I/O errors of either library
        raise MapError(f"{path}: not a readable {kind} map ({first_line(exc)})") from None


class StoredMap(ABC):
    """An opened map file or directory: metadata now (checked), data on demand, every read checked."""

    path: Path
    root: dict[str, Any]

    def accept_root(self, root: object) -> dict[str, Any]:
        """``root`` as read, checked: a mapping with a list of arm names; for a complete map of a readable
        version also the types of its keys and its digest (a map without digests is accepted with a warning
        if it is of format version 3, the last one without them)."""
        if not isinstance(root, dict):
            raise MapError(f"{self.path}: the root metadata is not a mapping (corrupt); rebuild the map")
        check_arms(self.path, root)
        if root.get("complete") is True and root.get("format_version") in READABLE_VERSIONS:
            check_root_types(self.path, root)
            try:
                sealed = check_root_digest(self.path, root)
            except (TypeError, ValueError, RecursionError) as exc:  # e.g. a string no JSON can hold
                raise MapError(
                    f"{self.path}: the root metadata is corrupt ({first_line(exc)}); rebuild the map"
                ) from None
            if not sealed:
                if root.get("format_version") != UNSEALED_VERSION:
                    raise MapError(f"{self.path}: the map has no metadata digests (corrupt); rebuild the map")
                warnings.warn(
                    f"{self.path}: map of format version {UNSEALED_VERSION} has no metadata digests, so "
                    f"changed metadata goes unnoticed; rebuild it to have it checked",
                    stacklevel=2,
                )
        return root

    def arm_meta(self, arm: str) -> dict[str, Any]:
        """The metadata of ``arm`` (as written by :func:`placement.build_map` and :func:`placement.save_maps`),
        checked against its digest and for the types reading needs (MapError naming the key otherwise)."""
        cache: dict[str, dict[str, Any]] = self.__dict__.setdefault("_metas", {})
        if arm not in cache:
            try:
                meta = self._arm_meta(arm)
            except MapError:
                raise
            except Exception as exc:
                raise MapError(
                    f"{self.path}: metadata of arm '{arm}' is corrupt ({first_line(exc)}); rebuild the map"
                ) from None
            if not isinstance(meta, dict):
                raise MapError(f"{self.path}: metadata of arm '{arm}' is not a mapping (corrupt); rebuild the map")
            try:
                check_arm_digest(self.path, self.root, arm, meta)
                check_arm_types(self.path, arm, meta)
            except (TypeError, ValueError, RecursionError) as exc:  # e.g. a string no JSON can hold
                raise MapError(
                    f"{self.path}: metadata of arm '{arm}' is corrupt ({first_line(exc)}); rebuild the map"
                ) from None
            cache[arm] = meta
        return cache[arm]

    @abstractmethod
    def _arm_meta(self, arm: str) -> object:
        """The stored metadata of ``arm``, unchecked (any exception if unreadable)."""

    @abstractmethod
    def _get(self, name: str) -> Any:  # a zarr.Array or an h5py.Dataset (h5py has no types)
        """The backend's array object called ``name`` (sliceable); any exception if it is missing."""

    def _array(self, arm: str, witness: bool = False) -> Any:
        """The backend's array object of ``arm`` (its values, or its witnesses), its shape, dtype and chunks
        checked against the arm's metadata; MapError if missing, unreadable or not as described."""
        cache: dict[tuple[str, bool], Any] = self.__dict__.setdefault("_arrays", {})
        if (arm, witness) not in cache:
            array = self._raw_array(arm, witness)
            meta = self.arm_meta(arm)
            shape = tuple(meta["grid"]["shape"])
            dtype = np.dtype(meta["witness"]["dtype"] if witness else np.float32)
            what = f"the {'witness ' if witness else ''}array of arm '{arm}'"
            for field, have, want in (
                ("shape", tuple(array.shape), shape),
                ("dtype", np.dtype(array.dtype), dtype),
                ("chunks", tuple(array.chunks or ()), chunk_shape(shape)),
            ):
                if have != want:
                    raise MapError(
                        f"{self.path}: {what} has {field} {have}, its metadata says {want} (corrupt); rebuild the map"
                    )
            cache[(arm, witness)] = array
        return cache[(arm, witness)]

    def check_arrays(self, arm: str) -> None:
        """MapError unless both arrays of ``arm`` are there as its metadata describes them, with their checksum
        tables (cheap: metadata only)."""
        for witness in (False, True):
            self._array(arm, witness)
            self.expected_crcs(arm, witness)

    def _raw_array(self, arm: str, witness: bool = False) -> Any:
        what = "witness array" if witness else "array"
        try:
            return self._get(witness_name(arm) if witness else arm)
        except MapError:
            raise
        except Exception as exc:
            raise MapError(
                f"{self.path}: {what} for arm '{arm}' is missing or corrupt ({first_line(exc)}); rebuild the map"
            ) from None

    def expected_crcs(self, arm: str, witness: bool = False) -> np.ndarray:
        """The stored CRC32 of every chunk of ``arm``'s values (or witnesses), (nz, n_pitch, n_roll) uint32;
        MapError if malformed."""
        cache: dict[tuple[str, str], np.ndarray] = self.__dict__.setdefault("_crcs", {})
        key = WITNESS_CRC_KEY if witness else CRC_KEY
        if (arm, key) not in cache:
            meta = self.arm_meta(arm)
            try:
                shape = tuple(int(s) for s in meta["grid"]["shape"])
                crcs = np.asarray(meta[key], dtype=np.int64)
                ok = crcs.shape == (shape[2], shape[4], shape[5]) and bool(np.all((crcs >= 0) & (crcs < 2**32)))
            except (KeyError, TypeError, ValueError, IndexError, OverflowError):
                ok = False
            if not ok:
                what = "witness" if witness else "chunk"
                raise MapError(
                    f"{self.path}: the {what} checksums of arm '{arm}' are missing or malformed "
                    f"(corrupt); rebuild the map"
                )
            cache[(arm, key)] = crcs.astype(np.uint32)
        return cache[(arm, key)]

    def read_chunk(self, arm: str, iz: int, ip: int, ir: int, witness: bool = False) -> np.ndarray:
        """Values (nx, ny, n_yaw) float32 (or witnesses) of the slice z = iz, pitch = ip, roll = ir,
        checked against its CRC32."""
        want = self.expected_crcs(arm, witness)[iz, ip, ir]
        chunk, crc = self._chunk_data(arm, iz, ip, ir, witness)
        if crc != want:
            raise self._damaged(arm, (iz, ip, ir), witness=witness)
        return chunk

    def read_slab(self, arm: str, iz: int, witness: bool = False) -> np.ndarray:
        """Values (nx, ny, n_yaw, n_pitch, n_roll) float32 (or witnesses) at z bin ``iz``: the chunks of one
        z layer in one read (far fewer library calls than chunk by chunk), each checked against its CRC32."""
        want = self.expected_crcs(arm, witness)[iz]
        data, crcs = self._layer_data(arm, iz, witness)
        bad = np.argwhere(crcs != want)
        if len(bad):
            raise self._damaged(arm, (int(iz), *(int(i) for i in bad[0])), len(bad), witness)
        return data

    def read_all(self, arm: str, witness: bool = False) -> np.ndarray:
        """The whole 6D float32 array of ``arm`` (or its witnesses), every chunk checked against its CRC32."""
        want = self.expected_crcs(arm, witness)
        data, crcs = self._all_data(arm, witness)
        bad = np.argwhere(crcs != want)
        if len(bad):
            raise self._damaged(arm, tuple(int(i) for i in bad[0]), len(bad), witness)
        return data

    def _chunk_data(self, arm: str, iz: int, ip: int, ir: int, witness: bool) -> tuple[np.ndarray, int]:
        """The chunk and the CRC32 of its decoded bytes (computed once, as it is decoded)."""
        what = f"{'witness ' if witness else ''}chunk ({iz}, {ip}, {ir})"
        return self._direct(arm, witness, what, lambda r: r.read(iz, ip, ir))

    def _layer_data(self, arm: str, iz: int, witness: bool) -> tuple[np.ndarray, np.ndarray]:
        return self._direct(arm, witness, f"{'witness ' if witness else ''}z layer {iz}", lambda r: r.layer(iz))

    def _all_data(self, arm: str, witness: bool) -> tuple[np.ndarray, np.ndarray]:
        return self._direct(arm, witness, "witnesses" if witness else "data", lambda r: r.whole())

    def _direct(self, arm: str, witness: bool, what: str, read: Callable[[ChunkReader], T]) -> T:
        """``read(reader)`` with the arm's :class:`ChunkReader`, any failure one MapError naming ``what``."""
        cache: dict[tuple[str, bool], ChunkReader] = self.__dict__.setdefault("_readers", {})
        try:
            if (arm, witness) not in cache:
                cache[(arm, witness)] = self._reader(arm, witness, self._array(arm, witness))
            return read(cache[(arm, witness)])
        except MapError:
            raise
        except FileRefused as exc:
            raise MapError(f"{self.path}: {what} of arm '{arm}': {first_line(exc)}; rebuild the map") from None
        except Exception as exc:  # codec and I/O errors
            raise MapError(
                f"{self.path}: {what} of arm '{arm}' is corrupt ({first_line(exc)}); rebuild the map"
            ) from None

    @abstractmethod
    def _reader(self, arm: str, witness: bool, array: Any) -> ChunkReader:
        """The chunk reader of ``arm``'s values or witnesses (``array``: its checked array object); MapError if
        the array is not stored as this package stores it."""

    def _damaged(self, arm: str, chunk: tuple[int, ...], count: int = 1, witness: bool = False) -> MapError:
        more = f" (and {count - 1} more)" if count > 1 else ""
        what = "witness chunk" if witness else "chunk"
        return MapError(
            f"{self.path}: {what} (z, pitch, roll) = {chunk} of arm '{arm}'{more} does not match its "
            f"checksum (changed, swapped or missing chunk data: corrupt); rebuild the map"
        )

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
    def write(self, path: Path, root: dict[str, Any], arms: dict[str, ArmArrays]) -> None:
        """Write a complete map to ``path`` (a fresh path; not atomic by itself); ``arms`` maps each arm
        to (values, metadata, witnesses)."""

    @abstractmethod
    def open(self, path: Path) -> StoredMap:
        """Open ``path`` for reading (raises MapError if it is not a readable map)."""


def partial_path(target: Path) -> Path:
    """Where this thread writes the map ``target`` before swapping it in: a hidden sibling."""
    return target.with_name(f".{target.name}.partial-{os.getpid()}-{threading.get_native_id()}")


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` runs (one of another user counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clear_leftovers(target: Path) -> list[str]:
    """Remove what a save into ``target`` killed midway left beside it (its partial copy, the old map
    it had moved aside), and restore the old map when the kill came between the two renames.

    Call it holding ``target``'s save lock: no save into ``target`` runs then, so a partial or old
    sibling of a process that is gone is a leftover. Returns one line per thing done.
    """
    done: list[str] = []
    siblings = sorted(target.parent.glob(f".{target.name}.*-*-*")) if target.parent.is_dir() else []
    for path in siblings:
        kind, _, rest = path.name[len(target.name) + 2 :].partition("-")
        pid = rest.split("-")[0]
        if kind not in ("partial", "old") or not pid.isdigit() or process_alive(int(pid)):
            continue
        if kind == "old" and not target.exists() and not target.is_symlink():
            os.replace(path, target)
            done.append(f"restored {target} from {path.name}, moved aside by a save that was killed (pid {pid})")
        else:
            _remove(path)
            done.append(f"removed {path.name}, left by a save that was killed (pid {pid})")
    return done


def atomic_replace(backend: Backend, target: Path | str, root: dict[str, Any], arms: dict[str, ArmArrays]) -> None:
    """Write via a sibling partial path, then swap it in; the old map survives a failure."""
    target = Path(target)
    partial = partial_path(target)
    old = target.with_name(f".{target.name}.old-{os.getpid()}-{threading.get_native_id()}")
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
