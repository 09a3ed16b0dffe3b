"""The exact footprint clearance of placement.planning.verification.clearance, against coal's distance between boxes
(an independent reference: two boxes of one height standing on the floor are as far apart as their
rectangles), and PlanResult.verify(scene=...) catching a base moved into a table."""

from __future__ import annotations

import dataclasses
import math

import coal
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from placement.planning import Planner
from placement.planning.verification.clearance import outline, polygon_distance
from placement.scene.model import Box

boxes = st.builds(
    lambda x, y, sx, sy, yaw: Box(np.array([x, y, 0.5]), np.array([sx, sy, 1.0]), yaw),
    st.floats(-2, 2),
    st.floats(-2, 2),
    st.floats(0.05, 1.5),
    st.floats(0.05, 1.5),
    st.floats(-math.pi, math.pi),
)


def coal_distance(a: Box, b: Box) -> float:
    def placed(box: Box):
        c, s = math.cos(box.yaw), math.sin(box.yaw)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return coal.Box(*map(float, box.size)), coal.Transform3s(R, np.asarray(box.center, dtype=float))

    (ga, ta), (gb, tb) = placed(a), placed(b)
    res = coal.DistanceResult()
    coal.distance(ga, ta, gb, tb, coal.DistanceRequest(), res)
    return max(float(res.min_distance), 0.0)


@settings(max_examples=300, deadline=None)
@given(boxes, boxes)
def test_rectangle_distance_is_coals(a, b):
    got = polygon_distance(outline(a)[0], outline(b)[0])
    want = coal_distance(a, b)
    assert got == pytest.approx(want, abs=1e-5)  # coal's GJK converges to about 1e-6 m


def test_a_square_three_centimetres_from_a_table():
    # the 1 m square [0, 1]^2 and a table from x = 1.03: 3 cm apart; overlapping by 1 cm: 0
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    table = Box(np.array([1.53, 0.5, 0.4]), np.array([1.0, 0.5, 0.8]))
    assert polygon_distance(square, outline(table)[0]) == pytest.approx(0.03)
    assert polygon_distance(square + [0.04, 0.0], outline(table)[0]) == 0.0
    inside = Box(np.array([0.5, 0.5, 0.4]), np.array([0.1, 0.1, 0.8]))  # wholly inside: no edges cross
    assert polygon_distance(square, outline(inside)[0]) == 0.0


def test_verify_with_the_scene_catches_a_base_in_a_table(maps_dir):
    from pathlib import Path

    scene = Path(__file__).resolve().parents[1] / "examples" / "table_clearing_obstacles.yaml"
    planner = Planner(scene, "sequential", maps_dir)
    result = planner.plan()
    assert result.ok and result.verify(planner.robot, scene=planner.scene) == []
    s = result.steps[0]
    table = min(
        (o for o in planner.scene.obstacles if o.table), key=lambda o: math.dist(o.shape.center[:2], s.base[:2])
    )
    moved = dataclasses.replace(s, base=(float(table.shape.center[0]), float(table.shape.center[1]), s.base[2]))
    bad = dataclasses.replace(result, steps=[moved, *result.steps[1:]])
    problems = [p for p in bad.verify(planner.robot, scene=planner.scene) if "footprint" in p]
    assert problems == [
        f"step 0 ({s.action} {s.target}): the base footprint overlaps obstacle '{table.name}' (padding 0.02 m)"
    ]


@pytest.mark.slow
@pytest.mark.parametrize("padding", [0.0, 0.1])
def test_every_method_keeps_the_footprint_clear_on_a_crowded_room(maps_dir, tmp_path, padding):
    """A generated room of 50 objects with crates (100 steps): every base pose of every method keeps
    the scene's footprint padding by the exact polygon check, and where one method places a step,
    none calls it infeasible for the footprint (the methods share one footprint test)."""
    import yaml

    from placement.evaluation.generate import generate_scene

    doc = generate_scene(7, objects=50, obstacles=True, maps=str(maps_dir))
    doc.setdefault("planner", {}).update(footprint_padding=padding, time_budget_s=3600, ik_budget_ms=60000)
    path = tmp_path / "crowded.yaml"
    path.write_text(yaml.safe_dump(doc))
    results = {}
    for method in ("global", "sequential", "single-step", "irm", "fixed"):
        planner = Planner(path, method, maps_dir)
        results[method] = result = planner.plan()
        assert result.verify(planner.robot, scene=planner.scene) == [], method
    placed = {s.step for r in results.values() for s in r.steps if s.ok}
    for method, result in results.items():
        for s in result.steps:
            if not s.ok and s.step in placed:
                assert "footprint" not in (s.reason or ""), (method, s.reason)
    assert sum(s.ok for s in results["global"].steps) == 100
