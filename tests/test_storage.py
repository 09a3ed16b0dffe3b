"""Map storage (Zarr v3 and HDF5): round trip, metadata, validation and atomic writes (docs/maps.md)."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from support.storage import FORMATS, SMALL, filled_cell_poses, map_path, set_root, zarr_chunk_files

import placement
from placement import MapError
from placement.storage.format import FORMAT_VERSION

META_KEYS = (
    "format_version",
    "robot",
    "urdf_sha256",
    "arm",
    "base_frame",
    "tip_frame",
    "grid",
    "measure",
    "samples",
    "seed",
    "build_time_s",
    "software",
)


@pytest.fixture(params=FORMATS)
def saved(request, tmp_path, pr2, right_map):
    """(format, path) of a freshly saved PR2 right-arm map."""
    fmt = request.param
    path = placement.save_maps(map_path(tmp_path, fmt), pr2, {"right": right_map}, fmt)
    return fmt, Path(path)


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
    assert meta["format_version"] == FORMAT_VERSION == 4
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
    assert root["complete"] is True and root["format_version"] == FORMAT_VERSION and root["arms"] == ["right"]
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


def test_slices_read_together_are_the_slices(saved, right_map):
    """read_slices (the chunk threads) caches what slice() reads, values and witnesses, in either backend."""
    _, path = saved
    g = right_map.grid.shape
    keys = [(z, p, r) for z in range(g[2]) for p in range(g[4]) for r in range(0, g[5], 3)]
    together = placement.open_map(path, "right")
    together.read_slices(keys)
    together.read_slices(keys[:3], witness=True)
    one = placement.open_map(path, "right")
    for iz, ip, ir in keys:
        got = together._slices[(iz, ip, ir)]  # read by read_slices, not by slice() below
        np.testing.assert_array_equal(got, right_map.values[:, :, iz, :, ip, ir])
        assert together.slice(iz, ip, ir) is got
    for key in keys[:3]:
        np.testing.assert_array_equal(together._witness_slices[key], one.witness_slice(*key))


def test_zarr_reads_the_chunks_written_directly_as_its_own(tmp_path, pr2, right_map):
    """A map's chunks are written without zarr (placement.storage.zarr.write_chunks): zarr reads the
    values and witnesses back equal to what was saved, and the same arrays written by zarr itself
    store the same chunk files (no chunk of fill values) with the same decoded bytes."""
    import zarr
    from zarr.codecs import BloscCodec, Crc32cCodec

    from placement.storage.zarr import write_chunks

    path = placement.save_maps(map_path(tmp_path, "zarr"), pr2, {"right": right_map}, "zarr")
    group = zarr.open_group(str(path), mode="r")
    np.testing.assert_array_equal(group["right"][...], right_map.values)
    witness = group["right.witness"][...]
    np.testing.assert_array_equal(witness, placement.open_map(path, "right").witness)
    values = right_map.values.copy()
    values[:, :, 1] = 0.0  # a layer of fill chunks: stored by neither
    mine = zarr.open_group(str(tmp_path / "mine"), mode="w", zarr_format=3)
    theirs = zarr.open_group(str(tmp_path / "theirs"), mode="w", zarr_format=3)
    for group_, name in ((mine, "mine"), (theirs, "theirs")):
        arr = group_.create_array(
            "a",
            shape=values.shape,
            dtype="float32",
            chunks=group["right"].chunks,
            compressors=[BloscCodec(cname="zstd", clevel=3, shuffle="shuffle"), Crc32cCodec()],
            fill_value=0.0,
        )
        if name == "theirs":
            arr[...] = values
        else:
            write_chunks(tmp_path / "mine" / "a", values, 0.0)
    files = [
        sorted(p.relative_to(tmp_path / n) for p in (tmp_path / n / "a" / "c").rglob("*") if p.is_file())
        for n in ("mine", "theirs")
    ]
    assert files[0] == files[1] and len(files[0]) < values.shape[2] * values.shape[4] * values.shape[5]
    np.testing.assert_array_equal(zarr.open_group(str(tmp_path / "mine"), mode="r")["a"][...], values)


def test_a_failed_layer_leaves_no_writer_running():
    """each_of (the layer writes of a save) raises a layer's error only once no other layer runs: the
    caller then removes the half-written map, and no thread writes into it afterwards."""
    import threading
    import time

    from placement.storage.chunks import each_of

    running, ended = set(), []
    lock = threading.Lock()

    def task(iz: int) -> None:
        with lock:
            running.add(iz)
        try:
            if iz == 0:
                raise OSError("No space left on device")
            time.sleep(0.05)
        finally:
            with lock:
                running.discard(iz)
                ended.append(iz)

    with pytest.raises(OSError, match="No space left"):
        each_of(task, range(12))
    assert running == set() and 0 in ended and len(ended) == len(set(ended))
    done = len(ended)
    time.sleep(0.1)
    assert running == set() and len(ended) == done  # nothing started after the raise


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize("version", [0, 1, 2, 99, None, "3"])
def test_wrong_format_version(saved, version):
    fmt, path = saved
    set_root(path, fmt, lambda root: root.update(format_version=version))
    with pytest.raises(MapError, match="format version"):
        placement.open_map(path, "right")


def test_wrong_format_name(tmp_path, pr2, right_map):
    with pytest.raises(MapError, match="zarr.*hdf5|hdf5.*zarr"):
        placement.save_maps(tmp_path / "x", pr2, {"right": right_map}, "parquet")


def test_chunk_crcs_are_per_chunk():
    """The whole-array CRC table (used on save and by read_all) equals each chunk's own CRC (read_chunk)."""
    from placement.storage.format import chunk_crc, chunk_crcs

    values = np.random.default_rng(0).random((5, 4, 3, 4, 3, 2)).astype(np.float32)
    table = chunk_crcs(values)
    assert table.shape == (3, 3, 2) and table.dtype == np.uint32
    for iz, ip, ir in np.ndindex(*table.shape):
        assert table[iz, ip, ir] == chunk_crc(values[:, :, iz, :, ip, ir])
    assert len(set(table.ravel().tolist())) == table.size  # distinct data, distinct CRCs
