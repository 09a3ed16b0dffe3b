"""``optimal`` prices the torso per step: its program over (cell, arm and grasp, torso setting) against
every sequence enumerated, its plans on the toy pitch-torso robot and on TIAGo's kitchen.

Oracle: the regions read from each option's map at its own setting's threshold, all-pairs shortest
paths by scipy's Dijkstra on an independently built graph, the torso term from the URDF's velocity
limit (v_max * |t - t'| / velocity [m]), and every sequence of (cell, arm, grasp, setting) of the
task enumerated with numpy broadcasting (a place keeps its pick's arm and grasp, not its setting).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.sparse.csgraph import dijkstra
from support.deep_table import deep_table_scene
from support.knee_torso import CROUCH, HIP, HIP_SPEED, KNEE, KNEE_SPEED, UPRIGHT, write_knee_torso
from support.navigation import grid_graph
from support.pitch_torso import JOINT, SETTINGS, SPEED, pitch_torso_maps, write_pitch_torso

import placement
from placement.maps.buildspec import parse_torso
from placement.maps.torso_builds import build_torso_maps
from placement.planning.methods.optimal import DynamicProgram, solve_verified
from placement.planning.planner import Planner
from placement.planning.program.forward import travel_bound
from placement.planning.program.held_first import HeldFirst
from placement.planning.program.priced_torso import TorsoProgram, torso_regions, torso_term
from placement.planning.task_time import task_time

ROOT = Path(__file__).resolve().parents[1]
TIAGO_SCENE = ROOT / "examples" / "kitchen_torso_tiago.yaml"
TIAGO_MAPS = ROOT / "maps" / "tiago"


@pytest.fixture(scope="module")
def pitch(tmp_path_factory):
    """(folder, maps path): the toy pitch robot's arm at both settings, 0.1 m cells."""
    folder = tmp_path_factory.mktemp("optimal_torso")
    return folder, pitch_torso_maps(folder)[2]


def _scene(folder: Path, maps: Path, resolution: float = 0.1, second: bool = False) -> str:
    """A 4 m long, 0.8 m deep table (y 2.0 .. 2.8) between the start (south) and its far side: the
    cup stands 0.55 m inside its south edge, which the upright arm reaches only from the north side
    (a drive around the table) and the leaning one from the south side; a stand to put it on in the
    south. ``second``: a mug on the table's north part too, set down on a second stand (4 steps)."""
    preset = write_pitch_torso(folder / "robot")
    scene = {
        "version": 1,
        "resolution": resolution,
        "bounds": [0.0, 0.0, 6.0, 5.0],
        "robot": {"preset": str(preset), "start": [3.0, 1.0, 0.0]},
        "maps": str(maps),
        "obstacles": [
            {"name": "table", "box": {"center": [3.0, 2.4, 0.375], "size": [4.0, 0.8, 0.75]}, "table": True},
            {"name": "stand", "box": {"center": [4.8, 1.0, 0.4], "size": [0.3, 0.3, 0.8]}, "table": True},
        ],
        "objects": [{"name": "cup", "position": [3.0, 2.55, 0.8], "yaw": 0.4, "size": [0.06, 0.06, 0.1]}],
        "place_locations": [{"name": "spot", "position": [4.8, 1.0, 0.85]}],
        "task": [{"pick": "cup", "place": "spot"}],
        "planner": {"threshold": 0.01, "yaw_steps": 40},
    }
    if second:
        scene["obstacles"].append(
            {"name": "stand_2", "box": {"center": [1.2, 3.8, 0.4], "size": [0.3, 0.3, 0.8]}, "table": True}
        )
        scene["objects"].append({"name": "mug", "position": [2.0, 2.7, 0.8], "yaw": 0.0, "size": [0.06, 0.06, 0.1]})
        scene["place_locations"].append({"name": "spot_2", "position": [1.2, 3.8, 0.85]})
        scene["task"].append({"pick": "mug", "place": "spot_2"})
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"scene_{resolution}_{second}.yaml"
    path.write_text(yaml.safe_dump(scene))
    return str(path)


