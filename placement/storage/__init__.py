"""Map storage: Zarr v3 (default) and HDF5 behind one interface (see base.py)."""

from __future__ import annotations

from pathlib import Path

from placement.errors import MapError
from placement.storage.base import Backend, StoredMap, atomic_replace
from placement.storage.hdf5 import Hdf5Backend
from placement.storage.zarr import ZarrBackend

BACKENDS: dict[str, Backend] = {"zarr": ZarrBackend(), "hdf5": Hdf5Backend()}


def backend(name: str) -> Backend:
    """The backend called ``name`` ("zarr" or "hdf5")."""
    try:
        return BACKENDS[name]
    except KeyError:
        raise MapError(f"unknown map format '{name}'; choose from {', '.join(BACKENDS)}") from None


def map_identity(path: str | Path) -> tuple[tuple[int, int, int], ...] | None:
    """What tells one stored map from another at ``path`` without reading it: (inode, mtime [ns],
    size [bytes]) of the path and, for a folder, of its root metadata file; None when it is gone. A
    build replaces a map by renaming a new one over it, so a rebuilt map has a new identity."""
    path = Path(path)
    out = []
    for p in (path, path / "zarr.json") if path.is_dir() else (path,):
        try:
            st = p.stat()
        except OSError:
            return None
        out.append((st.st_ino, st.st_mtime_ns, st.st_size))
    return tuple(out)


def detect(path: str | Path) -> Backend:
    """The backend that wrote ``path``; MapError if it is no map at all."""
    path = Path(path)
    if not path.exists():
        raise MapError(f"{path}: no such map (build one with `placement maps build`)")
    for b in BACKENDS.values():
        if b.is_map(path):
            return b
    raise MapError(f"{path}: not a reachability map (no zarr.json and not an HDF5 file)")


def open_store(path: str | Path) -> StoredMap:
    """Open a stored map of either backend."""
    return detect(path).open(Path(path))


__all__ = ["BACKENDS", "Backend", "StoredMap", "atomic_replace", "backend", "detect", "map_identity", "open_store"]
