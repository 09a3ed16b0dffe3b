"""One threshold meaning on every torso setting: a map built once per setting (the toy pitch robot of
support/pitch_torso.py, a revolute torso) has one value distribution per setting, and every option is
thresholded by its own setting's quantile, computed here with numpy from that setting's stored array;
a shifted map's settings (a prismatic lift) keep the arm's threshold; a scene's ``planner.threshold``
applies to every setting. ``maps check`` checks every setting's map with the robot held there.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
import zarr
from support.cli import run
from support.deep_table import deep_table_scene
from support.pitch_torso import JOINT, write_pitch_torso

import placement
from placement.errors import MapError
from placement.maps.accuracy import check_map
from placement.maps.buildspec import TorsoSpec
from placement.maps.opening import open_map
from placement.maps.torso_builds import build_torso_maps
from placement.planning.methods.weighted import rank_eq6
from placement.planning.planner import Planner
from placement.planning.problems.thresholds import setting_thresholds
from placement.planning.problems.torso_maps import map_variants
from placement.planning.program.regions import map_regions
from placement.planning.settings import PlannerConfig
from placement.planning.world.navigation import navigation_cost

SETTINGS = (0.0, 0.6)  # [rad]: upright (the preset's, the arm's own array) and leaning forward
#: threshold_quantile: the settings' quantiles differ by 3 % here, and the scene's options (and their
#: (arm, grasp) groups at the leaning setting) have cells between them (none at the default 0.343: a
#: map's values are a finite set)
Q = 0.2
TIAGO_MAPS = Path(__file__).resolve().parents[1] / "maps" / "tiago"


@pytest.fixture(scope="module")
def pitch(tmp_path_factory):
    """(robot, preset path, maps path): the arm at both settings, 200k samples each at 0.1 m."""
    folder = tmp_path_factory.mktemp("setting_thresholds")
    preset = write_pitch_torso(folder / "robot")
    robot = placement.load_robot(preset)
    spec = TorsoSpec(JOINT, SETTINGS)
    options = {"samples": 200_000, "seed": 2, "resolution": 0.1, "bins": (8, 5, 8), "progress": False}
    built = build_torso_maps(robot, "arm", torso=spec, **options)
    return robot, preset, placement.save_maps(folder / "maps", robot, built)


def _stored(maps: Path, value: float) -> np.ndarray:
    """The stored values of the arm's map at torso ``value``, read with zarr (not through the map)."""
    name = "arm" if value == 0.0 else f"arm@{JOINT}={value:g}"
    return np.asarray(zarr.open_group(str(maps), mode="r")[name][...])


def _own(maps: Path) -> dict[float, float]:
    """torso value -> numpy's quantile Q of that setting's non-zero stored values (in float64)."""
    out = {}
    for v in SETTINGS:
        a = _stored(maps, v)
        out[v] = float(np.quantile(a[a > 0].astype(np.float64), Q))
    return out


def _scene(tmp_path, preset, maps, planner: dict) -> str:
    """support/deep_table.py's scene with a 0.6 m table and the cup near its edge (both settings reach
    it), planned with ``planner`` (and 40 base yaws)."""
    path = Path(deep_table_scene(tmp_path, preset, maps))
    scene = yaml.safe_load(path.read_text())
    scene["obstacles"][0]["box"]["size"] = [0.6, 0.6, 0.75]
    scene["objects"][0]["position"] = [2.85, 2.5, 0.8]
    scene["planner"] = {"yaw_steps": 40, **planner}
    path.write_text(yaml.safe_dump(scene))
    return str(path)


@pytest.mark.slow
def test_each_setting_gets_its_own_quantile(tmp_path, pitch):
    _, preset, maps = pitch
    own = _own(maps)
    # the settings' quantiles differ by more than the tolerance below: the test tells them apart
    assert abs(own[0.0] - own[0.6]) > 0.01 * own[0.0]
    p = Planner(_scene(tmp_path, preset, maps, {"threshold_quantile": Q}), "sequential")
    assert set(p.setting_thresholds) == {("arm", v) for v in SETTINGS}
    for v in SETTINGS:
        assert p.setting_thresholds[("arm", v)] == pytest.approx(own[v], rel=2e-3), v
        assert p.context.threshold("arm", v) == p.setting_thresholds[("arm", v)]
        assert p.problems.threshold("arm", v) == p.setting_thresholds[("arm", v)]
    # the arm's own threshold is its own map's (the reference setting's); the config holds the smallest
    assert p.thresholds["arm"] == p.setting_thresholds[("arm", 0.0)]
    assert p.context.threshold("arm") == p.thresholds["arm"]
    assert p.base_config.threshold == min(p.setting_thresholds.values())


