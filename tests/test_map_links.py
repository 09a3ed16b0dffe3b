"""A map path that is a symbolic link is followed: the real map is replaced, the link kept, and a
message names the user's path and where it leads (placement/storage/output.py)."""

from __future__ import annotations

import os

import pytest

import placement
from placement import MapError


def test_a_save_through_a_link_replaces_the_real_map_and_keeps_the_link(tmp_path, pr2, right_map, left_map):
    real = tmp_path / "real" / "pr2"
    placement.save_maps(real, pr2, {"right": right_map})
    link = tmp_path / "maps"
    link.symlink_to(real, target_is_directory=True)
    placement.save_maps(link, pr2, {"left": left_map})
    assert link.is_symlink() and os.path.realpath(link) == str(real)
    for arm in ("right", "left"):
        placement.open_map(real, arm).verify()
        placement.open_map(link, arm).verify()
    assert sorted(p.name for p in real.parent.iterdir()) == ["pr2"]  # no .old or .partial left
    assert sorted(p.name for p in tmp_path.iterdir()) == ["maps", "real"]


def test_a_dangling_link_is_written_where_it_points(tmp_path, pr2, right_map):
    (tmp_path / "there").mkdir()
    link = tmp_path / "maps"
    link.symlink_to(tmp_path / "there" / "pr2")
    placement.save_maps(link, pr2, {"right": right_map})
    assert link.is_symlink()
    placement.open_map(tmp_path / "there" / "pr2", "right").verify()


def test_a_link_to_something_else_is_refused_naming_the_link(tmp_path, pr2, right_map):
    (tmp_path / "notes.txt").write_text("keep")
    link = tmp_path / "maps"
    link.symlink_to(tmp_path / "notes.txt")
    with pytest.raises(MapError, match=r"maps \(a link to .*notes\.txt\) exists and is not a map"):
        placement.save_maps(link, pr2, {"right": right_map})
    assert (tmp_path / "notes.txt").read_text() == "keep" and link.is_symlink()
