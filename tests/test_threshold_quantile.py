"""One threshold meaning on every robot: the map threshold as a quantile of each arm's own values.

A build records the quantiles of the non-zero values (placement/maps/quantiles.py); the planner
resolves ``planner.threshold_quantile`` (default) per arm, or takes ``planner.threshold`` as a map
value on every arm; every stage applies the arm's own. Also: a map records how the preset defines its
base frame, and a map whose base frame is defined otherwise does not open.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from support.cli import assert_one_line_error, run
from support.planning import write_scene
from support.storage import SMALL, reseal_arm, set_root

import placement
from placement.errors import MapError
from placement.maps.opening import open_map
from placement.maps.quantiles import ESTIMATE_STRIDE, estimate_quantiles, levels
from placement.planning.methods.ranking import rank_by_cost
from placement.planning.methods.search import other_yaws
from placement.planning.methods.weighted import rank_eq6
from placement.planning.planner import Planner
from placement.planning.problems.cache import StepProblems
from placement.planning.problems.thresholds import Thresholds
from placement.planning.settings import PlannerConfig
from placement.planning.world.navigation import navigation_cost
from placement.robots.preset import PRESET_DIR
from placement.scene import SceneError

PR2_MAPS = Path(__file__).resolve().parents[1] / "maps" / "pr2"
PAPER = 0.0235


def _nonzero(rmap) -> np.ndarray:
    """The stored non-zero values, in float64 (numpy's quantile of float32 data at a scalar level
    interpolates in float32; the record holds float64 quantiles)."""
    v = rmap.values
    return v[v > 0].astype(np.float64)


def test_the_recorded_quantiles_are_numpys_quantiles_of_the_stored_non_zero_values(maps_dir):
    for arm in ("right", "left"):
        rmap = open_map(maps_dir, arm)
        rec = rmap.meta["value_quantiles"]  # as stored and read back
        nz = _nonzero(rmap)
        assert rec["count"] == nz.size == rmap.meta["filled_cells"]
        assert rec["levels"] == 1000 and rec["source"] == "all cells"
        assert rec["values"] == np.quantile(nz, levels()).tolist()  # exactly
        assert rec["values"] == np.quantile(nz.astype(np.float32), levels()).tolist()  # as stored
        assert rec["values"][0] == nz.min() and rec["values"][-1] == nz.max()


def _planner(tmp_path, maps_dir, planner: dict, **kw) -> Planner:
    return Planner(write_scene(tmp_path, maps_dir, planner={"yaw_steps": 40, **planner}), "sequential", **kw)


def test_a_scene_threshold_quantile_resolves_to_each_arms_map_value(tmp_path, maps_dir):
    nz = {arm: _nonzero(open_map(maps_dir, arm)) for arm in ("right", "left")}
    for q in (0.5, 0.25):  # recorded levels: numpy's quantile exactly
        p = _planner(tmp_path, maps_dir, {"threshold_quantile": q})
        want = {arm: float(np.quantile(v, q)) for arm, v in nz.items()}
        assert dict(p.thresholds) == want
        assert p.config.threshold == min(want.values()) and p.config.threshold_quantile == q
    # between recorded levels: interpolated, within the table's step of numpy's quantile
    p = _planner(tmp_path, maps_dir, {"threshold_quantile": 0.3435})
    for arm, v in nz.items():
        assert p.thresholds[arm] == pytest.approx(np.quantile(v, 0.3435), rel=2e-3)


def test_a_scene_threshold_is_a_map_value_on_every_arm(tmp_path, maps_dir):
    p = _planner(tmp_path, maps_dir, {"threshold": 0.04})
    assert dict(p.thresholds) == {"right": 0.04, "left": 0.04}
    assert p.config.threshold == 0.04 and p.config.threshold_quantile is None


def test_the_default_gives_the_pr2_the_papers_threshold(tmp_path, maps_dir):
    """The default quantile is the share of the default PR2 maps' cells below 0.0235; on the small test
    maps (700 k samples, 10 cm cells) it lands within 3 % of it too."""
    p = _planner(tmp_path, maps_dir, {})
    assert p.config.threshold_quantile == PlannerConfig().threshold_quantile
    for arm in ("right", "left"):
        assert p.thresholds[arm] == pytest.approx(PAPER, rel=0.03), arm


@pytest.mark.skipif(not (PR2_MAPS / "zarr.json").is_file(), reason="no default PR2 maps (make maps)")
def test_the_default_on_the_default_pr2_maps_stays_at_or_just_under_the_papers_threshold():
    q = PlannerConfig().threshold_quantile
    assert q is not None
    for arm in ("right", "left"):
        value = open_map(PR2_MAPS, arm).quantile_value(q)
        assert PAPER * 0.995 <= value <= PAPER, arm


@pytest.mark.slow
def test_both_keys_are_one_error_naming_both(tmp_path, maps_dir):
    path = write_scene(tmp_path, maps_dir, planner={"threshold": 0.02, "threshold_quantile": 0.3})
    with pytest.raises(SceneError, match="both threshold and threshold_quantile") as err:
        Planner(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)
    assert_one_line_error(run("query", str(path), "--json", "-q"), "threshold", "threshold_quantile")


@pytest.mark.slow
@pytest.mark.parametrize("value", [-0.1, 1.5])
def test_threshold_quantile_out_of_range_is_one_line(tmp_path, maps_dir, value):
    path = write_scene(tmp_path, maps_dir, planner={"threshold_quantile": value})
    assert_one_line_error(run("query", str(path), "--json", "-q"), "planner.threshold_quantile")


@pytest.mark.slow
def test_every_stage_applies_each_arms_own_threshold(tmp_path, maps_dir):
    """Arms with thresholds far apart: the feasible region, the pairs, the whole-task regions, the Eq. 6
    ranking and the search's other yaws keep exactly the cells each arm's threshold keeps."""
    p = _planner(tmp_path, maps_dir, {"threshold_quantile": 0.5})
    nz = {arm: _nonzero(open_map(maps_dir, arm)) for arm in ("right", "left")}
    own = {"right": float(np.quantile(nz["right"], 0.2)), "left": float(np.quantile(nz["left"], 0.8))}
    cfg = replace(p.config, threshold=min(own.values()))
    thresholds = Thresholds(own, {}, cfg.threshold)
    problems = StepProblems(p.scene, p.world, p.maps, cfg, p.yaws, p.robot.gripper.max_opening, thresholds)
    ctx = replace(p.context, config=cfg, thresholds=thresholds, problems=problems)
    shape = p.world.nav.shape
    between = 0
    for i in range(len(problems.steps)):
        opts = problems.options(i)
        keeps = [o.full_value(shape) >= np.float32(own[o.arm]) for o in opts]
        assert (problems.feasible_region(i) == np.logical_or.reduce(keeps)).all()
        assert problems.pairs(i) == {(o.arm, o.candidate.grasp) for o, k in zip(opts, keeps) if k.any()}
        regions = p.method.regions(ctx, i)
        for g, mask in zip(regions.groups, regions.dense()):
            want = np.logical_or.reduce([k for o, k in zip(opts, keeps) if (o.arm, o.candidate.grasp) == g])
            assert (mask == want & p.world.feasible).all(), g
        nav, _ = navigation_cost(p.world.factor, p.world.feasible, p.start_cell(), p.world.nav.resolution)
        heur = np.zeros(shape)
        ranked = rank_eq6(ctx, opts, nav, heur, per_option=10**6)
        finite = np.isfinite(nav)
        want_cells = {(k, int(c)) for k, m in enumerate(keeps) for c in np.flatnonzero(m & finite)}
        assert {(r.option, r.cell) for r in ranked} == want_cells
        for k, o in enumerate(opts):  # each option's order (tiers by its own threshold, then cost) as alone
            alone = rank_by_cost([o], nav, heur, replace(cfg, threshold=own[o.arm], ik_tries=10**6), p.yaws)
            assert [(r.cell, r.yaw, r.cost) for r in ranked if r.option == k] == [
                (r.cell, r.yaw, r.cost) for r in alone
            ]
        more, values = other_yaws(ctx, opts, nav, heur)
        assert all(v >= np.float32(own[opts[k].arm]) for (k, _, _), v in values.items())
        # cells one threshold for all (the smallest) would have kept: the test tells the two apart
        between += sum(
            int(((o.value >= own["right"]) & (o.value < own["left"])).sum()) for o in opts if o.arm == "left"
        )
    assert between > 0


@pytest.mark.slow
def test_a_map_without_recorded_quantiles_estimates_them_from_every_8th_chunk(tmp_path, maps_dir):
    import shutil

    old = tmp_path / "old"
    shutil.copytree(maps_dir, old)
    for arm in ("right", "left"):
        import zarr

        group = zarr.open_group(str(old), mode="r+")
        attrs = dict(group[arm].attrs.asdict())
        exact = attrs.pop("value_quantiles")
        group[arm].attrs.clear()
        group[arm].attrs.update(attrs)
        reseal_arm(old, arm)  # as a map built before the record was
        rmap = open_map(old, arm)
        assert "value_quantiles" not in rmap.meta
        # the reference: the same chunks sliced out of the whole array
        v = rmap.values
        _, _, nz, _, n_pitch, n_roll = v.shape
        parts = []
        for flat in range(0, nz * n_pitch * n_roll, ESTIMATE_STRIDE):
            iz, rest = divmod(flat, n_pitch * n_roll)
            c = v[:, :, iz, :, rest // n_roll, rest % n_roll]
            parts.append(c[c > 0])
        sub = np.concatenate(parts)
        est = rmap.value_quantiles
        assert est["values"] == np.quantile(sub, levels()).tolist() and est["count"] == sub.size
        assert "estimated" in est["source"]
        assert est == estimate_quantiles(rmap.store, arm, rmap.grid.shape)
        # close to the exact quantiles over the middle of the distribution (coarse test map: 1 in 8 chunks)
        mid = slice(100, 901)
        assert np.allclose(est["values"][mid], exact["values"][mid], rtol=0.1)
        assert rmap.quantile_value(0.343) == pytest.approx(PAPER, rel=0.05)


def _preset(tmp_path: Path, name: str, xyz: str) -> Path:
    text = (PRESET_DIR / "pr2.yaml").read_text()
    assert "base_frame: base_footprint" in text
    text = text.replace(
        "base_frame: base_footprint",
        f"base_frame: base_floor\nbase_frame_parent: base_footprint\nbase_frame_xyz: {xyz}",
        1,
    )
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_map_records_its_base_frame_definition_and_refuses_another(tmp_path):
    a = placement.load_robot(_preset(tmp_path, "a.yaml", "[0.0, 0.0, 0.0]"))
    b = placement.load_robot(_preset(tmp_path, "b.yaml", "[0.05, 0.0, 0.0]"))
    built = placement.build_map(a, "right", samples=1000, seed=2, progress=False, **SMALL)
    path = placement.save_maps(tmp_path / "map", a, {"right": built})
    assert open_map(path, "right", a).store.root["base_frame_definition"] == {
        "parent": "base_footprint",
        "xyz": [0.0, 0.0, 0.0],
    }
    with pytest.raises(MapError, match="rebuild the map") as err:
        open_map(path, "right", b)
    assert "base_frame_xyz" in str(err.value) and "[0.05, 0, 0]" in str(err.value)
    with pytest.raises(MapError):  # a rebuild into it refuses too, before sampling
        placement.save_maps(path, b, {"right": placement.build_map(b, "right", samples=10, progress=False, **SMALL)})
    # a map built before the record: accepted
    set_root(path, "zarr", lambda root: root.pop("base_frame_definition"))
    assert open_map(path, "right", b).arm == "right"


def test_a_urdf_base_frame_is_recorded_as_null(maps_dir):
    assert open_map(maps_dir, "right").store.root["base_frame_definition"] is None
