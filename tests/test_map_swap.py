"""A long-lived planner whose maps are rebuilt under it (a build renames a new map over the old, as
`maps build` does): it reopens them and plans as a fresh planner on the new maps, never calling a
sound map corrupt; a map swapped for something unreadable is refused in one line naming the path."""

from __future__ import annotations

import shutil

import pytest
from support.planning import write_scene
from support.plans import strip_timings

import placement
from placement.errors import MapError
from placement.planning import Planner
from placement.storage import map_identity

pytestmark = pytest.mark.slow


def build(robot, path, seed):
    built = {
        arm: placement.build_map(
            robot, arm, samples=150_000, seed=seed, resolution=0.1, bins=(10, 5, 10), progress=False
        )
        for arm in ("right", "left")
    }
    placement.save_maps(path, robot, built)


def plain(result):
    return strip_timings(result.to_json())


@pytest.fixture(scope="module")
def rebuilt(pr2, tmp_path_factory):
    """A map folder, and a second map of other samples to swap in."""
    root = tmp_path_factory.mktemp("swap")
    build(pr2, root / "a" / "pr2", seed=1)
    build(pr2, root / "b" / "pr2", seed=2)
    return root


def test_a_rebuilt_map_is_reopened_and_planned_on(rebuilt, tmp_path):
    live_maps = tmp_path / "maps" / "pr2"
    shutil.copytree(rebuilt / "a" / "pr2", live_maps)
    scene = write_scene(tmp_path, live_maps)
    planner = Planner(scene)
    planner.plan()
    before = map_identity(live_maps)
    # the rebuild: a new map renamed over the old one
    staged = tmp_path / "maps" / ".staged"
    shutil.copytree(rebuilt / "b" / "pr2", staged)
    shutil.rmtree(live_maps)
    staged.rename(live_maps)
    assert map_identity(live_maps) != before
    report = planner.update({"start": [1.2, 4.0, 0.0]})
    assert report["maps"] == "reopened" and planner.maps_reopened == 1
    fresh = Planner(planner.scene)
    assert plain(planner.plan()) == plain(fresh.plan())
    assert planner.maps_reopened == 1  # once: the identity is the new map's now
    assert planner.update({"start": [1.0, 4.0, 0.0]}).get("maps") is None


def test_a_map_swapped_for_junk_is_refused_naming_the_path(rebuilt, tmp_path):
    live_maps = tmp_path / "maps" / "pr2"
    shutil.copytree(rebuilt / "a" / "pr2", live_maps)
    planner = Planner(write_scene(tmp_path, live_maps))
    shutil.rmtree(live_maps)
    live_maps.mkdir()
    (live_maps / "zarr.json").write_text("{not json")
    with pytest.raises(MapError) as err:
        planner.plan()
    text = str(err.value)
    assert f"the maps at {live_maps} changed since this planner opened them and cannot be opened again" in text
    assert "\n" not in text
