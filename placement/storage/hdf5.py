"""HDF5 backend: one file, gzip-compressed chunks with a fletcher32 checksum, metadata as JSON attributes."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from ..errors import MapError
from .base import ROOT_KEY, Backend, StoredMap, chunk_shape, first_line, opened
from .format import witness_name

_SIGNATURE = b"\x89HDF\r\n\x1a\n"


class Hdf5Map(StoredMap):
    def __init__(self, path: Path):
        self.path = path

        def read():
            f = h5py.File(path, "r")
            return f, json.loads(f.attrs.get(ROOT_KEY, "{}"))

        self.file, self.root = opened(path, "HDF5", read)

    def _get(self, name: str):
        return self.file[name]

    def arm_meta(self, arm: str) -> dict:
        try:
            return json.loads(self._array(arm).attrs["meta"])
        except MapError:
            raise
        except Exception as exc:
            raise MapError(f"{self.path}: metadata of arm '{arm}' is corrupt ({first_line(exc)})") from None

    def chunks_present(self, name: str) -> int | None:
        return None

    def close(self) -> None:
        self.file.close()


class Hdf5Backend(Backend):
    name = "hdf5"
    suffix = ".h5"

    def is_map(self, path: Path) -> bool:
        path = Path(path)
        if not path.is_file():
            return False
        with open(path, "rb") as fh:
            return fh.read(8) == _SIGNATURE

    def write(self, path: Path, root: dict, arms: dict) -> None:
        with h5py.File(path, "w") as fh:
            for arm, (values, meta, witness) in arms.items():
                ds = fh.create_dataset(arm, data=values, dtype="float32", chunks=chunk_shape(values.shape),
                                       compression="gzip", compression_opts=1, shuffle=True, fletcher32=True,
                                       fillvalue=0.0)
                ds.attrs["meta"] = json.dumps(meta)
                fh.create_dataset(witness_name(arm), data=witness, dtype=witness.dtype,
                                  chunks=chunk_shape(values.shape), compression="gzip", compression_opts=1,
                                  shuffle=True, fletcher32=True, fillvalue=np.iinfo(witness.dtype).max)
            root = dict(root)
            root["complete"] = True
            fh.attrs[ROOT_KEY] = json.dumps(root)
            fh.flush()

    def open(self, path: Path) -> StoredMap:
        return Hdf5Map(Path(path))
