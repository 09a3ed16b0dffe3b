"""Stored plans: the planner's results on fixed scenes and the test maps must not change by accident.

The scenes of ``tests/data/regression`` are planned with every method, with the PR2 as a 0.47 m circle
(``tests/data/pr2_round.yaml``; plans in ``plans.json``) and with the built-in PR2 and its square
footprint (``plans_footprint.json``), collisions checked, and compared field by field (timings
excluded). Where they came from: the first plans were the planner's before its planning layer was
restructured; collision checks then changed 7 steps (each a placement the check rejects); transfers
(a place keeps its pick's arm and grasp, the object set down upright as held, the carried object
checked) changed the places and, through them, the picks. ``scene_obstacles_s7_001`` had three
overlapping objects (object_1, object_3, object_6), which scenes may no longer have: object_3 and
object_6 were moved apart. ``placements_v1.json`` holds the placements of the planner before
transfers (base, arm, grasp), for the round PR2 without collision checks: half of its pick/place pairs
changed hands, which a robot cannot execute. When a plan is meant to change, regenerate them with
``PLACEMENT_REGEN_PLANS=1 pytest tests/test_regression.py`` and say why in the commit.
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


def test_the_old_plans_changed_hands_and_the_new_ones_do_not(maps_dir):
    """``placements_v1.json`` keeps the placements (status, base, arm, grasp per step) of the planner
    before transfers, for the round PR2 without collision checks: 47 of its 94 planned pick/place
    pairs placed the object with the other arm than the one that picked it. The same scenes planned
    now keep the arm (and the grasp) of every pick in its place, with every method."""
    old = json.loads((DATA / "placements_v1.json").read_text())
    changes = sum(
        a[2] != b[2] for steps in old.values() for a, b in zip(steps[::2], steps[1::2]) if a[0] == b[0] == "ok"
    )
    assert changes == 47
    got = _plans(maps_dir, str(DATA.parent / "pr2_round.yaml"), collisions=False)
    assert set(old) <= set(got)  # the methods of that planner, and the ones added since
    pairs = 0
    for key, plan in got.items():
        done = {s["target"]: s for s in plan["steps"] if s["action"] == "pick" and s.get("status", "ok") == "ok"}
        for s in plan["steps"]:
            if s["action"] == "place" and s.get("status", "ok") == "ok":
                pick = done[s["object"]]
                assert (s["arm"], s["grasp"]) == (pick["arm"], pick["grasp"]), key
                pairs += 1
    assert pairs >= 80
