"""Planner.replace_scene: a new scene over the open robot and maps plans exactly as a new planner of
it does, and a scene it cannot take changes nothing."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from support.plans import strip_timings

from placement.errors import PlacementError
from placement.planning import Planner
from placement.scene import load_scene

ARENA = Path(__file__).resolve().parents[1] / "examples" / "buildings" / "wrs_arena" / "tidy_up.yaml"


def plain(result):
    return strip_timings(result.to_json())


def test_a_replaced_scene_plans_as_a_new_planner_of_it(maps_dir):
    live = Planner(ARENA, "global", maps_dir)
    live.plan()
    scene = load_scene(ARENA)
    mug = next(o for o in scene.objects if o.name == "mug")
    moved = dataclasses.replace(
        scene,
        objects=tuple(
            dataclasses.replace(o, position=o.position + [0.1, 0, 0]) if o is mug else o for o in scene.objects
        ),
        start=(1.0, 0.6, 0.0),
    )
    assert live.serves(moved, maps_dir)
    maps = dict(live.maps)
    live.replace_scene(moved)
    assert all(live.maps[a] is maps[a] for a in maps)  # the open maps are kept
    assert plain(live.plan()) == plain(Planner(moved, "global", maps_dir).plan())


def test_a_scene_of_another_robot_is_refused_and_changes_nothing(maps_dir):
    live = Planner(ARENA, "global", maps_dir)
    before = plain(live.plan())
    other = dataclasses.replace(load_scene(ARENA), robot_preset="tiago")
    assert not live.serves(other, maps_dir)
    with pytest.raises(PlacementError, match="scene for robot 'tiago', but this planner's maps are of 'pr2'"):
        live.replace_scene(other)
    assert plain(live.plan()) == before
