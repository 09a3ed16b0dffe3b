"""ARMAR-6 from its maker's package (``armar``), as a user meets it: ``robots init`` unedited (its
comma-written vector read as meant, its fixed hand found), small maps built, a generated
table-clearing room with crates planned by ``global`` and ``sequential``; every step verified by
pinocchio FK and the exact footprint check, and free by the independent collision check."""

from __future__ import annotations

import copy
import importlib.util
import os

import pytest
from oracle_collision import IndependentCheck

import placement
from placement.evaluation.generate import generate_scene
from placement.planning import Planner
from placement.robots.description import readable_urdf
from placement.robots.onboarding.propose import propose
from placement.robots.onboarding.render import render

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(importlib.util.find_spec("armar") is None, reason="the armar package is not installed"),
]


def test_the_makers_armar6_plans_a_room_first_try(tmp_path):
    import armar
    import yaml

    urdf = armar.get_path_to_urdf_file("armar6")
    preset = tmp_path / "armar6.yaml"
    preset.write_text(render(propose(urdf, preset)))
    robot = placement.load_robot(preset)
    built = {
        arm: placement.build_map(robot, arm, samples=150_000, seed=1, resolution=0.15, completion=True, progress=False)
        for arm in robot.arms
    }
    placement.save_maps(tmp_path / "maps", robot, built)
    # the independent check reads the URDF with pinocchio alone: a copy with the vector spaced, its
    # package:// meshes found through a link to the package beside it
    fixed = tmp_path / "oracle" / "armar6.urdf"
    fixed.parent.mkdir()
    os.symlink(os.path.dirname(armar.__file__), fixed.parent / "armar", target_is_directory=True)
    fixed.write_text(readable_urdf(open(urdf).read())[0])
    planned = 0
    for index in range(1):
        doc = generate_scene(5, index, objects=4, obstacles=True, preset=str(preset), maps=str(tmp_path / "maps"))
        doc["planner"] = {"ik_budget_ms": 60000, "time_budget_s": 3600}
        path = tmp_path / f"room{index}.yaml"
        path.write_text(yaml.safe_dump(doc))
        for method in ("global", "sequential"):
            planner = Planner(path, method)
            result = planner.plan()
            assert result.ok, (method, result.failed_step.reason if result.failed_step else None)
            assert result.verify(planner.robot, scene=planner.scene) == []
            oracle_robot = copy.copy(planner.robot)
            oracle_robot.urdf_path = fixed
            for c in IndependentCheck(oracle_robot, planner.scene, cap=0.2).check_plan(result.to_json()):
                assert not c.scene_hits and not c.self_hits and not c.object_hits, (method, c.scene_hits, c.self_hits)
            planned += len(result.steps)
    assert planned == 2 * 8
