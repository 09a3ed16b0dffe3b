"""Map writes are atomic, and never overwrite what is not a map of the same robot and format."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from support.storage import FORMATS, set_root, snapshot

import placement
from placement import MapError
from placement.storage import backend
from placement.storage.base import atomic_replace
from placement.storage.format import FORMAT_VERSION
from placement.storage.zarr import ZarrBackend


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


@pytest.mark.slow
@pytest.mark.parametrize("exc", [Interrupted("disk full"), KeyboardInterrupt()], ids=["error", "ctrl-c"])
def test_atomic_replace_keeps_old_map(tmp_path, pr2, right_map, left_map, exc):
    path = placement.save_maps(tmp_path / "pr2", pr2, {"right": right_map}, "zarr")
    before = snapshot(path)
    root = {"format_version": FORMAT_VERSION, "preset": "pr2", **pr2.fingerprint, "arms": ["left", "right"]}
    arms = {
        "left": (left_map.values, left_map.meta, left_map.witness),
        "right": (right_map.values, right_map.meta, right_map.witness),
    }
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
    root = {"format_version": FORMAT_VERSION, "preset": "pr2", **pr2.fingerprint, "arms": ["right"]}
    with pytest.raises(Interrupted):
        atomic_replace(
            FailingZarr(Interrupted("boom")),
            tmp_path / "new",
            root,
            {
                "right": (right_map.values, right_map.meta, right_map.witness),
                "x": (right_map.values, right_map.meta, right_map.witness),
            },
        )
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
    root = {"format_version": FORMAT_VERSION, "preset": "pr2", **pr2.fingerprint, "arms": ["left"]}
    with pytest.raises(Interrupted):
        atomic_replace(backend("zarr"), path, root, {"left": (left_map.values, left_map.meta, left_map.witness)})
    monkeypatch.undo()
    assert snapshot(path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pr2"]
    placement.open_map(path, "right").verify()
