"""The planning window on a building's map: exact layers inside it, a fallback when it would cut the
base off a target, and the heuristic's reachable floor."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from support.occupancy import write_pgm

from placement.planning.problems.manipulation import base_yaws
from placement.planning.settings import PlannerConfig
from placement.planning.world.footprints import BaseShape
from placement.planning.world.layers import build_world, windowed_world
from placement.planning.world.navigation import reachable_from
from placement.planning.world.window import serves, task_window
from placement.scene import parse_scene

RES = 0.1  # [m] map cells


def building(walls: list[tuple[float, float, float, float]], size=(40.0, 10.0)) -> np.ndarray:
    """A map image (top row first) of ``size`` [m]: free, with the outer wall and ``walls`` (x0, y0, x1, y1) [m]."""
    ny, nx = int(size[1] / RES), int(size[0] / RES)
    occ = np.zeros((ny, nx), dtype=bool)
    occ[:2], occ[-2:], occ[:, :2], occ[:, -2:] = True, True, True, True
    for x0, y0, x1, y1 in walls:
        occ[int(y0 / RES) : int(y1 / RES), int(x0 / RES) : int(x1 / RES)] = True
    return np.where(occ, 0, 254)[::-1]


def write_building(tmp_path, pixels, name="floor"):
    write_pgm(tmp_path / f"{name}.pgm", pixels.tolist())
    (tmp_path / f"{name}.yaml").write_text(
        yaml.safe_dump({"image": f"{name}.pgm", "resolution": RES, "origin": [0.0, 0.0, 0.0]})
    )


def scene(tmp_path, objects, places, start=(2.0, 5.0, 0.0), **extra):
    tables = [
        {"name": f"t_{i}", "box": {"center": [x, y, 0.36], "size": [0.6, 0.6, 0.72]}, "table": True}
        for i, (x, y) in enumerate(objects + places)
    ]
    doc = {
        "version": 1,
        "robot": {"preset": "pr2", "start": list(start)},
        "occupancy_map": "floor.yaml",
        "obstacles": tables,
        "objects": [
            {"name": f"o_{i}", "position": [x, y, 0.77], "size": [0.05, 0.05, 0.1]} for i, (x, y) in enumerate(objects)
        ],
        "place_locations": [{"name": f"p_{i}", "position": [x, y, 0.8]} for i, (x, y) in enumerate(places)],
        "task": [{"pick": f"o_{i}", "place": f"p_{i}"} for i in range(len(objects))],
    }
    doc.update(extra)
    return parse_scene(doc, tmp_path)


@pytest.fixture(scope="module")
def base(pr2):
    return BaseShape.of(pr2, 0.02, base_yaws(PlannerConfig().yaw_steps))


def test_window_cells_equal_the_whole_grid(tmp_path, base, pr2):
    """A 40 m corridor building, a task in its first 8 m: the window is a third of the grid, and every
    cell of it has the whole grid's occupancy, feasibility, slowdown and allowed yaws."""
    write_building(tmp_path, building([(8.0, 0.0, 8.2, 4.0), (8.0, 6.0, 8.2, 10.0), (3.0, 7.5, 3.1, 8.5)]))
    sc = scene(tmp_path, [(4.0, 3.0)], [(6.0, 7.0)])
    cfg = PlannerConfig()
    window = task_window(sc, sc.nav_grid(), base)
    assert window is not None
    j0, j1, i0, i1 = window
    ny, nx = sc.grid_shape
    assert (j1 - j0) * (i1 - i0) < 0.4 * ny * nx
    full = build_world(sc, base, cfg, pr2.v_max)
    part = windowed_world(sc, base, cfg, pr2.v_max)
    assert part.window == window and part.nav.shape == (j1 - j0, i1 - i0)
    for name in ("occupied", "feasible", "factor", "touched"):
        np.testing.assert_array_equal(getattr(part, name), getattr(full, name)[j0:j1, i0:i1], err_msg=name)
    cells = np.arange(part.nav.shape[0] * part.nav.shape[1])
    rows, cols = cells // part.nav.shape[1], cells % part.nav.shape[1]
    np.testing.assert_array_equal(part.yaw_masks(cells), full.yaw_masks((rows + j0) * nx + (cols + i0)))
    # the windowed cell of a point is the whole grid's cell less the window's corner
    x, y = 5.03, 6.71
    fj, fi = full.nav.cell(x, y)
    assert part.nav.cell(x, y) == (fj - j0, fi - i0)


