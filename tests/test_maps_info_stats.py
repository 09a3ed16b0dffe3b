"""The fill and value statistics a map stores when it is saved, and `placement maps info`, which answers from
them (a map saved without them: by reading every chunk; --full: reading and comparing)."""

from __future__ import annotations

import json
import math

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from support.cli import run
from support.pitch_torso import JOINT as TOY_JOINT
from support.pitch_torso import write_pitch_torso
from support.storage import FORMATS, map_path

import placement
from placement import MapError
from placement.cli.main import cli
from placement.maps.buildspec import TorsoSpec
from placement.maps.torso_builds import build_torso_maps
from placement.storage import open_store
from placement.storage.digest import DIGEST_KEY, document_digest
from placement.storage.format import ROOT_KEY

KEY = "value_stats"
#: the histogram bins `maps info` has always shown (dimensionless map values; the last bin holds 1.0)
EDGES = [0.0, 0.01, 0.0235, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0]


def reference(values: np.ndarray) -> dict:
    """The statistics of a 6D values array by plain numpy over the whole array: bins counted one by one."""
    v = np.asarray(values, dtype=np.float64).ravel()
    reached = v[v > 0]
    counts = [
        int(np.count_nonzero((reached >= lo) & ((reached < hi) if hi != EDGES[-1] else (reached <= hi))))
        for lo, hi in zip(EDGES, EDGES[1:])
    ]
    return {
        "cells": v.size,
        "filled_cells": reached.size,
        "max": float(reached.max()) if reached.size else 0.0,
        "mean": float(math.fsum(reached) / reached.size) if reached.size else 0.0,
        "counts": counts,
    }


def assert_matches(stats: dict, ref: dict) -> None:
    """A statistics record (stored, or info's arm entry) against :func:`reference`."""
    assert stats["cells"] == ref["cells"]
    assert stats["filled_cells"] == ref["filled_cells"] > 0
    assert stats["fill_ratio"] == pytest.approx(ref["filled_cells"] / ref["cells"], rel=1e-15)
    assert stats["value"]["max"] == ref["max"]
    assert stats["value"]["mean"] == pytest.approx(ref["mean"], rel=1e-12)
    assert stats["value"]["histogram"] == {"edges": EDGES, "counts": ref["counts"]}


def edit_arm_meta(path, fmt: str, arm: str, edit) -> None:
    """Apply ``edit(meta)`` to the stored metadata of array ``arm`` and reseal its digest, as if the map had
    been written so (by another software version, or a writer with a bug)."""
    if fmt == "zarr":
        import zarr

        group = zarr.open_group(str(path), mode="r+")
        meta = dict(group[arm].attrs.asdict())
        edit(meta)
        group[arm].attrs.put(meta)
        meta = dict(zarr.open_group(str(path), mode="r")[arm].attrs.asdict())
        root = dict(group.attrs[ROOT_KEY])
        root[DIGEST_KEY]["arms"][arm] = document_digest(meta)
        group.attrs[ROOT_KEY] = root
    else:
        with h5py.File(path, "r+") as fh:
            meta = json.loads(fh[arm].attrs["meta"])
            edit(meta)
            fh[arm].attrs["meta"] = json.dumps(meta)
            root = json.loads(fh.attrs[ROOT_KEY])
            root[DIGEST_KEY]["arms"][arm] = document_digest(json.loads(fh[arm].attrs["meta"]))
            fh.attrs[ROOT_KEY] = json.dumps(root)


def stored_meta(path, arm: str) -> dict:
    store = open_store(path)
    try:
        return store.arm_meta(arm)
    finally:
        store.close()


def info(path, *extra):
    result = CliRunner().invoke(cli, ["maps", "info", str(path), "--json", "-q", *extra], catch_exceptions=False)
    assert result.exit_code == 0, result.output[-2000:]
    return json.loads(result.stdout)


@pytest.fixture(scope="module", params=FORMATS)
def saved(request, pr2, right_map, left_map, tmp_path_factory):
    """A sound two-arm map of each format (copied by the tests that change it)."""
    fmt = request.param
    path = map_path(tmp_path_factory.mktemp(f"stats-{fmt}"), fmt)
    return fmt, placement.save_maps(path, pr2, {"right": right_map, "left": left_map}, fmt)


def copy(src, tmp_path):
    import shutil

    dst = tmp_path / src.name
    (shutil.copytree if src.is_dir() else shutil.copyfile)(src, dst)
    return dst


@pytest.mark.slow
def test_saved_maps_store_the_statistics_of_their_arrays(saved):
    _, path = saved
    for arm in ("right", "left"):
        stored = stored_meta(path, arm)[KEY]
        assert_matches(stored, reference(placement.open_map(path, arm).values))