def _oracle_states(planner, masks=None):
    """Per step: (k,) flat cells, (k,) (arm, grasp) labels, (k,) settings of every (cell, group, setting)
    where an option at that setting keeps its threshold (``masks``: {(step, (arm, grasp), setting):
    (ny, nx) bool} limits them to what a program kept)."""
    ctx = planner.context
    shape = planner.world.nav.shape
    out = []
    for i in range(len(ctx.problems.steps)):
        found: dict = {}
        for o in ctx.problems.options(i):
            ok = (o.full_value(shape) >= ctx.threshold(o.arm, o.torso)) & planner.world.feasible
            key = ((o.arm, o.candidate.grasp), o.torso)
            found[key] = found.get(key, np.zeros(shape, bool)) | ok
        cells, groups, sets = [], [], []
        for (g, t), m in found.items():
            if masks is not None:
                m = m & masks.get((i, g, t), np.zeros(shape, bool))
            for c in np.flatnonzero(m):
                cells.append(int(c))
                groups.append(g)
                sets.append(float(t))
        out.append((np.array(cells, np.int64), groups, np.array(sets)))
    return out


def _urdf_term(planner):
    """The torso term [m] from the support module's velocity limit: v_max * |b - a| / SPEED."""
    v = planner.robot.v_max
    return lambda a, b: v * np.abs(np.asarray(b) - np.asarray(a)) / SPEED


def _enumerated(planner, states, start_torso: float, term=None) -> float:
    """The least travel + torso term [m] (``term``, default :func:`_urdf_term`) over every sequence of
    states, by broadcasting one axis per step (every sequence is a cell of the tensor)."""
    term = term or _urdf_term(planner)
    w = planner.world
    dist = dijkstra(grid_graph(w.factor, w.feasible, w.nav.resolution))
    sy, sx = planner.start_cell()
    steps = planner.context.problems.steps
    cells0, _, sets0 = states[0]
    total = dist[sy * w.nav.shape[1] + sx, cells0] + term(start_torso, sets0)
    for i in range(1, len(states)):
        (ca, ga, sa), (cb, gb, sb) = states[i - 1], states[i]
        move = dist[np.ix_(ca, cb)] + term(sa[:, None], sb[None, :])
        if steps[i].pick == i - 1:  # a place keeps its pick's arm and grasp
            same = np.array([[a == b for b in gb] for a in ga], bool).reshape(len(ga), len(gb))
            move = np.where(same, move, np.inf)
        total = total[..., None] + move.reshape((1,) * (total.ndim - 1) + move.shape)
    return float(total.min()) if total.size else math.inf


@pytest.fixture(scope="module")
def coarse(pitch):
    """{steps: planner} on 0.2 m (2 steps) and 0.25 m (4 steps) cells, without collisions."""
    folder, maps = pitch
    return {n: Planner(_scene(folder, maps, r, n == 4), "optimal", collisions=False) for n, r in ((2, 0.2), (4, 0.25))}


@pytest.mark.slow
@pytest.mark.parametrize("held", [0.0, 0.6], ids=["upright start", "leaning start"])
@pytest.mark.parametrize("n", [2, 4], ids=["2 steps", "4 steps"])
@pytest.mark.parametrize("kind", ["urdf", "cheap", "lean dearer"])
@pytest.mark.parametrize("grouped", [False, True], ids=["merged", "grouped"])
def test_the_priced_program_equals_every_sequence_enumerated(coarse, held, n, kind, grouped):
    """``held``: the setting the program starts from (the maps are built with the robot upright);
    ``kind``: the URDF's torso term (1.25 m per rad), 0.1 m per rad, or 0.1 m per rad plus 2 m for
    every step taken leaning (the chain leans only where it must: settings change within it);
    ``grouped``: every transfer grouped from the start (the places' per-group seeds)."""
    planner = coarse[n]
    ctx = planner.context
    states = _oracle_states(planner)
    assert all(len(s[0]) for s in states) and {t for s in states for t in s[2]} == set(SETTINGS)
    terms = {
        "urdf": _urdf_term(planner),
        "cheap": lambda a, b: 0.1 * np.abs(np.asarray(b) - np.asarray(a)),
        "lean dearer": lambda a, b: 0.1 * np.abs(np.asarray(b) - np.asarray(a)) + 2.0 * (np.asarray(b) > 0.3),
    }
    term = terms[kind]
    want = _enumerated(planner, states, held, term)
    assert math.isfinite(want)
    w = planner.world
    grid = (w.factor, w.feasible, w.nav.resolution, planner.start_cell())
    linked = [s.pick == s.index - 1 for s in ctx.problems.steps]
    regions = [torso_regions(ctx, i) for i in range(n)]
    assert sum(len(s[0]) for s in states) == sum(int(r.masks.sum()) for r in regions)
    program_term = torso_term(ctx) if kind == "urdf" else (lambda a, b: float(term(a, b)))
    program = TorsoProgram(grid, linked, held, program_term)
    if grouped:
        program.group([i for i in range(n) if linked[i]])
    chain = program.solve(regions)
    assert chain is not None and chain.total == pytest.approx(want, rel=1e-9)
    # the chain is what it says: its cells and settings in the regions, its cost the oracle's
    dist = dijkstra(grid_graph(w.factor, w.feasible, w.nav.resolution))
    at, t, cost = grid[3][0] * w.nav.shape[1] + grid[3][1], held, 0.0
    for i, (c, g) in enumerate(zip(chain.cells, chain.groups)):
        assert regions[i].has(g, c)
        assert regions[i].settings is not None
        s = regions[i].settings[g]
        cost += dist[at, c] + float(term(t, s))
        if linked[i]:
            assert regions[i].groups[g] == regions[i - 1].groups[chain.groups[i - 1]]
        at, t = c, s
    assert cost == pytest.approx(want, rel=1e-9)
    # with the held chain first (provably optimal or not): the same optimum (for a torso term, one
    # that costs nothing where the torso stays)
    if kind != "lean dearer":
        floor = travel_bound(ctx, planner.start_cell())
        answer = HeldFirst(grid, linked, held, SETTINGS, program_term, floor)
        first = answer.solve(regions)
        assert first is not None and first.total == pytest.approx(want, rel=1e-9)
        if kind == "urdf":  # both branches taken: the upright start escalates, the leaning one need not
            assert answer.escalated == (held == 0.0)


