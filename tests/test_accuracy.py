"""Map accuracy against IK (placement.maps.accuracy.check_map) on a small PR2 map."""

from __future__ import annotations

import numpy as np
import pytest

import placement
from placement.errors import MapError
from placement.maps.accuracy import check_map
from placement.maps.build import BuiltMap, arm_reach

SAMPLES = 60


@pytest.fixture(scope="module")
def small_map(pr2):
    """A sparse map of the PR2 right arm (20k samples, default grid)."""
    return placement.build_map(pr2, "right", samples=20000, progress=False)


@pytest.fixture(scope="module")
def report(pr2, small_map):
    calls = []
    out = check_map(pr2, small_map, samples=SAMPLES, seed=0, progress=lambda d, t: calls.append((d, t)))
    out["_calls"] = calls
    return out


@pytest.mark.slow
def test_counts_consistent(report):
    r = report
    assert r["positives_drawn"] == SAMPLES and r["negatives_drawn"] == SAMPLES
    assert r["true_positives"] + r["false_positives"] == SAMPLES
    assert r["true_negatives"] + r["false_negatives"] == SAMPLES
    assert len(r["positive_cells"]) == len(set(r["positive_cells"])) == SAMPLES
    assert len(r["negative_cells"]) == len(set(r["negative_cells"])) == SAMPLES
    assert len(r["false_positive_cells"]) == r["false_positives"]
    assert len(r["false_negative_cells"]) == r["false_negatives"]
    assert r["accuracy"] == pytest.approx((r["true_positives"] + r["true_negatives"]) / (2 * SAMPLES))
    for key in (
        "precision",
        "negative_predictive_value",
        "recall_estimate",
        "specificity_estimate",
        "accuracy",
        "accuracy_estimate",
    ):
        assert 0.0 <= r[key] <= 1.0, key
    assert r["time_s"] >= r["ik_time_s"] > 0
    assert r["_calls"][-1] == (2 * SAMPLES, 2 * SAMPLES) and len(r["_calls"]) == 2 * SAMPLES


def test_precision_high(report):
    # Positives come from real samples: the cell centre is within one cell of a reachable pose.
    assert report["precision"] > 0.8


def test_tolerances_are_one_cell(report, small_map):
    g = small_map.grid
    assert report["pos_tol_m"] == g.resolution
    assert report["rot_tol_rad"] == pytest.approx(max(g.angle_steps))


def test_drawn_cells_are_in_their_class(pr2, report, small_map):
    flat = small_map.values.reshape(-1)
    assert np.all(flat[report["positive_cells"]] > 0)
    assert np.all(flat[report["negative_cells"]] == 0)
    assert report["map_positive_cells"] == int(np.count_nonzero(flat))
    # Negatives are restricted to positions within the arm's reach bound.
    centre, reach = arm_reach(pr2, "right")
    pos = small_map.grid.centre(np.asarray(report["negative_cells"]))[:, :3, 3]
    assert np.all(np.linalg.norm(pos - centre, axis=1) <= reach + 1e-9)


@pytest.mark.slow
def test_deterministic_and_threshold(pr2, small_map, report):
    again = check_map(pr2, small_map, samples=SAMPLES, seed=0)
    for key in ("positive_cells", "negative_cells", "true_positives", "false_negatives"):
        assert again[key] == report[key]
    # A threshold above every value: no positives, undefined precision, no crash.
    none = check_map(pr2, small_map, samples=5, threshold=float(small_map.values.max()) + 1.0)
    assert none["positives_drawn"] == 0 and none["precision"] is None
    assert none["negatives_drawn"] == 5


def test_wrong_robot_is_rejected(pr2, small_map):
    other = BuiltMap(small_map.values, {**small_map.meta, "robot": "not-pr2"})
    with pytest.raises(MapError):
        check_map(pr2, other, samples=5)


@pytest.mark.slow
def test_opened_map(pr2, tmp_path):
    """The same check on a map saved and opened lazily (coarse grid to keep it quick)."""
    built = placement.build_map(pr2, "right", samples=5000, resolution=0.1, bins=(10, 5, 10), progress=False)
    placement.save_maps(tmp_path / "pr2", pr2, {"right": built})
    rmap = placement.open_map(tmp_path / "pr2", "right", pr2)
    a = check_map(pr2, rmap, samples=20, seed=1)
    b = check_map(pr2, built, samples=20, seed=1)
    assert a["positive_cells"] == b["positive_cells"] and a["negative_cells"] == b["negative_cells"]
    assert a["true_positives"] + a["false_positives"] == 20
    assert a["pos_tol_m"] == 0.1
    assert a["precision"] > 0.8


def test_wilson_interval():
    from placement.maps.accuracy import wilson

    lo, hi = wilson(90, 100)
    assert lo == pytest.approx(0.8256, abs=1e-3) and hi == pytest.approx(0.9448, abs=1e-3)
    assert wilson(0, 0) is None
    lo, hi = wilson(0, 20)
    assert lo == 0.0 and 0.1 < hi < 0.2


def test_poses_in_cells_stay_in_their_cells(small_map):
    from placement.maps.accuracy import poses_in_cells

    g = small_map.grid
    cells = np.random.default_rng(0).integers(0, g.size, 2000)
    assert np.array_equal(g.index(poses_in_cells(g, cells, np.random.default_rng(1))), cells)


def test_pose_level_metrics(pr2, report, small_map):
    p = report["pose_level"]
    assert p["pos_tol_m"] == 0.01 and p["rot_tol_rad"] == 0.05 and p["witness_seeded"]
    assert p["precision_poses"] == SAMPLES and 0 <= p["precision_reached"] <= SAMPLES
    assert p["precision"] == p["precision_reached"] / SAMPLES
    assert p["precision_ci95"][0] <= p["precision"] <= p["precision_ci95"][1]
    # 20k samples fill few 5 cm cells: the honest recall must say so
    assert p["recall_cells"] == SAMPLES and p["recall"] < 0.5
    assert p["recall_draws"] >= p["recall_cells"]


@pytest.mark.slow
def test_pose_level_recall_and_precision_can_fail(pr2, small_map):
    """A map that marks every cell reachable has recall 1 and a poor precision; an empty one recall 0."""
    from placement.maps.accuracy import pose_metrics

    full = BuiltMap(np.ones_like(small_map.values), small_map.meta)
    p = pose_metrics(pr2, full, samples=30, seed=2)
    assert p["recall"] == 1.0 and not p["witness_seeded"] and p["precision"] < 0.5
    empty = BuiltMap(np.zeros_like(small_map.values), small_map.meta)
    p = pose_metrics(pr2, empty, samples=10, seed=2)
    assert p["recall"] == 0.0 and p["precision"] is None and p["precision_ci95"] is None
