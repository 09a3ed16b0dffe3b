"""Plans on real building maps (examples/buildings: SLAM maps as their teams published them, tables at
their named locations): every step planned by the default method and `sequential`, each plan checked
by FK and against the map independently (no base footprint on a cell the map marks)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support.map_check import footprint_on_map

from placement.planning import Planner
from placement.planning.task_time import task_time

BUILDINGS = sorted((Path(__file__).resolve().parents[1] / "examples" / "buildings").glob("*/tidy_up.yaml"))


@pytest.fixture(scope="module")
def plans(maps_dir):
    out = {}
    for path in BUILDINGS:
        for method in ("global", "sequential"):
            planner = Planner(path, method, maps_dir)
            out[path.parent.name, method] = (planner, planner.plan())
    return out


@pytest.mark.slow
@pytest.mark.parametrize("path", BUILDINGS, ids=lambda p: p.parent.name)
@pytest.mark.parametrize("method", ["global", "sequential"])
def test_every_step_plans_and_holds(plans, path, method):
    planner, result = plans[path.parent.name, method]
    assert result.ok, result.failed_step
    assert result.verify(planner.robot, scene=planner.scene) == []
    for step in result.steps:
        assert footprint_on_map(planner, step.base) == [], (step.step, step.base)


@pytest.mark.parametrize("path", BUILDINGS, ids=lambda p: p.parent.name)
def test_the_default_takes_no_longer_than_sequential(plans, path):
    times = {}
    for method in ("global", "sequential"):
        planner, result = plans[path.parent.name, method]
        times[method] = task_time(planner.robot, result, planner.scene.start)["total_s"]
    assert times["global"] <= times["sequential"], times


def test_rooms_plan_on_a_window_of_the_map(plans):
    """The lab and the arena are planned on windows around their tasks (a fraction of the maps' cells)."""
    for name in ("brsu_home_lab", "wrs_arena"):
        planner, _ = plans[name, "global"]
        ny, nx = planner.scene.grid_shape
        wy, wx = planner.world.nav.shape
        assert planner.world.window is not None and wy * wx < 0.6 * ny * nx, name


def walled_scene(
    place_table: tuple[tuple[float, float], tuple[float, float]], spot: tuple[float, float], walls, height
):
    """A cup on a pick table in the open, to be set down at ``spot`` on a place table ((x, y) centre,
    (sx, sy) size [m]), with walls ``height`` [m] tall (((x, y) centre, (sx, sy) size) each)."""
    from placement.scene import parse_scene

    (px, py), (psx, psy) = place_table
    return parse_scene(
        {
            "version": 1,
            "bounds": [-1.0, -1.0, 8.0, 6.0],
            "robot": {"preset": "pr2", "start": [1.0, 1.0, 0.0]},
            "obstacles": [
                {"name": "pick_table", "box": {"center": [1.5, 3.5, 0.36], "size": [0.8, 0.6, 0.72]}, "table": True},
                {"name": "place_table", "box": {"center": [px, py, 0.36], "size": [psx, psy, 0.72]}, "table": True},
            ]
            + [
                {"name": f"wall_{i}", "box": {"center": [x, y, height / 2], "size": [sx, sy, height]}}
                for i, ((x, y), (sx, sy)) in enumerate(walls)
            ],
            "objects": [{"name": "cup", "position": [1.5, 3.35, 0.77], "size": [0.06, 0.06, 0.1]}],
            "place_locations": [{"name": "spot", "position": [*spot, 0.8]}],
            "task": [{"pick": "cup", "place": "spot"}],
        }
    )


def pocket_scene():
    """A pick table and a place table 3 m apart; behind the place table a pocket of floor closed by
    knee-high walls (the base cannot get in, the arm reaches over them): the place step's feasible
    region has a part there that no base can drive to."""
    wall = 0.1
    walls = [  # the pocket: x 4.4 .. 6.0, y 2.35 .. 4.0, the place table its south side
        ((5.2, 4.0 + wall / 2), (1.6 + 2 * wall, wall)),
        ((4.4 - wall / 2, 3.2), (wall, 1.7)),
        ((6.0 + wall / 2, 3.2), (wall, 1.7)),
    ]
    return walled_scene(((5.2, 2.0), (1.6, 0.7)), (5.2, 2.1), walls, 0.3)


def test_sequential_plans_beside_floor_the_base_cannot_reach(maps_dir):
    """The next-step heuristic weighs only regions the base can reach: with the pocket's region in
    it, every cost was infinite and `sequential` called the pick infeasible."""
    from placement.planning.world.navigation import reachable_from

    planner = Planner(pocket_scene(), "sequential", maps_dir)
    world, problems = planner.world, planner.problems
    pocket = world.feasible & ~problems.reachable
    assert pocket[world.nav.cell(5.2, 3.2)]
    assert (problems.feasible_region(1) & pocket).any()  # the place can be reached from the pocket
    np.testing.assert_array_equal(problems.reachable, reachable_from(world.feasible, world.nav, 1.0, 1.0))
    result = planner.plan()
    assert result.ok, result.failed_step
    assert result.verify(planner.robot, scene=planner.scene) == []
    assert np.isfinite(problems.heuristic(1)[world.nav.cell(*result.steps[0].base[:2])])


def closed_room_scene():
    """A pick table in the open and a place table inside a room closed by walls 2 m high (no door):
    the maps keep the threshold only on floor inside the room, which no base can drive to."""
    t = 0.1
    walls = [((5.0, 1.0), (3.0 + t, t)), ((5.0, 4.0), (3.0 + t, t)), ((3.5, 2.5), (t, 3.0)), ((6.5, 2.5), (t, 3.0))]
    return walled_scene(((5.0, 2.5), (0.8, 0.6)), (5.0, 2.5), walls, 2.0)


@pytest.mark.parametrize("method", ["global", "sequential"])
def test_a_place_only_a_closed_room_serves_says_the_base_cannot_get_there(maps_dir, method):
    """Every method keeps the pick and names the place: no path for the base to the cells the maps
    allow, none of them within the base's reach (`global` called it a transfer no arm and grasp makes,
    with an empty diagnosis; the step-by-step methods said no placement keeps the map threshold, and
    failed the pick)."""
    planner = Planner(closed_room_scene(), method, maps_dir)
    result = planner.plan()
    assert not result.ok
    pick, place = result.steps
    assert pick.ok and place.status == "infeasible" and place.action == "place"
    assert "no collision-free path for the base reaches a placement of this step; " in place.reason
    assert ", 0 of them reachable from" in place.reason and "they lie where the footprint cannot drive" in place.reason
    d = place.diagnosis
    if method == "global":
        assert place.reason.startswith("no collision-free path")
        assert d["arm"] in ("left", "right") and d["pose_role"] in ("pre-place", "place") and d["tried"] == 0
        assert d["hint"] in place.reason
    else:  # per arm and grasp, what failed at the place
        assert d["place"] == "spot" and all("no collision-free path" in t["failed"] for t in d["transfers"])
    assert result.verify(planner.robot, scene=planner.scene) == []


@pytest.mark.slow
@pytest.mark.parametrize("method", ["global", "optimal", "sequential"])
def test_a_spent_time_budget_keeps_the_verified_steps_and_says_why(maps_dir, method):
    """With 0.1 s for the whole task, 0.09 s of it spent before the plan starts (as a query's planner
    construction is counted), the plan stops soon after: the steps verified by then are kept, and the
    first one not verified says which budget ran out and how to raise it. (The whole budget planned
    the office's six steps on a fast machine.)"""
    import dataclasses
    import time

    from placement.scene import load_scene

    scene = load_scene(next(p for p in BUILDINGS if p.parent.name == "willow_office"))  # ~1 s on the full map
    planner = Planner(dataclasses.replace(scene, planner={"time_budget_s": 0.1}), method, maps_dir)
    t = time.perf_counter()
    result = planner.plan(spent_s=0.09)
    assert time.perf_counter() - t < 2.0
    assert not result.ok
    *done, failed = result.steps
    assert all(s.ok for s in done) and failed.status == "infeasible"
    assert "time budget of 0.1 s ran out" in failed.reason and "planner.time_budget_s" in failed.reason
    assert [s.step for s in result.steps] == list(range(len(result.steps)))
    if done:
        partial = dataclasses.replace(result, steps=done)
        assert partial.verify(planner.robot) == []


def test_every_method_names_the_same_failing_step_and_keeps_the_steps_before(maps_dir):
    """The lab's last place moved to 1.9 m, above what the maps hold: every map-based method plans the
    steps before it, then names that place with the same reason (not its pick, not a band as a limit)."""
    import dataclasses

    from placement.scene import load_scene

    scene = load_scene(next(p for p in BUILDINGS if p.parent.name == "brsu_home_lab"))
    places = tuple(
        dataclasses.replace(p, position=(p.position[0], p.position[1], 1.9)) if p.name == "desk_right" else p
        for p in scene.place_locations
    )
    scene = dataclasses.replace(scene, place_locations=places)
    reasons = {}
    for method in ("global", "optimal", "sequential", "single-step"):
        planner = Planner(scene, method, maps_dir)
        result = planner.plan()
        *done, failed = result.steps
        assert [s.step for s in result.steps] == list(range(6)), method
        assert all(s.ok for s in done) and failed.target == "desk_right" and failed.action == "place", method
        assert dataclasses.replace(result, steps=done).verify(planner.robot) == [], method
        reasons[method] = failed.reason
    assert len(set(reasons.values())) == 1, reasons
    assert "outside the height range of the maps" in reasons["global"]


@pytest.mark.slow
def test_an_update_on_a_windowed_map_plans_as_a_fresh_planner(maps_dir):
    """The arena, planned on a window of its map: an object moved 2 cm (the same window), then the start
    moved to the second room (another window): each re-plan equals a fresh planner's plan."""
    path = next(p for p in BUILDINGS if p.parent.name == "wrs_arena")
    live = Planner(path, "global", maps_dir)
    live.plan()
    first = live.world.window
    for change in (
        {"objects": [{"name": "cracker_box", "position": [1.07, -0.55, 0.705]}]},
        {"start": [2.2, 3.8, 1.5]},  # the second room's cupboard goal
    ):
        live.update(change)
        got = live.plan()
        fresh = Planner(live.scene, "global", maps_dir)
        want = fresh.plan()
        assert live.world.window == fresh.world.window
        assert [(s.base, s.arm, s.grasp) for s in got.steps] == [(s.base, s.arm, s.grasp) for s in want.steps]
        if "objects" in change:
            assert live.world.window == first
    assert live.world.window != first
