"""Damaged map data never gives an answer: every kind of damage fails with one MapError when read.

Each damage is made to a real file of a freshly saved map; then the damaged chunk is read through
the API (``value()`` on its cells, lazily and through the whole-array path, and ``slice()``) and
through `placement maps info` in a fresh process (exit 2, exactly one stderr line).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import zarr
from support.storage import zarr_chunk_files

import placement
from placement import MapError

ROOT = Path(__file__).resolve().parents[1]


def chunk_index(path: Path, f: Path) -> tuple[int, int, int]:
    """(iz, ip, ir) of a zarr chunk file (key c/ix/iy/iz/iyaw/ip/ir)."""
    parts = [int(x) for x in f.relative_to(path / "right" / "c").parts]
    return parts[2], parts[4], parts[5]


def data_chunks(path: Path) -> list[Path]:
    """Stored chunk files, largest (most data) first."""
    return sorted(zarr_chunk_files(path), key=lambda p: -p.stat().st_size)


def garble(data: bytes) -> bytes:
    """Overwrite a run of bytes after the header with a fixed pattern."""
    start = min(32, len(data) // 2)
    n = max(8, (len(data) - start) // 2)
    return data[:start] + bytes((i * 37 + 11) & 0xFF for i in range(n)) + data[start + n :]


def changed_bytes(path):
    f = data_chunks(path)[0]
    f.write_bytes(garble(f.read_bytes()))
    return chunk_index(path, f)


def bit_flip(path):
    f = data_chunks(path)[0]
    data = bytearray(f.read_bytes())
    data[len(data) // 2] ^= 0x10
    f.write_bytes(bytes(data))
    return chunk_index(path, f)


def truncated(path):
    f = data_chunks(path)[0]
    f.write_bytes(f.read_bytes()[:10])
    return chunk_index(path, f)


def swapped(path):
    a, b = data_chunks(path)[:2]
    da, db = a.read_bytes(), b.read_bytes()
    a.write_bytes(db)
    b.write_bytes(da)
    return chunk_index(path, a)


def moved(path):
    """A chunk file moved to the key of a chunk that was all zero (not stored): the chunk count is unchanged."""
    f = data_chunks(path)[0]
    arr = zarr.open_group(str(path), mode="r")["right"]
    _, _, nz, _, n_pitch, n_roll = arr.shape
    stored = {chunk_index(path, p) for p in zarr_chunk_files(path)}
    iz, ip, ir = next(
        (z, p, r) for z in range(nz) for p in range(n_pitch) for r in range(n_roll) if (z, p, r) not in stored
    )
    target = path / "right" / "c" / "0" / "0" / str(iz) / "0" / str(ip) / str(ir)
    target.parent.mkdir(parents=True, exist_ok=True)
    os.replace(f, target)
    return chunk_index(path, f)


def deleted(path):
    f = data_chunks(path)[0]
    f.unlink()
    return chunk_index(path, f)


def rewritten(path):
    """Valid chunk bytes holding other data (a stray writer): only the CRC of the decoded chunk sees it."""
    arr = zarr.open_group(str(path), mode="r+")["right"]
    f = data_chunks(path)[0]
    iz, ip, ir = chunk_index(path, f)
    block = arr[:, :, iz, :, ip, ir]
    arr[:, :, iz, :, ip, ir] = block + np.float32(0.5) * (block > 0)
    return iz, ip, ir


def _hdf5_chunk(path):
    with h5py.File(path, "r") as fh:
        ds = fh["right"]
        return max((ds.id.get_chunk_info(i) for i in range(ds.id.get_num_chunks())), key=lambda c: c.size)


def hdf5_byte_flip(path):
    info = _hdf5_chunk(path)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        b = fh.read(1)
        fh.seek(info.byte_offset + info.size // 2)
        fh.write(bytes([b[0] ^ 0x01]))
    _, _, iz, _, ip, ir = info.chunk_offset
    return iz, ip, ir


def hdf5_rewritten(path):
    info = _hdf5_chunk(path)
    _, _, iz, _, ip, ir = info.chunk_offset
    with h5py.File(path, "r+") as fh:
        block = fh["right"][:, :, iz, :, ip, ir]
        fh["right"][:, :, iz, :, ip, ir] = block + np.float32(0.5) * (block > 0)
    return iz, ip, ir


ZARR_DAMAGE = [changed_bytes, bit_flip, truncated, swapped, moved, deleted, rewritten]
HDF5_DAMAGE = [hdf5_byte_flip, hdf5_rewritten]
CASES = [("zarr", d) for d in ZARR_DAMAGE] + [("hdf5", d) for d in HDF5_DAMAGE]
IDS = [d.__name__ for _, d in CASES]


@pytest.fixture(params=CASES, ids=IDS)
def damaged(request, tmp_path, pr2, right_map):
    """(path, (iz, ip, ir) of a damaged chunk, damage name) of a saved map with one damage."""
    fmt, damage = request.param
    path = placement.save_maps(
        tmp_path / ("pr2" + placement.storage.backend(fmt).suffix), pr2, {"right": right_map}, fmt
    )
    placement.open_map(path, "right").verify()  # sound before the damage
    return path, damage(path), damage.__name__


def cells_of_chunk(built, iz, ip, ir) -> np.ndarray:
    """Flat indices of the reached cells of chunk (iz, ip, ir)."""
    mask = np.zeros(built.values.shape, dtype=bool)
    mask[:, :, iz, :, ip, ir] = built.values[:, :, iz, :, ip, ir] > 0
    flat = np.flatnonzero(mask)
    assert flat.size > 0
    return flat


@pytest.mark.slow
def test_value_of_a_damaged_chunk_raises(damaged, right_map):
    path, (iz, ip, ir), _ = damaged
    poses = right_map.grid.centre(cells_of_chunk(right_map, iz, ip, ir))
    with pytest.raises(MapError, match="corrupt"):
        placement.open_map(path, "right").value(poses[:5])  # lazy: reads that one chunk
    many = np.concatenate([poses, np.repeat(poses[:1], 2001, axis=0)])
    with pytest.raises(MapError, match="corrupt"):
        placement.open_map(path, "right").value(many)  # > 2000 poses: the whole array
    with pytest.raises(MapError, match="corrupt"):
        placement.open_map(path, "right").slice(iz, ip, ir)


@pytest.mark.slow
def test_a_z_layer_read_finds_the_damage_too(damaged, right_map):
    """read_slab (the map viewer's layer-wise read) checks every chunk of the layer; other layers read exactly."""
    path, (iz, ip, ir), name = damaged
    if name == "deleted":
        pytest.skip("fails at open")
    rmap = placement.open_map(path, "right")
    with pytest.raises(MapError, match="corrupt") as exc:
        rmap.store.read_slab("right", iz)
    assert "\n" not in str(exc.value)
    if name in ("swapped", "moved"):
        return  # the other chunk key may lie in any layer
    other = next(z for z in range(right_map.grid.shape[2]) if z != iz)
    np.testing.assert_array_equal(rmap.store.read_slab("right", other), right_map.values[:, :, other])


@pytest.mark.slow
def test_damage_is_named_as_such(damaged):
    """Decoded-data damage names the chunk; byte damage is caught by the backend's checksum or codec."""
    path, (iz, ip, ir), name = damaged
    if name == "deleted":
        with pytest.raises(MapError, match="has .* of .* data chunks"):
            placement.open_map(path, "right")
        return
    rmap = placement.open_map(path, "right")
    with pytest.raises(MapError) as exc:
        rmap.slice(iz, ip, ir)
    if name in ("swapped", "moved", "rewritten", "hdf5_rewritten"):
        assert f"chunk (z, pitch, roll) = ({iz}, {ip}, {ir})" in str(exc.value)
        assert "checksum" in str(exc.value)
    assert "\n" not in str(exc.value)


@pytest.mark.slow
def test_slices_read_together_fail_on_the_damaged_one(damaged):
    """read_slices reads on the chunk threads: a damaged chunk among sound ones is one MapError."""
    path, (iz, ip, ir), name = damaged
    if name == "deleted":
        pytest.skip("fails at open")
    rmap = placement.open_map(path, "right")
    g = rmap.grid.shape
    keys = [(z, p, r) for z in range(g[2]) for p in range(g[4]) for r in range(g[5])]
    with pytest.raises(MapError) as exc:
        rmap.read_slices(keys)
    assert "\n" not in str(exc.value)


@pytest.mark.slow
def test_maps_info_full_fails_with_one_line(damaged):
    path, _, _ = damaged
    p = subprocess.run(
        [sys.executable, "-m", "placement.cli.main", "maps", "info", str(path), "--full"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert p.returncode == 2, p.stderr
    assert p.stdout == ""
    lines = p.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "corrupt" in lines[0], p.stderr[:3000]


@pytest.mark.slow
def test_sound_chunks_still_read_beside_a_damaged_one(damaged, right_map):
    """Reading is per chunk: a chunk that is intact and was not moved onto reads exactly."""
    path, (iz, ip, ir), name = damaged
    if name in ("deleted", "moved", "swapped"):
        pytest.skip("these touch two chunk keys or fail at open")
    rmap = placement.open_map(path, "right")
    other = next(
        (z, p, r)
        for z in range(right_map.grid.shape[2])
        for p in range(right_map.grid.shape[4])
        for r in range(right_map.grid.shape[5])
        if (z, p, r) != (iz, ip, ir) and right_map.values[:, :, z, :, p, r].any()
    )
    np.testing.assert_array_equal(rmap.slice(*other), right_map.values[:, :, other[0], :, other[1], other[2]])


def test_truncated_hdf5_file(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2.h5", pr2, {"right": right_map}, "hdf5")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(MapError):
        placement.open_map(path, "right").verify()


@pytest.mark.parametrize("fmt", ["zarr", "hdf5"])
def test_backends_check_bytes_too(tmp_path, pr2, right_map, fmt):
    """zarr stores chunks with a crc32c codec, HDF5 with the fletcher32 filter."""
    path = placement.save_maps(tmp_path / ("m" + placement.storage.backend(fmt).suffix), pr2, {"right": right_map}, fmt)
    if fmt == "zarr":
        codecs = [c.to_dict()["name"] for c in zarr.open_group(str(path), mode="r")["right"].metadata.codecs]
        assert codecs[-1] == "crc32c"
    else:
        with h5py.File(path, "r") as fh:
            assert fh["right"].fletcher32