def test_optimal_is_the_enumerated_optimum_of_the_cells_verification_left(pitch):
    folder, maps = pitch
    held = 0.0
    planner = Planner(_scene(folder, maps, 0.2), "optimal")
    ctx = planner.context
    dp = DynamicProgram(ctx, planner.start_cell(), priced=True)
    chain, picks, failure = solve_verified(dp)
    assert failure is None and chain is not None and len(picks) == len(ctx.problems.steps)
    kept = {}
    for i, reg in enumerate(dp.regions):
        assert reg.settings is not None
        for k, (g, t) in enumerate(zip(reg.groups, reg.settings)):
            kept[(i, g, t)] = reg.dense()[k]
    want = _enumerated(planner, _oracle_states(planner, kept), held)
    assert chain.total == pytest.approx(want, rel=1e-9)
    # the plan: every step verified, its travel + torso term (from the steps' joints) the optimum
    result = planner.plan()
    assert all(s.ok for s in result.steps) and result.verify(planner.robot) == []
    v, t, cost = planner.robot.v_max, held, 0.0
    for s in result.steps:
        cost += s.travel_time_s * v + v * abs(s.joints[JOINT] - t) / SPEED
        t = s.joints[JOINT]
    assert cost == pytest.approx(want, rel=1e-9)


def _model_m(robot, result, joint: str, start: float) -> float:
    """A plan's travel + torso term [m]: v_max * (travel [s] + |dq| / the joint's URDF velocity limit)."""
    model = robot.model
    velocity = float(model.velocityLimit[model.joints[model.getJointId(joint)].idx_v])
    total, t = 0.0, start
    for s in result.steps:
        total += robot.v_max * (s.travel_time_s + abs(s.joints[joint] - t) / velocity)
        t = s.joints[joint]
    return total


def test_a_pick_whose_near_side_needs_the_lean_gets_it(pitch):
    folder, maps = pitch
    planner = Planner(_scene(folder, maps), "optimal")
    robot = planner.robot
    result = planner.plan()
    assert all(s.ok for s in result.steps) and result.verify(robot) == []
    pick = result.steps[0]
    # leaning, from the start's (south) side of the table: no drive around it
    assert pick.joints[JOINT] == 0.6 and pick.base[1] < 2.0
    # the hold rule (global) stands upright on the far side: a longer drive than the lean costs
    planner.set_method("global")
    held = planner.plan()
    assert all(s.ok for s in held.steps) and held.steps[0].joints[JOINT] == 0.0 and held.steps[0].base[1] > 2.8
    assert _model_m(robot, result, JOINT, 0.0) < _model_m(robot, held, JOINT, 0.0) - 1.0
    tt, th = task_time(robot, result, planner.context.scene.start), task_time(robot, held, planner.context.scene.start)
    assert tt is not None and th is not None and tt["total_s"] < th["total_s"]