def test_info_answers_from_the_stored_statistics(saved):
    _, path = saved
    doc = info(path)
    for arm in ("right", "left"):
        entry = doc["arms"][arm]
        assert entry["stats_from"] == "stored" and entry["chunks_checked"] == 0
        assert_matches(entry, reference(placement.open_map(path, arm).values))
        assert KEY not in entry["meta"] and "chunk_crc32" not in entry["meta"]


def test_full_reads_every_chunk_and_agrees(saved):
    _, path = saved
    doc = info(path, "--full")
    for arm in ("right", "left"):
        entry = doc["arms"][arm]
        shape = placement.open_map(path, arm).grid.shape
        assert entry["stats_from"] == "read"
        assert entry["chunks_checked"] == 2 * shape[2] * shape[4] * shape[5]  # values and witnesses
        assert_matches(entry, reference(placement.open_map(path, arm).values))


@pytest.mark.slow
def test_a_map_saved_without_statistics_is_read_with_a_note(saved, tmp_path):
    fmt, src = saved
    path = copy(src, tmp_path)
    for arm in ("right", "left"):
        edit_arm_meta(path, fmt, arm, lambda m: m.pop(KEY))
        assert KEY not in stored_meta(path, arm)
    proc = run("maps", "info", str(path), "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    want = info(src)
    for arm in ("right", "left"):
        entry = doc["arms"][arm]
        assert entry["stats_from"] == "read" and entry["chunks_checked"] > 0
        for key in ("cells", "filled_cells", "fill_ratio", "value"):
            assert entry[key] == want["arms"][arm][key], key
    notes = [ln for ln in proc.stderr.splitlines() if ln.startswith("note:")]
    assert len(notes) == 2 and all("no stored statistics" in n for n in notes), proc.stderr
    assert {"'right'", "'left'"} == {w for n in notes for w in n.split() if w in ("'right'", "'left'")}


def test_full_names_the_arm_whose_stored_histogram_was_changed(saved, tmp_path):
    fmt, src = saved
    path = copy(src, tmp_path)

    def tamper(meta):
        counts = meta[KEY]["value"]["histogram"]["counts"]
        counts[1], counts[2] = counts[1] + 1, counts[2] - 1  # the total stays: only the bins can tell
        assert counts[2] >= 0

    edit_arm_meta(path, fmt, "left", tamper)
    assert info(path)["arms"]["left"]["stats_from"] == "stored"  # without --full nothing is read
    result = CliRunner().invoke(cli, ["maps", "info", str(path), "--full", "-q"], catch_exceptions=False)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    assert "array 'left'" in lines[0] and "value.histogram.counts" in lines[0], lines[0]


def test_malformed_stored_statistics_are_refused_naming_the_key(saved, tmp_path):
    fmt, src = saved
    path = copy(src, tmp_path)
    edit_arm_meta(path, fmt, "right", lambda m: m[KEY]["value"]["histogram"]["counts"].pop())
    with pytest.raises(MapError, match=r"arm 'right': value_stats\.value\.histogram\.counts: expected 8 counts"):
        placement.open_map(path, "right")


def test_saving_beside_an_arm_without_statistics_gives_it_them(pr2, right_map, left_map, tmp_path):
    path = placement.save_maps(tmp_path / "m", pr2, {"right": right_map})
    edit_arm_meta(path, "zarr", "right", lambda m: m.pop(KEY))
    placement.save_maps(path, pr2, {"left": left_map})
    for arm, m in (("right", right_map), ("left", left_map)):
        assert_matches(stored_meta(path, arm)[KEY], reference(m.values))


@pytest.mark.slow
def test_every_torso_setting_array_stores_its_own_statistics(tmp_path):
    robot = placement.load_robot(write_pitch_torso(tmp_path / "robot"))
    built = build_torso_maps(
        robot, "arm", torso=TorsoSpec(TOY_JOINT, (0.3, 0.8)), samples=5_000, resolution=0.25, bins=(4, 3, 4)
    )
    path = placement.save_maps(tmp_path / "m", robot, built)
    assert len(built) == 3
    for name, m in built.items():
        assert_matches(stored_meta(path, name)[KEY], reference(m.values))
    doc = info(path)["arms"]["arm"]
    assert doc["stats_from"] == "stored" and all(s["stats_from"] == "stored" for s in doc["settings"])
    assert {s["array"]: s["filled_cells"] for s in doc["settings"]} | {"arm": doc["filled_cells"]} == {
        name: int(np.count_nonzero(m.values)) for name, m in built.items()
    }
