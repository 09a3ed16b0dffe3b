"""Zarr v3 backend: a directory store, zstd-compressed chunks with a crc32c of their stored bytes.

zarr reads and writes the metadata (through :class:`BoundedStore`: only regular files of a sane
size); the chunks of a map are read directly (:class:`ChunkFiles`): every map this package writes
has the one codec chain bytes (little endian) -> blosc -> crc32c, and reading a chunk file, checking
its crc32c and decompressing it into a buffer of the chunk's exact size costs a fraction of zarr's
per-chunk overhead (a whole map reads several times as fast), with the bound on every file.
"""

from __future__ import annotations

import asyncio
import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import google_crc32c
import numpy as np
import numpy.typing as npt
import zarr
from numcodecs import blosc
from zarr.codecs import BloscCodec, Crc32cCodec
from zarr.core.buffer.core import default_buffer_prototype
from zarr.storage import LocalStore

from placement.errors import MapError
from placement.storage.base import ROOT_KEY, ArmArrays, Backend, StoredMap, chunk_shape, opened
from placement.storage.chunks import ChunkReader, each_of
from placement.storage.digest import seal
from placement.storage.files import META_LIMIT, read_bounded
from placement.storage.format import witness_name

if TYPE_CHECKING:
    from zarr.abc.store import ByteRequest
    from zarr.core.buffer import Buffer, BufferPrototype

#: the codecs of every array this package writes (anything else is not one of its maps)
CODECS = ("bytes", "blosc", "crc32c")
#: the blosc settings of those codecs (what the arrays record, and what write_chunks compresses with)
BLOSC_CNAME: Literal["zstd"] = "zstd"
BLOSC_LEVEL = 3
_BLOSC_HEADER = 16


def chunk_file(folder: Path | str, iz: int, ip: int, ir: int) -> str:
    """The file of chunk (iz, ip, ir) in the chunk folder (``<array>/c``) of an array chunked one
    (z, pitch, roll) slice per chunk: zarr's default keys, ``0/0/<iz>/0/<ip>/<ir>``."""
    return os.path.join(folder, "0", "0", str(iz), "0", str(ip), str(ir))


def _compressors() -> list[Any]:
    """The codecs after ``bytes`` of every array this package writes (see :data:`CODECS`)."""
    return [BloscCodec(cname=BLOSC_CNAME, clevel=BLOSC_LEVEL, shuffle="shuffle"), Crc32cCodec()]


class BoundedStore(LocalStore):
    """A read-only LocalStore that reads only regular files of at most :data:`META_LIMIT` bytes."""

    def __init__(self, root: Path | str, read_only: bool = True) -> None:
        super().__init__(root, read_only=True)

    async def get(
        self, key: str, prototype: BufferPrototype | None = None, byte_range: ByteRequest | None = None
    ) -> Buffer | None:
        if byte_range is not None:
            raise ValueError(f"{key}: byte-range reads are not used by maps")
        try:
            data = await asyncio.to_thread(read_bounded, Path(self.root) / key, META_LIMIT)
        except (FileNotFoundError, NotADirectoryError):
            return None
        return (prototype or default_buffer_prototype()).buffer.from_bytes(data)

    async def get_partial_values(
        self, prototype: BufferPrototype, key_ranges: Iterable[tuple[str, ByteRequest | None]]
    ) -> list[Buffer | None]:
        return [await self.get(key, prototype, byte_range) for key, byte_range in key_ranges]


class ChunkFiles(ChunkReader):
    """The chunk files of one array (codecs :data:`CODECS`), read directly: bounded, crc32c checked."""

    def __init__(self, folder: Path, shape: tuple[int, ...], dtype: npt.DTypeLike, fill: float | np.generic) -> None:
        super().__init__(shape, dtype, fill)
        self.folder = folder

    def decoded(self, iz: int, ip: int, ir: int) -> npt.NDArray[np.uint8] | None:
        try:
            data = read_bounded(chunk_file(self.folder, iz, ip, ir), self.limit)
        except (FileNotFoundError, NotADirectoryError):
            return None
        if len(data) < _BLOSC_HEADER + 4:
            raise ValueError(f"{len(data)} bytes: truncated")
        body = data[:-4]
        if google_crc32c.value(body) != int.from_bytes(data[-4:], "little"):
            raise ValueError("stored and computed crc32c do not match")
        nbytes, cbytes = int.from_bytes(body[4:8], "little"), int.from_bytes(body[12:16], "little")
        if nbytes != self.raw or cbytes != len(body):
            raise ValueError(
                f"blosc header says {nbytes} bytes from {cbytes}, the chunk holds {self.raw} from {len(body)}"
            )
        out = np.empty(self.raw, dtype=np.uint8)
        blosc.decompress(body, out)
        return out