def test_every_option_is_thresholded_by_its_own_setting(tmp_path, pitch):
    """The feasible region (of all options and of each setting's alone), the pairs and the Eq. 6
    ranking keep exactly the cells each option's own setting's threshold keeps; some cells lie between
    the two settings' thresholds (the arm's threshold at every setting would drop them)."""
    _, preset, maps = pitch
    p = Planner(_scene(tmp_path, preset, maps, {"threshold_quantile": Q}), "sequential")
    own = {v: np.float32(p.setting_thresholds[("arm", v)]) for v in SETTINGS}
    assert own[0.6] < own[0.0]  # the leaning setting's distribution lies lower here
    shape, problems = p.world.nav.shape, p.problems
    nav, _ = navigation_cost(p.world.factor, p.world.feasible, p.start_cell(), p.world.nav.resolution)
    between = 0
    for i in range(len(problems.steps)):
        opts = problems.options(i)
        assert {o.torso for o in opts} == set(SETTINGS)
        keeps = [o.full_value(shape) >= own[o.torso] for o in opts]
        assert (problems.feasible_region(i) == np.logical_or.reduce(keeps)).all()
        for v in SETTINGS:
            alone = [k for o, k in zip(opts, keeps) if o.torso == v]
            assert (problems.feasible_region(i, [o for o in opts if o.torso == v]) == np.logical_or.reduce(alone)).all()
        assert problems.pairs(i) == {(o.arm, o.candidate.grasp) for o, k in zip(opts, keeps) if k.any()}
        ranked = rank_eq6(p.context, opts, nav, np.zeros(shape), per_option=10**6)
        finite = np.isfinite(nav)
        want = {(k, int(c)) for k, m in enumerate(keeps) for c in np.flatnonzero(m & finite)}
        assert {(r.option, r.cell) for r in ranked} == want
        between += sum(int(((o.value >= own[0.6]) & (o.value < own[0.0])).sum()) for o in opts if o.torso == 0.6)
    assert between > 0
    result = p.plan()
    assert all(s.ok for s in result.steps), [s.reason for s in result.steps]


def test_whole_task_regions_use_each_settings_threshold(tmp_path, pitch):
    _, preset, maps = pitch
    p = Planner(_scene(tmp_path, preset, maps, {"threshold_quantile": Q}), "global")
    own = {v: np.float32(p.setting_thresholds[("arm", v)]) for v in SETTINGS}
    for i in range(len(p.problems.steps)):
        for v in SETTINGS:
            opts = p.problems.held_options(i, v)
            regions = map_regions(p.context, i, held=v)
            for g, mask in zip(regions.groups, regions.dense()):
                keeps = [o.full_value(mask.shape) >= own[v] for o in opts if (o.arm, o.candidate.grasp) == g]
                assert (mask == np.logical_or.reduce(keeps) & p.world.feasible).all(), (i, v, g)


def test_an_explicit_threshold_applies_to_every_setting(tmp_path, pitch):
    _, preset, maps = pitch
    p = Planner(_scene(tmp_path, preset, maps, {"threshold": 0.005}), "sequential")
    assert dict(p.setting_thresholds) == {}
    assert all(p.context.threshold("arm", v) == 0.005 for v in SETTINGS)
    shape = p.world.nav.shape
    keeps = [o.full_value(shape) >= np.float32(0.005) for o in p.problems.options(0)]
    assert (p.problems.feasible_region(0) == np.logical_or.reduce(keeps)).all()


@pytest.mark.skipif(not (TIAGO_MAPS / "zarr.json").is_file(), reason="no maps/tiago")
def test_a_shifted_maps_settings_keep_the_arms_threshold():
    rmap = open_map(TIAGO_MAPS, "arm")
    assert rmap.torso is not None and rmap.torso.kind == "shifted"
    assert len(map_variants({"arm": rmap})["arm"]) > 1
    assert setting_thresholds(PlannerConfig(), {"arm": rmap}) == {}


@pytest.mark.slow
def test_maps_check_checks_every_setting_with_the_robot_held_there(pitch):
    robot, preset, maps = pitch
    proc = run("maps", "check", str(maps), "--robot", str(preset), "--samples", "4", "--json", "-q")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)["arms"]["arm"]
    assert doc["torso"]["checked"] == "every setting" and doc["torso"]["kind"] == "per_setting"
    assert [s["setting"]["value"] for s in doc["settings"]] == [0.6]
    lean = doc["settings"][0]
    assert lean["setting"]["array"] == f"arm@{JOINT}=0.6"
    # each check counted its own setting's stored cells (numpy on the stored arrays)
    assert doc["map_positive_cells"] == int((_stored(maps, 0.0) > 0).sum())
    assert lean["map_positive_cells"] == int((_stored(maps, 0.6) > 0).sum())
    assert doc["map_positive_cells"] != lean["map_positive_cells"]
    # the same cells and IK outcomes as check_map of that setting's map with the robot held at 0.6 rad
    view = open_map(maps, "arm", robot).at_torso(0.6)
    direct = check_map(robot.with_fixed({JOINT: 0.6}), view, samples=4, seed=0, pose_level=False)
    for key in ("positive_cells", "negative_cells", "true_positives", "false_negatives"):
        assert lean[key] == direct[key], key
    text = run("maps", "check", str(maps), "--robot", str(preset), "--samples", "4", "-q")
    assert text.returncode == 0, text.stderr
    heads = [ln for ln in text.stdout.splitlines() if "pose-level" in ln]
    assert len(heads) == 2 and "(reference)" in heads[0] and f"{JOINT} = 0.6 rad" in heads[1]


def test_checking_a_settings_map_with_another_settings_robot_is_refused(pitch):
    robot, _, maps = pitch
    view = open_map(maps, "arm", robot).at_torso(0.6)
    with pytest.raises(MapError, match=f"{JOINT} at 0.6.*holds it at 0") as err:
        check_map(robot, view, samples=2, pose_level=False)
    assert "\n" not in str(err.value)
    with pytest.raises(MapError, match=JOINT):
        check_map(robot.with_fixed({JOINT: 0.6}), open_map(maps, "arm", robot), samples=2, pose_level=False)


@pytest.mark.skipif(not (TIAGO_MAPS / "zarr.json").is_file(), reason="no maps/tiago")
def test_maps_check_of_a_shifted_map_says_the_reference_stands_for_every_setting():
    proc = run("maps", "check", str(TIAGO_MAPS), "--samples", "1", "--json", "-q")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)["arms"]["arm"]
    assert doc["torso"]["checked"] == "reference" and "settings" not in doc
    text = run("maps", "check", str(TIAGO_MAPS), "--samples", "1", "-q")
    assert "the reference's check stands for every setting" in text.stdout
