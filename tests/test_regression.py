"""Stored plans: the planner's results on fixed scenes and the test maps must not change by accident.

The plans in ``tests/data/regression/plans.json`` were computed by the planner before the planning
layer was restructured (issue 11) and are compared field by field (timings excluded). When a plan
is meant to change, regenerate them with ``PLACEMENT_REGEN_PLANS=1 pytest tests/test_regression.py``
and say why in the commit.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

from placement.planning.planner import Planner

DATA = Path(__file__).parent / "data" / "regression"
PLANS = DATA / "plans.json"
METHODS = ("sequential", "single-step", "irm", "fixed", "optimal")
REL = 1e-7  # joints come from an iterative IK: same code, same machine kind, same seeds


def _strip(value):
    """The plan without its timings (they change from run to run)."""
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if k not in ("timings_ms", "update")}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def _compare(got, want, where: str) -> None:
    if isinstance(want, dict):
        assert isinstance(got, dict) and sorted(got) == sorted(want), f"{where}: keys {sorted(got)} != {sorted(want)}"
        for k in want:
            _compare(got[k], want[k], f"{where}.{k}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), f"{where}: length {len(got)} != {len(want)}"
        for i, (g, w) in enumerate(zip(got, want)):
            _compare(g, w, f"{where}[{i}]")
    elif isinstance(want, float):
        assert isinstance(got, (int, float)) and math.isclose(got, want, rel_tol=REL, abs_tol=1e-9), \
            f"{where}: {got} != {want}"
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def _plans(maps_dir) -> dict:
    out = {}
    for scene in sorted(DATA.glob("*.yaml")):
        planner = Planner(scene, METHODS[0], maps_dir)
        for method in METHODS:
            planner.set_method(method)
            out[f"{scene.stem}/{method}"] = _strip(planner.plan().to_json())
    return out


def test_plans_match_the_stored_plans(maps_dir):
    got = _plans(maps_dir)
    if os.environ.get("PLACEMENT_REGEN_PLANS"):
        PLANS.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        pytest.skip(f"regenerated {PLANS}")
    want = json.loads(PLANS.read_text())
    assert sorted(got) == sorted(want)
    for key in want:
        _compare(got[key], want[key], key)
