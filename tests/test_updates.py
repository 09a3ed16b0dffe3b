"""Dynamic updates (paper Table III): what a change keeps, all-or-nothing updates, the stream mode."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.planning import write_scene

import placement
from placement.planning import Planner, SceneError
from placement.planning.updates import parse_update


@pytest.fixture(scope="module")
def planner(tmp_path_factory, maps_dir):
    return Planner(write_scene(tmp_path_factory.mktemp("updates"), maps_dir))


def test_updates_redo_only_what_changed(tmp_path, maps_dir, pr2):
    planner = Planner(write_scene(tmp_path, maps_dir))
    first = planner.plan()
    assert first.ok
    # the cup's place poses follow how it is picked: a moved cup recomputes its pick and its place,
    # the box's steps are kept
    cached = [planner.problems.options(i) for i in range(4)]
    info = planner.update({"objects": [{"name": "cup", "position": [3.2, 2.5, 0.8]}]})
    assert info["updated"] == ["cup"]
    now = [planner.problems.options(i) for i in range(4)]
    assert [a is b for a, b in zip(now, cached)] == [False, False, True, True]
    moved = planner.plan()
    assert moved.ok
    assert moved.steps[0].tcp[-1][:2, 3] == pytest.approx([3.2, 2.5])
    # a crate on the chosen placement: the new plan avoids it
    x, y, _ = moved.steps[0].base
    planner.update({"obstacles": {"add": [{"name": "crate", "box": {"center": [x, y, 0.3], "size": [0.4, 0.4, 0.6]}}]}})
    again = planner.plan()
    assert again.ok
    assert math.hypot(again.steps[0].base[0] - x, again.steps[0].base[1] - y) > pr2.footprint_radius


@pytest.mark.parametrize(
    "change, message",
    [
        ({"colour": 1}, "unknown key 'colour'; allowed: objects, obstacles, start"),
        ({}, "an update must be a non-empty mapping"),
        ([1, 2], "an update must be a non-empty mapping"),
        ({"objects": None}, "objects: expected a list, got null"),
        ({"objects": [{"name": "mug", "yaw": 1.0}]}, "objects[0].name: unknown object 'mug'; objects: cup, box"),
        ({"objects": [{"yaw": 1.0}]}, "missing required key 'objects[0].name'"),
        ({"objects": [{"name": "cup", "position": [1, 2]}]}, "objects[0].position: expected 3 numbers, got 2"),
        ({"objects": [{"name": "cup", "position": [3.0, 2.5, 0.3]}]}, "object 'cup' is inside obstacle 'table'"),
        ({"objects": [{"name": "cup", "yaw": "north"}]}, "objects[0].yaw: expected a number"),
        ({"obstacles": {"add": None}}, "obstacles.add: expected a list, got null"),
        ({"obstacles": {"remove": [["x"]]}}, "obstacles.remove[0]: expected a non-empty string, got a list"),
        ({"obstacles": {"remove": ["wall"]}}, "obstacles.remove[0]: unknown obstacle 'wall'"),
        (
            {"obstacles": {"add": [{"name": "cup", "cylinder": {"center": [0, 0, 0], "radius": 1, "height": 1}}]}},
            "obstacles.add[0].name: duplicate name 'cup'",
        ),
        ({"obstacles": []}, "obstacles: expected a mapping, got a list"),
        ({"start": [1, 2]}, "start: expected 3 numbers, got 2"),
        ({"start": [100.0, 2.0, 0.0]}, "robot.start: the start position at (100, 2) is outside bounds"),
    ],
)
def test_bad_updates_are_one_line_and_change_nothing(planner, change, message):
    before = (planner.scene, planner.world, planner.problems)
    with pytest.raises(SceneError) as err:
        planner.update(change)
    assert message in str(err.value) and str(err.value).startswith("update: ") and "\n" not in str(err.value)
    assert (planner.scene, planner.world, planner.problems) == before


def test_failed_update_leaves_the_planner_as_it_was(tmp_path, maps_dir):
    """A change that fails halfway (a good object move, then a bad obstacle) applies nothing."""
    planner = Planner(write_scene(tmp_path, maps_dir))
    want = planner.plan().to_json()
    cup = planner.scene.object("cup")
    with pytest.raises(placement.PlacementError):
        planner.update({"objects": [{"name": "cup", "position": [3.2, 2.5, 0.8]}], "obstacles": {"remove": ["x"]}})
    assert planner.scene.object("cup") is cup
    got = planner.plan().to_json()
    for a, b in zip(got["steps"], want["steps"]):
        assert a["base"] == b["base"] and a["joints"] == b["joints"]


# A recursive strategy: the JSON values a stream line can hold.
_json = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.floats(allow_nan=True) | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=4)
        | st.dictionaries(
            st.sampled_from(
                [
                    "objects",
                    "obstacles",
                    "start",
                    "name",
                    "position",
                    "yaw",
                    "size",
                    "add",
                    "remove",
                    "box",
                    "cylinder",
                    "polygon",
                    "center",
                    "radius",
                    "height",
                    "table",
                    "x",
                ]
            ),
            children,
            max_size=4,
        )
    ),
    max_leaves=20,
)
_object_names = st.sampled_from(["cup", "box", "mug"])
_vec3 = st.lists(st.floats(-10, 10) | st.integers(-10, 10) | st.text(max_size=2), min_size=2, max_size=4)
_plausible = st.fixed_dictionaries(
    {},
    optional={
        "objects": st.lists(
            st.fixed_dictionaries(
                {"name": _object_names}, optional={"position": _vec3, "yaw": st.floats(-4, 4), "size": _vec3}
            ),
            max_size=2,
        ),
        "obstacles": st.fixed_dictionaries(
            {},
            optional={
                "remove": st.lists(st.sampled_from(["table", "shelf", "pillar", "cup"]) | _json, max_size=2),
                "add": st.lists(
                    st.fixed_dictionaries(
                        {"name": st.text(min_size=1, max_size=5)},
                        optional={
                            "box": st.fixed_dictionaries({"center": _vec3, "size": _vec3}),
                            "cylinder": st.fixed_dictionaries(
                                {"center": _vec3, "radius": st.floats(-1, 2), "height": st.floats(0, 2)}
                            ),
                            "polygon": st.lists(st.lists(st.floats(-1, 7), min_size=2, max_size=2), max_size=4),
                        },
                    ),
                    max_size=2,
                ),
            },
        ),
        "start": _vec3,
    },
)


@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(change=_json | _plausible)
def test_any_update_is_a_clean_error_or_a_valid_scene(planner, change):
    """Random and plausible-but-mutated update documents: SceneError or a valid scene, nothing else."""
    try:
        scene, moved, obstacles, _ = parse_update(change, planner.scene)
    except SceneError as exc:
        assert "\n" not in str(exc)
        return
    assert moved <= {"cup", "box"} and isinstance(obstacles, bool)
    assert {o.name for o in scene.objects} == {"cup", "box"}


@pytest.mark.slow
def test_stream_mode(tmp_path, maps_dir):
    deep = "[" * 100_000 + "]" * 100_000
    lines = (
        "\n".join(
            [
                '{"objects": [{"name": "cup", "yaw": 1.0}]}',
                "not json",
                '{"objects": null}',
                '{"obstacles": {"add": null}}',
                '{"obstacles": {"remove": [["x"]]}}',
                deep,
                '{"start": [1.5, 4.0, 0.0]}',
            ]
        )
        + "\n"
    )
    p = subprocess.run(
        [sys.executable, "-m", "placement.cli.main", "query", str(write_scene(tmp_path, maps_dir)), "--stream", "-q"],
        input=lines,
        capture_output=True,
        text=True,
        env=dict(os.environ),
    )
    assert p.returncode == 0, p.stderr
    out = [json.loads(x) for x in p.stdout.splitlines()]
    assert len(out) == 8 and out[0]["status"] == "ok" and out[1]["update"]["updated"] == ["cup"]
    assert all("error" in o for o in out[2:7]), out[2:7]
    assert out[7]["status"] == "ok" and out[7]["update"]["updated"] == ["start"]
    assert "Traceback" not in p.stderr


@pytest.mark.slow
@pytest.mark.parametrize(
    "change",
    [
        {"obstacles": {"add": [{"name": "crate", "box": {"center": [2.6, 2.5, 0.3], "size": [0.4, 0.6, 0.6]}}]}},
        {"obstacles": {"remove": ["shelf"]}},
        {
            "obstacles": {
                "remove": ["pillar"],
                "add": [{"name": "bin", "cylinder": {"center": [3.0, 1.6, 0.4], "radius": 0.25, "height": 0.8}}],
            }
        },
        {"objects": [{"name": "box", "position": [3.1, 2.6, 0.8]}]},
        {"objects": [{"name": "cup", "yaw": 1.2}], "start": [1.5, 4.2, 0.5]},
        {
            "obstacles": {
                "remove": ["shelf"],
                "add": [{"name": "shelf", "box": {"center": [1.3, 0.8, 0.375], "size": [0.6, 0.6, 0.75]}}],
            }
        },
    ],
)
def test_updates_equal_a_fresh_planner(tmp_path, maps_dir, change):
    """Refreshed IRMs (only cells whose feasibility changed), the incremental occupancy and the
    re-plan equal a planner built from scratch on the changed scene."""
    from placement.scene import scene_to_dict

    planner = Planner(write_scene(tmp_path, maps_dir))
    planner.plan()  # fills the caches
    planner.update(change)
    fresh = Planner(parse_update_scene(planner, tmp_path), maps=maps_dir)
    assert np.array_equal(planner.world.distance, fresh.world.distance)
    # the PR2's square footprint: the touched layer and every cell's allowed yaws too
    assert np.array_equal(planner.world.touched, fresh.world.touched)
    cells = np.arange(fresh.world.feasible.size)
    assert np.array_equal(planner.world.yaw_masks(cells), fresh.world.yaw_masks(cells))
    for i in range(len(planner.problems.steps)):
        for a, b in zip(planner.problems.options(i), fresh.problems.options(i)):
            assert (
                a.window == b.window and np.array_equal(a.value, b.value) and np.array_equal(a.yaw_index, b.yaw_index)
            )
    got, want = planner.plan().to_json(), fresh.plan().to_json()
    assert [s["base"] for s in got["steps"]] == [s["base"] for s in want["steps"]]
    assert [s["cost"] for s in got["steps"]] == [s["cost"] for s in want["steps"]]
    assert scene_to_dict(planner.scene) == scene_to_dict(fresh.scene)


def parse_update_scene(planner, tmp_path):
    from placement.planning import save_scene

    return save_scene(planner.scene, tmp_path / "changed.yaml")


def test_chained_obstacle_updates_before_a_plan_equal_a_fresh_planner(tmp_path, maps_dir):
    """IRMs are refreshed lazily: two obstacle changes in a row (no plan between) still refresh from
    the cells the maps were computed for."""
    planner = Planner(write_scene(tmp_path, maps_dir))
    planner.plan()
    planner.update({"obstacles": {"add": [{"name": "a", "box": {"center": [2.5, 2.5, 0.3], "size": [0.4, 0.4, 0.6]}}]}})
    planner.update(
        {
            "obstacles": {
                "remove": ["a", "shelf"],
                "add": [{"name": "b", "box": {"center": [3.6, 2.5, 0.3], "size": [0.4, 0.4, 0.6]}}],
            }
        }
    )
    fresh = Planner(parse_update_scene(planner, tmp_path), maps=maps_dir)
    for i in range(len(planner.problems.steps)):
        for a, b in zip(planner.problems.options(i), fresh.problems.options(i)):
            assert a.window == b.window and np.array_equal(a.value, b.value)
    assert [s.base for s in planner.plan().steps] == [s.base for s in fresh.plan().steps]


def test_an_update_of_obstacles_and_start_together_lists_both(pr2, tmp_path):
    """The report of one update names each kind of change: obstacles drawn into the old grid and a
    new start pose. (The obstacle diff once reused the name of the update's dict, so "start" was
    checked in the diff tuple and went missing.) The update returns a new state; the old is kept."""
    from placement.planning.context import PlanningContext
    from placement.planning.problems.cache import StepProblems
    from placement.planning.problems.manipulation import base_yaws
    from placement.planning.settings import PlannerConfig
    from placement.planning.updates import apply_update
    from placement.planning.world.footprints import BaseShape
    from placement.planning.world.layers import build_world
    from placement.scene import load_scene

    scene = load_scene(write_scene(tmp_path, tmp_path / "maps"))  # no maps: nothing here reads one
    cfg = PlannerConfig.from_overrides(scene.planner)
    yaws = base_yaws(cfg.yaw_steps)
    world = build_world(scene, BaseShape.of(pr2, cfg.footprint_padding, yaws), cfg)
    ctx = PlanningContext(scene, pr2, {}, world, StepProblems(scene, world, {}, cfg, yaws), cfg, yaws)
    crate = {"name": "crate", "box": {"center": [5.5, 0.5, 0.3], "size": [0.2, 0.2, 0.6]}}
    new, info = apply_update(ctx, {"obstacles": {"add": [crate]}, "start": [1.5, 4.0, 0.0]})
    assert info["updated"] == ["obstacles", "start"]
    assert new.scene.start == (1.5, 4.0, 0.0) and "crate" in {o.name for o in new.scene.obstacles}
    assert new.world is not world and new.world.occupied.sum() > world.occupied.sum()
    assert ctx.scene is scene and ctx.world is world and scene.start == (1.0, 4.0, 0.0)
    new, info = apply_update(new, {"obstacles": {"remove": ["crate"]}, "start": [1.5, 4.1, 0.0]})
    assert info["updated"] == ["obstacles", "start"]
    assert np.array_equal(new.world.occupied, world.occupied)
