"""Stored plans: the planner's results on fixed scenes and the test maps must not change by accident.

The scenes of ``tests/data/regression`` are planned with every method, with the PR2 as a 0.47 m circle
(``tests/data/pr2_round.yaml``; plans in ``plans.json``) and with the built-in PR2 and its square
footprint (``plans_footprint.json``), collisions checked, and compared field by field (timings
excluded); every place keeps its pick's arm and grasp. When a plan is meant to change, regenerate
them with ``PLACEMENT_REGEN_PLANS=1 pytest tests/test_regression.py`` and say why in the commit (the
git history of the two files says how the plans came to be).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import replace
from pathlib import Path

import pytest
from support.plans import strip_timings

from placement.planning.planner import Planner
from placement.scene import load_scene

pytestmark = pytest.mark.slow

DATA = Path(__file__).parent / "data" / "regression"
#: stored plans per robot preset (None: the scenes' own, the built-in PR2)
PLANS = {str(DATA.parent / "pr2_round.yaml"): DATA / "plans.json", None: DATA / "plans_footprint.json"}
METHODS = ("sequential", "single-step", "irm", "fixed", "optimal", "global")
REL = 1e-7  # joints come from an iterative IK: same code, same machine kind, same seeds


def _compare(got, want, where: str) -> None:
    if isinstance(want, dict):
        # keys added to the plan document since the plans were stored (a step's ``configuration``) are
        # accepted; every stored key must still be there with its value
        assert isinstance(got, dict) and set(want) <= set(got), f"{where}: keys {sorted(want)} not all in {sorted(got)}"
        for k in want:
            _compare(got[k], want[k], f"{where}.{k}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), f"{where}: length {len(got)} != {len(want)}"
        for i, (g, w) in enumerate(zip(got, want)):
            _compare(g, w, f"{where}[{i}]")
    elif isinstance(want, float):
        assert isinstance(got, (int, float)) and math.isclose(got, want, rel_tol=REL, abs_tol=1e-9), (
            f"{where}: {got} != {want}"
        )
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def _plans(maps_dir, preset: str | None, collisions: bool = True) -> dict:
    out = {}
    for path in sorted(DATA.glob("*.yaml")):
        scene = load_scene(path)
        # no time budget (the search stops when every candidate was tried, or at its cap): the plans
        # must not depend on the machine's speed
        scene = replace(scene, planner={**scene.planner, "ik_budget_ms": 60000.0, "time_budget_s": 3600.0})
        planner = Planner(
            scene if preset is None else replace(scene, robot_preset=preset),
            METHODS[0],
            maps_dir,
            collisions=collisions,
        )
        for method in METHODS:
            planner.set_method(method)
            out[f"{path.stem}/{method}"] = strip_timings(planner.plan().to_json())
    return out


@pytest.mark.parametrize("preset", list(PLANS), ids=["round_pr2", "pr2_footprint"])
def test_plans_match_the_stored_plans(maps_dir, preset):
    got = _plans(maps_dir, preset)
    if os.environ.get("PLACEMENT_REGEN_PLANS"):
        PLANS[preset].write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        pytest.skip(f"regenerated {PLANS[preset]}")
    want = json.loads(PLANS[preset].read_text())
    assert sorted(got) == sorted(want)
    for key in want:
        _compare(got[key], want[key], key)


def test_every_place_keeps_the_arm_and_grasp_of_its_pick(maps_dir):
    """A robot cannot hand an object from one gripper to the other between its pick and its place: on
    the regression scenes (round PR2, no collision checks), every method's places keep the arm and the
    grasp of their picks."""
    got = _plans(maps_dir, str(DATA.parent / "pr2_round.yaml"), collisions=False)
    pairs = 0
    for key, plan in got.items():
        done = {s["target"]: s for s in plan["steps"] if s["action"] == "pick" and s.get("status", "ok") == "ok"}
        for s in plan["steps"]:
            if s["action"] == "place" and s.get("status", "ok") == "ok":
                pick = done[s["object"]]
                assert (s["arm"], s["grasp"]) == (pick["arm"], pick["grasp"]), key
                pairs += 1
    assert pairs >= 80
