"""HDF5 backend: one file, gzip-compressed chunks with a fletcher32 checksum, metadata as JSON attributes.

Only a regular file is opened; only datasets stored in the file itself are read (no links to other
files, no external or virtual storage), and a metadata attribute only up to a sane size.
"""

from __future__ import annotations

import json
import zlib
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import numpy.typing as npt

from placement.errors import MapError
from placement.storage.base import ROOT_KEY, ArmArrays, Backend, StoredMap, chunk_shape, first_line, opened
from placement.storage.chunks import ChunkReader
from placement.storage.digest import seal
from placement.storage.files import META_LIMIT, FileRefused, read_head, regular_size
from placement.storage.format import witness_name

_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: an HDF5 map file may be this large [bytes] (a 5 cm PR2 map with both arms: ~0.6 GB)
HDF5_LIMIT = 1 << 40


#: the filters of every dataset this package writes, in pipeline order
FILTERS = (h5py.h5z.FILTER_SHUFFLE, h5py.h5z.FILTER_DEFLATE, h5py.h5z.FILTER_FLETCHER32)


class Hdf5Chunks(ChunkReader):
    """The chunks of one dataset (filters :data:`FILTERS`), read raw and decoded here, in parallel.

    A chunk's stored size is checked against the bound of its shape before it is read; the deflate
    stream is inflated to at most the chunk's size, and zlib checks its Adler-32 (the fletcher32 trailer
    only repeats that check on the compressed bytes; the CRC32 of the decoded chunk decides).
    """

    def __init__(self, ds: h5py.Dataset) -> None:
        super().__init__(ds.shape, ds.dtype, ds.fillvalue)
        self.ds = ds
        self.sizes: dict[tuple[int, ...], int] = {}  # chunk offset -> stored size [bytes], of every stored chunk
        ds.id.chunk_iter(lambda info: self.sizes.__setitem__(tuple(info.chunk_offset), int(info.size)))

    def decoded(self, iz: int, ip: int, ir: int) -> npt.NDArray[np.uint8] | None:
        coord = (0, 0, iz, 0, ip, ir)
        size = self.sizes.get(coord)
        if size is None:
            return None
        if not 4 < size <= self.limit:
            raise ValueError(f"stored size {size} bytes, a chunk of {self.raw} bytes needs at most {self.limit}")
        mask, raw = self.ds.id.read_direct_chunk(coord)
        if mask or len(raw) != size:
            raise ValueError(f"filters skipped (mask {mask}) or {len(raw)} bytes read, not {size}")
        inflate = zlib.decompressobj()
        shuffled = inflate.decompress(raw[:-4], self.raw + 1)
        if not inflate.eof or inflate.unused_data or len(shuffled) != self.raw:
            raise ValueError(f"deflate stream of {len(shuffled)} bytes, not {self.raw}")
        k = self.dtype.itemsize
        out = np.empty((self.raw // k, k), dtype=np.uint8)
        planes = np.frombuffer(shuffled, dtype=np.uint8).reshape(k, self.raw // k)
        for j in range(k):  # byte plane j -> byte j of every element
            out[:, j] = planes[j]
        return out


class Hdf5Map(StoredMap):
    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            regular_size(path, HDF5_LIMIT)
        except FileRefused as exc:
            raise MapError(f"{path}: {first_line(exc)}") from None

        def read() -> tuple[h5py.File, object]:
            f = h5py.File(path, "r")
            return f, json.loads(self._attribute(f, ROOT_KEY, "{}"))

        self.file, root = opened(path, "HDF5", read)
        self.root = self.accept_root(root)

    @staticmethod
    def _attribute(obj: h5py.HLObject, name: str, default: str | None = None) -> Any:  # h5py has no types
        """A JSON text attribute of at most META_LIMIT bytes (``default`` if absent)."""
        if name not in obj.attrs:
            return default
        size = h5py.h5a.open(obj.id, name.encode()).get_storage_size()
        if size > META_LIMIT:
            raise ValueError(f"attribute '{name}' has {size} bytes, more than {META_LIMIT}")
        return obj.attrs[name]

    def _get(self, name: str) -> h5py.Dataset:
        link = self.file.get(name, getlink=True)
        if not isinstance(link, h5py.HardLink):
            raise ValueError(
                f"'{name}' is {type(link).__name__ if link is not None else 'missing'}, not a dataset of this file"
            )
        ds = self.file[name]
        if not isinstance(ds, h5py.Dataset) or ds.external or ds.is_virtual:
            raise ValueError(f"'{name}' is not a dataset stored in this file")
        return ds

    def _reader(self, arm: str, witness: bool, array: h5py.Dataset) -> Hdf5Chunks:
        plist = array.id.get_create_plist()
        filters = tuple(plist.get_filter(i)[0] for i in range(plist.get_nfilters()))
        if filters != FILTERS:
            raise MapError(
                f"{self.path}: the {'witness ' if witness else ''}dataset of arm '{arm}' has filters "
                f"{list(filters)} (not written by placement: corrupt); rebuild the map"
            )
        return Hdf5Chunks(array)

    def _arm_meta(self, arm: str) -> object:
        return json.loads(self._attribute(self._raw_array(arm), "meta"))

    def chunks_present(self, name: str) -> int | None:
        return None

    def close(self) -> None:
        self.file.close()


class Hdf5Backend(Backend):
    name = "hdf5"
    suffix = ".h5"

    def is_map(self, path: Path) -> bool:
        path = Path(path)
        try:
            return read_head(path, len(_SIGNATURE), HDF5_LIMIT) == _SIGNATURE
        except OSError:  # no regular file (a FIFO or a device is never opened), or unreadable
            return False

    def write(self, path: Path, root: dict[str, Any], arms: dict[str, ArmArrays]) -> None:
        with h5py.File(path, "w") as fh:
            metas = {}
            for arm, (values, meta, witness) in arms.items():
                ds = fh.create_dataset(
                    arm,
                    data=values,
                    dtype="float32",
                    chunks=chunk_shape(values.shape),
                    compression="gzip",
                    compression_opts=1,
                    shuffle=True,
                    fletcher32=True,
                    fillvalue=0.0,
                )
                ds.attrs["meta"] = json.dumps(meta)
                metas[arm] = json.loads(ds.attrs["meta"])  # sealed as it reads back
                fh.create_dataset(
                    witness_name(arm),
                    data=witness,
                    dtype=witness.dtype,
                    chunks=chunk_shape(values.shape),
                    compression="gzip",
                    compression_opts=1,
                    shuffle=True,
                    fletcher32=True,
                    fillvalue=np.iinfo(witness.dtype).max,
                )
            root = dict(root)
            root["complete"] = True
            fh.attrs[ROOT_KEY] = json.dumps(seal(root, metas))
            fh.flush()

    def open(self, path: Path) -> StoredMap:
        return Hdf5Map(Path(path))