def test_a_window_that_cuts_the_only_drivable_route_is_not_used(tmp_path, base, pr2):
    """The map's short route to the far room goes through a door a keepout mask closes; the base must
    drive round by a corridor along the building and back, outside the window: the whole grid is planned."""
    # the left room opens on the far room by a door (x 8, y 4 .. 6) and on a corridor (y 0.2 .. 2) that
    # joins the far room only at the building's far end (x > 38)
    walls = [(8.0, 1.8, 8.2, 4.0), (8.0, 6.0, 8.2, 10.0), (8.2, 2.0, 38.0, 2.2)]
    write_building(tmp_path, building(walls))
    keep = np.full((100, 400), 254)
    keep[::-1][40:60, 75:90] = 0  # the door at x 8 .. 8.2, y 4 .. 6 (and around it)
    write_pgm(tmp_path / "keep.pgm", keep.tolist())
    (tmp_path / "keep.yaml").write_text(yaml.safe_dump({"image": "keep.pgm", "resolution": RES, "origin": [0, 0, 0]}))
    sc = scene(tmp_path, [(4.0, 3.0)], [(12.0, 6.0)], keepout_mask="keep.yaml")
    cfg = PlannerConfig()
    window = task_window(sc, sc.nav_grid(), base)
    assert window is not None
    cut = build_world(sc, base, cfg, pr2.v_max, window)
    assert not serves(cut.feasible, cut.nav, sc)
    world = windowed_world(sc, base, cfg, pr2.v_max)
    assert world.window is None and world.nav.shape == sc.grid_shape
    assert serves(world.feasible, world.nav, sc)


def test_bounds_in_the_file_plan_the_whole_grid(tmp_path, base):
    write_building(tmp_path, building([]))
    sc = scene(tmp_path, [(4.0, 3.0)], [(6.0, 7.0)], bounds=[-1.0, -1.0, 41.0, 11.0])
    assert sc.bounds_given and task_window(sc, sc.nav_grid(), base) is None
    assert task_window(scene(tmp_path, [(4.0, 3.0)], [(6.0, 7.0)]), sc.nav_grid(), base) is not None


def test_reachable_floor_is_the_start_component(tmp_path, base, pr2):
    # a closed room at the far end: feasible floor the base can never reach
    write_building(tmp_path, building([(30.0, 0.0, 30.2, 10.0)]))
    sc = scene(tmp_path, [(4.0, 3.0)], [(6.0, 7.0)], bounds=[-1.0, -1.0, 41.0, 11.0])
    world = build_world(sc, base, PlannerConfig(), pr2.v_max)
    reach = reachable_from(world.feasible, world.nav, 2.0, 5.0)
    inside, far = world.nav.cell(10.0, 5.0), world.nav.cell(35.0, 5.0)
    assert reach[inside] and world.feasible[far] and not reach[far]
    # off the floor: nothing narrower than every feasible cell can be said
    np.testing.assert_array_equal(reachable_from(world.feasible, world.nav, 30.1, 5.0), world.feasible)


def test_a_cut_window_falls_back_to_the_planners_own_routes(tmp_path, base, pr2):
    """As above in a 100 m building whose far half the task never needs: the map's route through the
    closed door gives a window that cuts the base off; the whole grid is built and cut to the window of
    the planner's own cheapest routes (round by the corridor), whose cells are the whole grid's."""
    walls = [(8.0, 1.8, 8.2, 4.0), (8.0, 6.0, 8.2, 10.0), (8.2, 2.0, 38.0, 2.2), (45.0, 0.0, 45.2, 10.0)]
    write_building(tmp_path, building(walls, size=(100.0, 10.0)))
    keep = np.full((100, 1000), 254)
    keep[::-1][40:60, 75:90] = 0
    write_pgm(tmp_path / "keep.pgm", keep.tolist())
    (tmp_path / "keep.yaml").write_text(yaml.safe_dump({"image": "keep.pgm", "resolution": RES, "origin": [0, 0, 0]}))
    sc = scene(tmp_path, [(4.0, 3.0)], [(12.0, 6.0)], keepout_mask="keep.yaml")
    cfg = PlannerConfig()
    first = task_window(sc, sc.nav_grid(), base)
    assert first is not None and not serves(*_layers(build_world(sc, base, cfg, pr2.v_max, first)), sc)
    world = windowed_world(sc, base, cfg, pr2.v_max)
    assert world.window is not None and world.window != first
    j0, j1, i0, i1 = world.window
    full = build_world(sc, base, cfg, pr2.v_max)
    assert world.nav.shape[1] < 0.6 * full.nav.shape[1] and world.nav.origin[0] + world.nav.shape[1] * 0.05 > 38.0
    for name in ("occupied", "feasible", "factor"):
        np.testing.assert_array_equal(getattr(world, name), getattr(full, name)[j0:j1, i0:i1], err_msg=name)
    assert serves(world.feasible, world.nav, sc)


def _layers(world):
    return world.feasible, world.nav