class ZarrMap(StoredMap):
    def __init__(self, path: Path) -> None:
        self.path = path

        def read() -> tuple[zarr.Group, object]:
            group = zarr.open_group(store=BoundedStore(path), mode="r")
            return group, group.attrs.get(ROOT_KEY, {})

        self.group, root = opened(path, "Zarr", read)
        self.root = self.accept_root(root)

    def _get(self, name: str) -> zarr.Array[Any]:
        node = self.group[name]
        if not isinstance(node, zarr.Array):
            raise ValueError(f"'{name}' is a {type(node).__name__}, not an array")
        return node

    def _arm_meta(self, arm: str) -> dict[str, Any]:
        return dict(self._raw_array(arm).attrs.asdict())

    def _reader(self, arm: str, witness: bool, array: zarr.Array[Any]) -> ChunkFiles:
        md: dict[str, Any] = array.metadata.to_dict()  # walked as plain JSON: any layout but ours fails below
        codecs = tuple(c.get("name") for c in md.get("codecs", ()))
        encoding = md.get("chunk_key_encoding", {})
        if (
            codecs != CODECS
            or md["codecs"][0].get("configuration", {}).get("endian") != "little"
            or encoding.get("configuration", {}).get("separator") != "/"
        ):
            raise MapError(
                f"{self.path}: the {'witness ' if witness else ''}array of arm '{arm}' has codecs "
                f"{list(codecs)} (not written by placement: corrupt); rebuild the map"
            )
        fill = array.metadata.fill_value
        if not isinstance(fill, (int, float, np.generic)):  # zarr parses a v3 fill value to a scalar of the dtype
            raise MapError(
                f"{self.path}: the {'witness ' if witness else ''}array of arm '{arm}' has fill value {fill!r} "
                f"(corrupt); rebuild the map"
            )
        name = witness_name(arm) if witness else arm
        return ChunkFiles(self.path / name / "c", tuple(array.shape), array.dtype, fill)

    def chunks_present(self, name: str) -> int | None:
        return count_chunks(self.path / name)


def count_chunks(array_dir: Path) -> int:
    """How many chunk files the array stored in ``array_dir`` has (entries are only listed, never opened)."""
    chunk_dir = array_dir / "c"
    if not chunk_dir.is_dir():
        return 0
    return sum(len(files) for _, _, files in os.walk(chunk_dir))


def write_chunks(folder: Path, array: npt.NDArray[Any], fill: float | int) -> None:
    """Store every (z, pitch, roll) chunk of ``array`` (nx, ny, nz, n_yaw, n_pitch, n_roll) that is not
    all ``fill`` in the array directory ``folder`` as zarr stores it with :data:`CODECS`: its C-order
    little-endian bytes, blosc (:data:`BLOSC_CNAME`, :data:`BLOSC_LEVEL`, byte shuffle), the crc32c
    of those (4 bytes, little endian), at :func:`chunk_file`; a chunk of ``fill`` alone is not stored
    (zarr's default).
    Zarr reads the array as the one it would write (tests/test_storage.py), in a quarter of the time:
    zarr's own writes took 1-2 ms per chunk, most of a small map's build."""
    dtype = array.dtype.newbyteorder("<")
    _, _, nz, _, n_pitch, n_roll = array.shape

    cname = BLOSC_CNAME.encode()

    def layer(iz: int) -> None:
        for ip in range(n_pitch):
            for ir in range(n_roll):
                chunk = array[:, :, iz, :, ip, ir]
                if (chunk == fill).all():
                    continue
                body = blosc.compress(np.ascontiguousarray(chunk, dtype=dtype), cname, BLOSC_LEVEL, blosc.SHUFFLE)
                where = Path(chunk_file(folder / "c", iz, ip, ir))
                where.parent.mkdir(parents=True, exist_ok=True)
                where.write_bytes(body + google_crc32c.value(body).to_bytes(4, "little"))

    each_of(layer, range(nz))


class ZarrBackend(Backend):
    name = "zarr"
    suffix = ""

    def is_map(self, path: Path) -> bool:
        return os.path.lexists(Path(path) / "zarr.json")  # a zarr.json that is no regular file fails when read

    def write(self, path: Path, root: dict[str, Any], arms: dict[str, ArmArrays]) -> None:
        group = zarr.open_group(store=str(path), mode="w", zarr_format=3)
        metas = {}
        for arm, (values, meta, witness) in arms.items():
            arr = group.create_array(
                arm,
                shape=values.shape,
                dtype="float32",
                chunks=chunk_shape(values.shape),
                compressors=_compressors(),
                fill_value=0.0,
                dimension_names=["x", "y", "z", "yaw", "pitch", "roll"],
            )
            write_chunks(path / arm, values, 0.0)
            group.create_array(
                witness_name(arm),
                shape=witness.shape,
                dtype=witness.dtype,
                chunks=chunk_shape(values.shape),
                compressors=_compressors(),
                fill_value=np.iinfo(witness.dtype).max,
                dimension_names=["x", "y", "z", "yaw", "pitch", "roll"],
            )
            write_chunks(path / witness_name(arm), witness, np.iinfo(witness.dtype).max)
            meta = dict(meta)
            meta["stored_chunks"] = count_chunks(path / arm)
            meta["stored_witness_chunks"] = count_chunks(path / witness_name(arm))
            arr.attrs.update(json.loads(json.dumps(meta)))
            metas[arm] = dict(arr.attrs.asdict())  # sealed as it reads back
        root = dict(root)
        root["complete"] = True  # last: a map without it is half-written
        group.attrs[ROOT_KEY] = seal(root, metas)

    def open(self, path: Path) -> StoredMap:
        return ZarrMap(Path(path))
