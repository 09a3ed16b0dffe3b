"""Map storage (Zarr v3 and HDF5): round trip, metadata, validation and atomic writes (SPEC section 4)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

import placement
from placement import MapError
from placement.storage import backend
from placement.storage.base import ROOT_KEY, atomic_replace
from placement.storage.zarr import ZarrBackend

SMALL = dict(resolution=0.2, bins=(4, 3, 4))
FORMATS = ["zarr", "hdf5"]
META_KEYS = ("format_version", "robot", "urdf_sha256", "arm", "base_frame", "tip_frame", "grid", "measure",
             "samples", "seed", "build_time_s", "software")


@pytest.fixture(scope="module")
def right_map(pr2):
    return placement.build_map(pr2, "right", samples=4000, seed=2, progress=False, **SMALL)


@pytest.fixture(scope="module")
def left_map(pr2):
    return placement.build_map(pr2, "left", samples=1000, seed=3, progress=False, **SMALL)


def map_path(tmp_path: Path, fmt: str, name: str = "pr2") -> Path:
    return tmp_path / (name + backend(fmt).suffix)


@pytest.fixture(params=FORMATS)
def saved(request, tmp_path, pr2, right_map):
    """(format, path) of a freshly saved PR2 right-arm map."""
    fmt = request.param
    path = placement.save_maps(map_path(tmp_path, fmt), pr2, {"right": right_map}, fmt)
    return fmt, Path(path)


def set_root(path: Path, fmt: str, edit) -> None:
    """Apply ``edit(root_dict)`` to the stored root metadata (simulates damage/other versions)."""
    if fmt == "zarr":
        meta_file = path / "zarr.json"
        doc = json.loads(meta_file.read_text())
        edit(doc["attributes"][ROOT_KEY])
        meta_file.write_text(json.dumps(doc))
    else:
        with h5py.File(path, "r+") as fh:
            root = json.loads(fh.attrs[ROOT_KEY])
            edit(root)
            fh.attrs[ROOT_KEY] = json.dumps(root)


def zarr_chunk_files(path: Path, arm: str = "right") -> list[Path]:
    return sorted(p for p in (path / arm / "c").rglob("*") if p.is_file())


def filled_cell_poses(m, limit=None):
    flat = np.flatnonzero(m.values)
    if limit is not None:
        flat = flat[:: max(1, len(flat) // limit)][:limit]
    return flat, m.grid.centre(flat)


def snapshot(directory: Path) -> dict:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


# --------------------------------------------------------------------------------------------
# Round trip and metadata
# --------------------------------------------------------------------------------------------

def test_round_trip_values(saved, right_map):
    fmt, path = saved
    rmap = placement.open_map(path, "right")
    assert rmap.grid == right_map.grid
    flat, poses = filled_cell_poses(right_map)
    assert len(flat) > 2000  # the full-load path of value() is used below
    # lazy, chunk by chunk (<= 2000 poses)
    sub = slice(0, 1500)
    got = rmap.value(poses[sub])
    np.testing.assert_array_equal(got, right_map.values.ravel()[flat[sub]].astype(np.float64))
    assert rmap._full is None, "the lazy path was expected for <= 2000 poses"
    # single pose
    assert rmap.value(poses[0]).shape == (1,)
    assert rmap.value(poses[0])[0] == right_map.values.ravel()[flat[0]]
    # empty cells read 0, poses outside the grid read 0
    empty = np.flatnonzero(right_map.values == 0)[::997]
    np.testing.assert_array_equal(rmap.value(right_map.grid.centre(empty)), 0.0)
    far = np.eye(4)
    far[:3, 3] = 10.0
    assert rmap.value(far)[0] == 0.0
    # many poses: whole array loaded
    rmap2 = placement.open_map(path, "right")
    np.testing.assert_array_equal(rmap2.value(poses), right_map.values.ravel()[flat])
    assert rmap2._full is not None
    np.testing.assert_array_equal(rmap2.store.read_all("right"), right_map.values)
    rmap2.verify()


def test_metadata(saved, pr2, right_map):
    fmt, path = saved
    rmap = placement.open_map(path, "right", robot=pr2)
    meta = rmap.meta
    for key in META_KEYS:
        assert key in meta, f"metadata key '{key}' missing from the {fmt} map"
    assert meta["format_version"] == 1
    assert meta["robot"] == "pr2" and meta["urdf_sha256"] == pr2.urdf_sha256
    assert meta["arm"] == "right" and meta["base_frame"] == "base_footprint"
    assert meta["tip_frame"] == "r_gripper_tool_frame"
    assert meta["fixed_joints"] == {"torso_lift_joint": 0.15}
    assert meta["samples"] == 4000 and meta["seed"] == 2
    assert meta["measure"]["index"] == "isotropy" and meta["measure"]["rotation_scale"] == 0.15
    assert placement.Grid.from_dict(meta["grid"]) == right_map.grid
    assert meta["software"].startswith("placement ")
    assert isinstance(meta["build_time_s"], (int, float)) and meta["build_time_s"] >= 0
    np.testing.assert_allclose(meta["tcp_offset"], pr2.arm("right").tcp_offset)
    root = rmap.store.root
    assert root["complete"] is True and root["format_version"] == 1 and root["arms"] == ["right"]
    assert root["robot"] == "pr2" and root["urdf_sha256"] == pr2.urdf_sha256


@pytest.mark.parametrize("fmt", FORMATS)
def test_chunking_one_chunk_per_irm_slice(tmp_path, pr2, right_map, fmt):
    path = placement.save_maps(map_path(tmp_path, fmt), pr2, {"right": right_map}, fmt)
    nx, ny, _, n_yaw, _, _ = right_map.values.shape
    if fmt == "zarr":
        import zarr

        arr = zarr.open_group(str(path), mode="r")["right"]
        assert arr.chunks == (nx, ny, 1, n_yaw, 1, 1)
    else:
        with h5py.File(path, "r") as fh:
            assert fh["right"].chunks == (nx, ny, 1, n_yaw, 1, 1)
    rmap = placement.open_map(path, "right")
    np.testing.assert_array_equal(rmap.slice(2, 1, 3), right_map.values[:, :, 2, :, 1, 3])


@pytest.mark.parametrize("fmt", FORMATS)
def test_saving_another_arm_keeps_the_first(tmp_path, pr2, right_map, left_map, fmt):
    path = map_path(tmp_path, fmt)
    placement.save_maps(path, pr2, {"right": right_map}, fmt)
    placement.save_maps(path, pr2, {"left": left_map}, fmt)
    for arm, m in (("right", right_map), ("left", left_map)):
        rmap = placement.open_map(path, arm)
        np.testing.assert_array_equal(rmap.store.read_all(arm), m.values)
        rmap.verify()
    assert sorted(placement.open_map(path, "left").store.root["arms"]) == ["left", "right"]
    assert not list(tmp_path.glob(".*partial*")) and not list(tmp_path.glob(".*old*"))


# --------------------------------------------------------------------------------------------
# Bad input: clear MapError
# --------------------------------------------------------------------------------------------

def test_missing_path(tmp_path):
    with pytest.raises(MapError, match="no such map"):
        placement.open_map(tmp_path / "nothing_here", "right")


def test_directory_that_is_not_a_map(tmp_path):
    d = tmp_path / "photos"
    d.mkdir()
    (d / "a.txt").write_text("hello")
    with pytest.raises(MapError, match="not a reachability map"):
        placement.open_map(d, "right")
    f = tmp_path / "notes.txt"
    f.write_text("not hdf5")
    with pytest.raises(MapError, match="not a reachability map"):
        placement.open_map(f, "right")


def test_zarr_group_that_is_not_a_placement_map(tmp_path):
    import zarr

    g = zarr.open_group(str(tmp_path / "other"), mode="w", zarr_format=3)
    g.attrs["something"] = 1
    with pytest.raises(MapError, match="not a reachability map"):
        placement.open_map(tmp_path / "other", "right")
    bad = tmp_path / "garbage"
    bad.mkdir()
    (bad / "zarr.json").write_text("{ not json")
    with pytest.raises(MapError):
        placement.open_map(bad, "right")


def test_half_written_without_complete_flag(saved):
    fmt, path = saved
    set_root(path, fmt, lambda root: root.pop("complete"))
    with pytest.raises(MapError, match="half-written"):
        placement.open_map(path, "right")


def test_half_written_missing_chunks_zarr(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    files = zarr_chunk_files(path)
    assert len(files) > 3
    for f in files[::3]:
        f.unlink()
    with pytest.raises(MapError, match="chunks"):
        placement.open_map(path, "right")


def test_truncated_hdf5_file(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2.h5", pr2, {"right": right_map}, "hdf5")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(MapError):
        rmap = placement.open_map(path, "right")
        rmap.verify()


def _corrupt(data: bytes) -> bytes:
    """Overwrite a run of bytes after the header with a fixed pattern."""
    start = min(32, len(data) // 2)
    n = max(8, (len(data) - start) // 2)
    return data[:start] + bytes((i * 37 + 11) & 0xFF for i in range(n)) + data[start + n:]


def test_corrupted_chunk_zarr(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    f = max(zarr_chunk_files(path), key=lambda p: p.stat().st_size)  # a chunk with data
    f.write_bytes(_corrupt(f.read_bytes()))
    rmap = placement.open_map(path, "right")
    with pytest.raises(MapError, match="corrupt"):
        rmap.verify()
    # reading the damaged chunk: a MapError, or data that no longer matches (caught by verify above)
    parts = [int(x) for x in f.relative_to(path / "right" / "c").parts]
    iz, ip, ir = parts[2], parts[4], parts[5]
    _assert_slice_corrupt_or_changed(rmap, right_map, iz, ip, ir)


def _assert_slice_corrupt_or_changed(rmap, built, iz, ip, ir):
    """Reading a damaged chunk gives a MapError, or data that no longer matches (verify catches it)."""
    try:
        s = rmap.slice(iz, ip, ir)
    except MapError as exc:
        assert "corrupt" in str(exc)
    else:
        assert not np.array_equal(s, built.values[:, :, iz, :, ip, ir])


def test_truncated_chunk_zarr_fails_on_read(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    f = max(zarr_chunk_files(path), key=lambda p: p.stat().st_size)
    parts = [int(x) for x in f.relative_to(path / "right" / "c").parts]
    f.write_bytes(f.read_bytes()[:10])
    rmap = placement.open_map(path, "right")
    with pytest.raises(MapError, match="corrupt"):
        rmap.slice(parts[2], parts[4], parts[5])
    with pytest.raises(MapError, match="corrupt"):
        rmap.verify()


def test_corrupted_chunk_hdf5(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2.h5", pr2, {"right": right_map}, "hdf5")
    with h5py.File(path, "r") as fh:
        ds = fh["right"]
        infos = [ds.id.get_chunk_info(i) for i in range(ds.id.get_num_chunks())]
    info = max(infos, key=lambda c: c.size)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset)
        chunk = fh.read(info.size)
        fh.seek(info.byte_offset)
        fh.write(_corrupt(chunk))
    rmap = placement.open_map(path, "right")
    with pytest.raises(MapError, match="corrupt"):
        rmap.verify()
    _, _, iz, _, ip, ir = info.chunk_offset
    _assert_slice_corrupt_or_changed(rmap, right_map, iz, ip, ir)


def test_wrong_arm(saved):
    fmt, path = saved
    with pytest.raises(MapError, match="no map for arm 'left'.*right"):
        placement.open_map(path, "left")


def test_map_of_another_robot(tmp_path, armar6, pr2):
    m = placement.build_map(armar6, "left", samples=500, seed=1, progress=False, **SMALL)
    for fmt in FORMATS:
        path = placement.save_maps(map_path(tmp_path, fmt, "armar6"), armar6, {"left": m}, fmt)
        assert placement.open_map(path, "left").meta["robot"] == "armar6"  # opens with its own robot
        with pytest.raises(MapError, match="armar6.*pr2"):
            placement.open_map(path, "left", robot="pr2")
        with pytest.raises(MapError, match="armar6.*pr2"):
            placement.open_map(path, "left", robot=pr2)
        # and a PR2 map cannot be saved into the ARMAR-6 map
        pm = placement.build_map(pr2, "right", samples=200, seed=1, progress=False, **SMALL)
        before = placement.open_map(path, "left").store.read_all("left")
        with pytest.raises(MapError):
            placement.save_maps(path, pr2, {"right": pm}, fmt)
        np.testing.assert_array_equal(placement.open_map(path, "left").store.read_all("left"), before)


def test_map_of_another_urdf(saved, pr2):
    fmt, path = saved
    set_root(path, fmt, lambda root: root.update(urdf_sha256="0" * 64))
    with pytest.raises(MapError, match="URDF"):
        placement.open_map(path, "right", robot=pr2)


@pytest.mark.parametrize("version", [0, 2, 99, None, "1"])
def test_wrong_format_version(saved, version):
    fmt, path = saved
    set_root(path, fmt, lambda root: root.update(format_version=version))
    with pytest.raises(MapError, match="format version"):
        placement.open_map(path, "right")


def test_wrong_format_name(tmp_path, pr2, right_map):
    with pytest.raises(MapError, match="zarr.*hdf5|hdf5.*zarr"):
        placement.save_maps(tmp_path / "x", pr2, {"right": right_map}, "parquet")


# --------------------------------------------------------------------------------------------
# Atomic writes
# --------------------------------------------------------------------------------------------

class Interrupted(Exception):
    pass


class FailingZarr(ZarrBackend):
    """Writes the first arm completely, then dies while writing the second."""

    def __init__(self, exc):
        self.exc = exc

    def write(self, path, root, arms):
        first = dict(list(arms.items())[:1])
        super().write(path, {**root, "arms": sorted(first)}, first)
        assert (Path(path) / "zarr.json").is_file()  # something really was written
        raise self.exc


@pytest.mark.parametrize("exc", [Interrupted("disk full"), KeyboardInterrupt()], ids=["error", "ctrl-c"])
def test_atomic_replace_keeps_old_map(tmp_path, pr2, right_map, left_map, exc):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    before = snapshot(path)
    root = {"format_version": 1, "preset": "pr2", **pr2.fingerprint, "arms": ["left", "right"]}
    arms = {"left": (left_map.values, left_map.meta), "right": (right_map.values, right_map.meta)}
    with pytest.raises(type(exc)):
        atomic_replace(FailingZarr(exc), path, root, arms)
    assert snapshot(path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pr2"], "partial or backup directory left behind"
    rmap = placement.open_map(path, "right")
    np.testing.assert_array_equal(rmap.store.read_all("right"), right_map.values)
    rmap.verify()
    with pytest.raises(MapError, match="no map for arm 'left'"):
        placement.open_map(path, "left")


def test_atomic_replace_fresh_target_leaves_nothing(tmp_path, pr2, right_map):
    root = {"format_version": 1, "preset": "pr2", **pr2.fingerprint, "arms": ["right"]}
    with pytest.raises(Interrupted):
        atomic_replace(FailingZarr(Interrupted("boom")), tmp_path / "new", root,
                       {"right": (right_map.values, right_map.meta), "x": (right_map.values, right_map.meta)})
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(MapError, match="no such map"):
        placement.open_map(tmp_path / "new", "right")


@pytest.mark.parametrize("fmt", FORMATS)
def test_refuses_to_overwrite_a_plain_directory(tmp_path, pr2, right_map, fmt):
    d = tmp_path / "precious"
    (d / "sub").mkdir(parents=True)
    (d / "thesis.tex").write_text("years of work")
    (d / "sub" / "data.bin").write_bytes(os.urandom(100))
    before = snapshot(d)
    with pytest.raises(MapError, match="not a map"):
        placement.save_maps(d, pr2, {"right": right_map}, fmt)
    assert snapshot(d) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["precious"]


@pytest.mark.parametrize("fmt", FORMATS)
def test_refuses_to_overwrite_a_plain_file(tmp_path, pr2, right_map, fmt):
    f = tmp_path / "notes.txt"
    f.write_text("keep me")
    with pytest.raises(MapError):
        placement.save_maps(f, pr2, {"right": right_map}, fmt)
    assert f.read_text() == "keep me"


def test_refuses_to_replace_a_map_of_the_other_format(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "m", pr2, {"right": right_map}, "zarr")
    with pytest.raises(MapError, match="zarr"):
        placement.save_maps(path, pr2, {"right": right_map}, "hdf5")
    placement.open_map(path, "right").verify()


def test_overwriting_a_half_written_map_works(tmp_path, pr2, right_map):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    set_root(path, "zarr", lambda root: root.pop("complete"))
    shutil.rmtree(path / "right" / "c" / "0" / "0" / "1", ignore_errors=True)
    placement.save_maps(path, pr2, {"right": right_map}, "zarr")
    rmap = placement.open_map(path, "right")
    rmap.verify()
    np.testing.assert_array_equal(rmap.store.read_all("right"), right_map.values)


def test_atomic_replace_restores_old_map_if_the_final_rename_fails(tmp_path, pr2, right_map, left_map, monkeypatch):
    """Die between moving the old map aside and moving the new one in: the old map comes back."""
    import placement.storage.base as base

    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    before = snapshot(path)
    real_replace = os.replace

    def flaky_replace(src, dst):
        if Path(src).name.startswith(".pr2.partial"):
            raise Interrupted("power cut")
        return real_replace(src, dst)

    monkeypatch.setattr(base.os, "replace", flaky_replace)
    root = {"format_version": 1, "preset": "pr2", **pr2.fingerprint, "arms": ["left"]}
    with pytest.raises(Interrupted):
        atomic_replace(backend("zarr"), path, root, {"left": (left_map.values, left_map.meta)})
    monkeypatch.undo()
    assert snapshot(path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pr2"]
    placement.open_map(path, "right").verify()


@pytest.mark.parametrize("position", [20, 40, -5, -1])
def test_single_bit_flip_in_a_zarr_chunk_is_detected(tmp_path, pr2, right_map, position):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    f = max(zarr_chunk_files(path), key=lambda p: p.stat().st_size)
    data = bytearray(f.read_bytes())
    data[position] ^= 0x10
    f.write_bytes(bytes(data))
    with pytest.raises(MapError, match="corrupt"):
        placement.open_map(path, "right").verify()


@pytest.mark.parametrize("fmt", FORMATS)
def test_data_changed_behind_the_maps_back_fails_checksum(tmp_path, pr2, right_map, fmt):
    """A chunk that still decodes but holds other data (bit rot, a stray writer) fails verify()."""
    path = placement.save_maps(map_path(tmp_path, fmt), pr2, {"right": right_map}, fmt)
    idx = np.unravel_index(int(np.flatnonzero(right_map.values)[0]), right_map.values.shape)
    if fmt == "zarr":
        import zarr

        arr = zarr.open_group(str(path), mode="r+")["right"]
        arr[idx] = arr[idx] + np.float32(0.5)
    else:
        with h5py.File(path, "r+") as fh:
            fh["right"][idx] = fh["right"][idx] + np.float32(0.5)
    rmap = placement.open_map(path, "right")
    assert rmap.value(right_map.grid.centre([np.ravel_multi_index(idx, right_map.values.shape)]))[0] != \
        right_map.values[idx]
    with pytest.raises(MapError, match="checksum"):
        rmap.verify()
