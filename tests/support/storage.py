"""Map storage helpers: a small grid, the formats, edits of stored metadata, file snapshots."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from placement.storage import backend
from placement.storage.digest import DIGEST_KEY, document_digest
from placement.storage.format import ROOT_KEY

#: the grid of the small test maps (built by the ``right_map`` / ``left_map`` fixtures of conftest.py)
SMALL = dict(resolution=0.2, bins=(4, 3, 4))
FORMATS = ["zarr", "hdf5"]


def map_path(tmp_path: Path, fmt: str, name: str = "pr2") -> Path:
    return tmp_path / (name + backend(fmt).suffix)


def set_root(path: Path, fmt: str, edit, reseal: bool = True) -> None:
    """Apply ``edit(root_dict)`` to the stored root metadata (simulates other maps and versions: with
    ``reseal``, the root's digest is made to match, as if it had been written so; else damage)."""

    def change(root):
        edit(root)
        if reseal and isinstance(root.get(DIGEST_KEY), dict):
            root[DIGEST_KEY]["root"] = document_digest({k: v for k, v in root.items() if k != DIGEST_KEY})

    if fmt == "zarr":
        meta_file = path / "zarr.json"
        doc = json.loads(meta_file.read_text())
        change(doc["attributes"][ROOT_KEY])
        meta_file.write_text(json.dumps(doc))
    else:
        with h5py.File(path, "r+") as fh:
            root = json.loads(fh.attrs[ROOT_KEY])
            change(root)
            fh.attrs[ROOT_KEY] = json.dumps(root)


def reseal_arm(path: Path, arm: str) -> None:
    """Make the root's digest of ``arm``'s metadata (Zarr) match its stored metadata, as if written so."""
    import zarr

    group = zarr.open_group(str(path), mode="r+")
    root = dict(group.attrs[ROOT_KEY])
    root[DIGEST_KEY]["arms"][arm] = document_digest(dict(group[arm].attrs.asdict()))
    group.attrs[ROOT_KEY] = root
    set_root(path, "zarr", lambda r: None)


def zarr_chunk_files(path: Path, arm: str = "right") -> list[Path]:
    return sorted(p for p in (path / arm / "c").rglob("*") if p.is_file())


def filled_cell_poses(m, limit=None):
    flat = np.flatnonzero(m.values)
    if limit is not None:
        flat = flat[:: max(1, len(flat) // limit)][:limit]
    return flat, m.grid.centre(flat)


def snapshot(directory: Path) -> dict:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}
