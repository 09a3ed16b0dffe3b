"""The default method's local repair (placement.planning.program.repair): a search from afar covers
the whole region once instead of each window; the repaired chains are the same either way."""

from __future__ import annotations

import importlib
import math
from pathlib import Path

import placement.planning.methods.optimal as optimal
from placement.planning import Planner

# the module, not the function the program package exports under its name
repair_module = importlib.import_module("placement.planning.program.repair")

SCENE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing_obstacles.yaml"


def _plan(maps, monkeypatch, far: float) -> tuple[list[tuple], list[bool]]:
    """The plan's steps (arm, grasp, base) and each repair's outcome, with ``FAR`` set to ``far``."""
    monkeypatch.setattr(repair_module, "FAR", far)
    outcomes: list[bool] = []
    real = repair_module.repair

    def counted(dp, chain, i):
        out = real(dp, chain, i)
        outcomes.append(out is not None)
        return out

    monkeypatch.setattr(optimal, "repair", counted)
    result = Planner(SCENE, "global", maps).plan()
    assert result.ok
    return [(s.arm, s.grasp, s.base, s.travel_time_s) for s in result.steps], outcomes


def test_searches_over_the_whole_region_repair_as_windowed_searches_do(tiny_maps, monkeypatch):
    windowed, repairs = _plan(tiny_maps, monkeypatch, math.inf)  # never from afar: a search per window
    whole, repairs_whole = _plan(tiny_maps, monkeypatch, 0.0)  # always: one search for the whole region
    assert repairs and any(repairs), "the scene must exercise a successful repair"
    assert repairs_whole == repairs
    assert whole == windowed
