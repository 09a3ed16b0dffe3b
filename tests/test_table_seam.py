"""Tables pushed together are one surface: an object set down on their seam rests on both, where it
was called in collision with the neighbour table (placement/collision/held.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from placement.collision.held import LEVEL_TOLERANCE, extends
from placement.planning import Planner

ROOT = Path(__file__).resolve().parents[1]


def seam_scene(tmp_path: Path, maps: Path, rise: float = 0.0) -> Path:
    """The table-clearing example with place table b pushed against place table a (b ``rise`` [m]
    taller) and place_a on their seam."""
    doc = yaml.safe_load((ROOT / "examples" / "table_clearing.yaml").read_text())
    doc["maps"] = str(maps)
    doc["planner"] = {"ik_budget_ms": 60000, "time_budget_s": 3600}  # plans that no load on the machine changes
    for ob in doc["obstacles"]:
        if ob["name"] == "place_table_b":
            ob["box"]["center"] = [2.1, 1.6, 0.375 + rise / 2]
            ob["box"]["size"] = [0.5, 0.5, 0.75 + rise]
    doc["obstacles"].append(
        {"name": "place_table_c", "box": {"center": [8.4, 1.6, 0.375], "size": [0.5, 0.5, 0.75]}, "table": True}
    )
    for loc in doc["place_locations"]:
        if loc["name"] == "place_a":
            loc["position"] = [1.85, 1.6, 0.85 + rise]
    path = tmp_path / "seam.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def box(lo, hi):
    return np.array([lo, hi], dtype=float)


def test_a_level_touching_piece_continues_the_surface():
    table = box([0, 0, 0], [1, 1, 0.75])
    assert extends(table, box([1, 0, 0], [2, 1, 0.75]))  # pushed against it
    assert extends(table, box([1, 0, 0], [2, 1, 0.75 + 0.5 * LEVEL_TOLERANCE]))
    assert not extends(table, box([1, 0, 0], [2, 1, 0.76]))  # 1 cm taller: a step, not the surface
    assert not extends(table, box([1.01, 0, 0], [2, 1, 0.75]))  # 1 cm apart: a gap
    assert not extends(table, box([3, 3, 0], [4, 4, 0.75]))  # level but elsewhere


@pytest.mark.parametrize("method", ["sequential", pytest.param("global", marks=pytest.mark.slow)])
def test_an_object_on_the_seam_of_two_tables_is_set_down(tiny_maps, tmp_path, method):
    planner = Planner(seam_scene(tmp_path, tiny_maps), method, tiny_maps)
    result = planner.plan()
    assert result.ok, result.failed_step.reason if result.failed_step else ""
    assert result.verify(planner.robot, scene=planner.scene) == []
    places = [s for s in result.steps if s.action == "place" and s.target == "place_a"]
    assert places and all(s.support in ("place_table_a", "place_table_b") for s in places)


def test_on_a_step_the_object_rests_on_the_taller_table(tiny_maps, tmp_path):
    """Table b 2 cm taller: the seam is a step; the object is set down on b's top, above a's."""
    planner = Planner(seam_scene(tmp_path, tiny_maps, rise=0.02), "sequential", tiny_maps)
    result = planner.plan()
    assert result.ok, result.failed_step.reason if result.failed_step else ""
    place = next(s for s in result.steps if s.action == "place" and s.target == "place_a")
    assert place.support == "place_table_b" and place.placed_pose is not None
    cup = planner.scene.object(place.object)
    assert place.placed_pose[2, 3] == pytest.approx(0.77 + cup.size[2] / 2, abs=1e-9)
