"""The planner's choices against brute force: Eq. 6 over every cell, and the heuristic's effect.

Oracles: navigation and heuristic costs from scipy's Dijkstra on an independently built graph,
Eq. 6 evaluated in float64 over every (arm, grasp, cell), and IK on every cheaper placement.
The tests run at the default threshold (each arm's quantile: about 0.0235 on the PR2's maps).
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import yaml
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra
from support.navigation import grid_graph
from support.planning import SCENE

from placement.planning import Planner as AnyPlanner
from placement.planning.verification.ik import trajectory_ik

# these tests are about the step-by-step search (the paper's method), not the default
Planner = functools.partial(AnyPlanner, method="sequential")

# planning orders costs computed partly in float32 (map values); a placement must be cheaper than
# the chosen one by more than this to count as a better one the planner missed
COST_TOL = 1e-6


def _oracle_heuristic(planner, i, graph):
    """Area-weighted Dijkstra costs from the centre cells of step i's feasible regions."""
    region = np.zeros(planner.world.nav.shape, bool)
    for o in planner.problems.options(i):
        region |= o.full_value(region.shape) >= planner.thresholds[o.arm]
    labels, n = ndimage.label(region, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    keep = [k for k in range(1, n + 1) if sizes[k - 1] >= planner.config.min_region * sizes.sum()]
    total = np.zeros(region.size)
    for k in keep:
        cells = np.argwhere(labels == k)
        centre = cells[np.argmin(((cells - cells.mean(axis=0)) ** 2).sum(axis=1))]
        cost = dijkstra(graph, indices=int(centre[0] * region.shape[1] + centre[1]))
        total += sizes[k - 1] / sum(sizes[j - 1] for j in keep) * cost
    return total.reshape(region.shape)


def test_each_placement_minimises_eq6_over_the_ik_feasible_cells(tmp_path, maps_dir):
    scene = json.loads(json.dumps(SCENE))
    scene.update(maps=str(maps_dir), planner={"yaw_steps": 40})  # the default threshold (0.0235 on the PR2)
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    planner = Planner(path)
    result = planner.plan()
    assert result.ok, result.failed_step
    cfg, world = planner.config, planner.world
    nav = world.nav
    graph = grid_graph(world.factor, world.feasible, nav.resolution)
    xs, ys = nav.centres()
    prev_cell = planner.start_cell()
    prev_q = {arm: planner.robot.arm(arm).home.copy() for arm in planner.maps}
    checked = 0
    for s in result.steps:
        nav_cost = dijkstra(graph, indices=prev_cell[0] * nav.shape[1] + prev_cell[1]).reshape(nav.shape)
        last = s.step + 1 == len(result.steps)
        heur = np.zeros(nav.shape) if last else _oracle_heuristic(planner, s.step + 1, graph)
        chosen = nav.cell(s.base[0], s.base[1])
        want = cfg.lambda_n * nav_cost[chosen] + cfg.lambda_m / float(s.manipulability) + cfg.lambda_nh * heur[chosen]
        assert s.cost.total == pytest.approx(want, rel=1e-9)
        for o in planner.problems.options(s.step):
            value = o.full_value(nav.shape).astype(float)
            thr = planner.thresholds[o.arm]
            inner = ndimage.minimum_filter(value, size=3, mode="constant", cval=0.0) >= thr
            ok = (value >= thr) & inner & np.isfinite(nav_cost) & np.isfinite(heur)
            cost = np.full(nav.shape, np.inf)
            cost[ok] = cfg.lambda_n * nav_cost[ok] + cfg.lambda_m / value[ok] + cfg.lambda_nh * heur[ok]
            for flat in np.flatnonzero(cost < s.cost.total - COST_TOL):
                iy, ix = divmod(int(flat), nav.shape[1])
                base = (float(xs[ix]), float(ys[iy]), float(planner.yaws[o.yaw_at(iy, ix)]))
                q = trajectory_ik(planner.robot, o.arm, o.candidate.poses, base, prev_q[o.arm])
                assert q is None, (
                    f"step {s.step}: {o.arm}/{o.candidate.name} at {base} costs "
                    f"{cost[iy, ix]:.5f} < {s.cost.total:.5f} and IK solves it"
                )
                checked += 1
        prev_cell, prev_q[s.arm] = chosen, s.q
    assert checked < 200  # the brute force stays a test, not a search


def _corridor_scene(maps_dir, place_y: float) -> dict:
    """A 3 m long table across the room with a cup at its middle, reachable from its north and south
    sides alike; the start on the table's axis, west of it; the place location north or south."""
    return {
        "version": 1,
        "resolution": 0.05,
        "bounds": [0.0, 0.0, 9.0, 9.0],
        "maps": str(maps_dir),
        "robot": {"preset": "pr2", "start": [0.8, 4.5, 0.0]},
        "obstacles": [
            {"name": "table", "box": {"center": [4.5, 4.5, 0.375], "size": [3.0, 0.6, 0.75]}, "table": True},
            {"name": "shelf", "box": {"center": [4.5, place_y, 0.375], "size": [0.5, 0.5, 0.75]}, "table": True},
        ],
        "objects": [{"name": "cup", "position": [4.5, 4.5, 0.8], "yaw": 0.0, "size": [0.06, 0.06, 0.1]}],
        "place_locations": [{"name": "spot", "position": [4.5, place_y, 0.85]}],
        "task": [{"pick": "cup", "place": "spot"}],
        "planner": {"yaw_steps": 40},
    }


@pytest.mark.parametrize("place_y, side", [(8.2, 1), (0.8, -1)])
def test_heuristic_moves_the_pick_to_the_side_of_the_next_step(tmp_path, maps_dir, place_y, side):
    """With the place location north (south) of the table, ``sequential`` picks the cup from the
    north (south) side; the heuristic term is what makes the difference (its share is checked)."""
    path = tmp_path / "corridor.yaml"
    path.write_text(yaml.safe_dump(_corridor_scene(maps_dir, place_y)))
    planner = Planner(path)
    seq = planner.plan()
    assert seq.ok, seq.failed_step
    assert np.sign(seq.steps[0].base[1] - 4.5) == side
    assert seq.steps[0].cost.heuristic > 0
    # the other side's best placement would cost more in total, through the heuristic
    planner.set_method("single-step")
    single = planner.plan()
    assert single.ok and single.steps[0].cost.heuristic == 0
    if np.sign(single.steps[0].base[1] - 4.5) != side:
        assert (
            seq.steps[0].cost.navigation + seq.steps[0].cost.manipulation
            >= single.steps[0].cost.navigation + single.steps[0].cost.manipulation
        )