@pytest.mark.skipif(not (TIAGO_MAPS / "zarr.json").is_file(), reason="no maps/tiago")
def test_tiago_kitchen_optimal_plans_every_step_no_dearer_than_global():
    planner = Planner(TIAGO_SCENE, "optimal")
    robot = planner.robot
    joint = "torso_lift_joint"
    start = float(robot.fixed_joints[joint])
    result = planner.plan()
    assert all(s.ok for s in result.steps), [s.reason for s in result.steps]
    assert result.verify(robot) == []
    planner.set_method("global")
    other = planner.plan()
    assert all(s.ok for s in other.steps)
    assert _model_m(robot, result, joint, start) <= _model_m(robot, other, joint, start) + 1e-9


@pytest.mark.slow
def test_postures_are_priced_by_their_slowest_joint(tmp_path):
    """The hip-and-knee torso (support/knee_torso.py) at two postures: the deep table's cup only
    crouched; ``optimal`` crouches for it, and the chain's torso terms are v_max times the slowest
    joint's time between the plan's postures (hip 0.9 rad at 0.4 rad/s: 2.25 s, the knee's 1.29 s)."""
    preset = write_knee_torso(tmp_path / "robot")
    robot = placement.load_robot(preset)
    spec = {"joints": [HIP, KNEE], "postures": [list(UPRIGHT), list(CROUCH)]}
    built = build_torso_maps(
        robot,
        "arm",
        torso=parse_torso(spec, "torso"),
        samples=200_000,
        seed=2,
        resolution=0.1,
        bins=(8, 5, 8),
        progress=False,
    )
    maps = placement.save_maps(tmp_path / "maps", robot, built)
    planner = Planner(deep_table_scene(tmp_path, preset, maps), "optimal")
    result = planner.plan()
    assert all(s.ok for s in result.steps), [s.reason for s in result.steps]
    assert result.verify(robot) == []
    assert (result.steps[0].joints[HIP], result.steps[0].joints[KNEE]) == CROUCH
    ctx = planner.context
    dp = DynamicProgram(ctx, planner.start_cell(), priced=True)
    chain, _, failure = solve_verified(dp)
    assert failure is None and chain is not None
    before, total = UPRIGHT, 0.0
    for s in result.steps:
        now = (s.joints[HIP], s.joints[KNEE])
        seconds = max(abs(now[0] - before[0]) / HIP_SPEED, abs(now[1] - before[1]) / KNEE_SPEED)
        total += robot.v_max * (s.travel_time_s + seconds)
        before = now
    assert chain.total == pytest.approx(total, rel=1e-9)
    assert sum(dp.torso_m(chain, i) for i in range(len(chain.cells))) >= robot.v_max * 2.25 - 1e-9


def test_solving_again_keeps_each_settings_node_costs(coarse):
    """With ``optimal_manipulability_weight`` > 0 the node cost of a (arm, grasp, setting) group is
    the weight over that setting's best map value: solving again from the maps' regions (after
    rejections took neighbourhoods away) prices the same chain the same."""
    planner = coarse[2]
    ctx = planner.context
    config = ctx.config
    object.__setattr__(config, "optimal_manipulability_weight", 0.05)
    try:
        dp = DynamicProgram(ctx, planner.start_cell(), priced=True)
        chain, _, failure = solve_verified(dp)
        assert failure is None and chain is not None
        again = dp.exact_again()
        assert again is not None and again.total == pytest.approx(chain.total, rel=1e-12)
        for i, reg in enumerate(dp.regions):  # node = weight / the group's best value at its setting
            assert reg.node is not None and reg.settings is not None
            for k, ((arm, grasp), t) in enumerate(zip(reg.groups, reg.settings)):
                best = np.max(
                    [
                        o.full_value(planner.world.nav.shape)
                        for o in ctx.problems.held_options(i, t)
                        if (o.arm, o.candidate.grasp) == (arm, grasp)
                    ],
                    axis=0,
                )
                on = reg.masks[k]
                assert np.allclose(reg.node[k][on], 0.05 / best.flat[reg.cells[on]], rtol=1e-6)
    finally:
        object.__setattr__(config, "optimal_manipulability_weight", 0.0)
