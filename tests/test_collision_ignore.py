"""Self pairs that are modelling artefacts (issue 9): ``robots init`` finds Romeo's overlapping wrist meshes,
writes them as ``ignore_collisions``, and the checker then stops rejecting almost every arm configuration."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

import placement
from placement.collision import SceneCollision
from placement.planning import parse_scene
from placement.robots.onboarding.propose import propose
from placement.robots.onboarding.render import render
from placement.robots.onboarding.selfpairs import artefact_pairs
from placement.robots.spec import share_dir

ROOT = Path(__file__).resolve().parents[1]
ROMEO = ROOT / "examples" / "robots" / "romeo.yaml"
WRISTS = {("LWristRollLink", "l_wrist"), ("RWristRollLink", "r_wrist")}


def romeo_urdf() -> Path:
    path = share_dir() / "example-robot-data/robots/romeo_description/urdf/romeo.urdf"
    if not path.is_file():
        pytest.skip(f"{path} is not available")
    return path


def empty_scene():
    """Nothing near the robot: only self collisions can reject a configuration."""
    return parse_scene(
        {
            "version": 1,
            "resolution": 0.05,
            "bounds": [-3, -3, 3, 3],
            "robot": {"preset": "pr2", "start": [0, 0, 0]},
            "obstacles": [
                {"name": "far_table", "box": {"center": [2.5, 2.5, 0.35], "size": [0.4, 0.4, 0.7]}, "table": True}
            ],
            "objects": [{"name": "cup", "position": [2.5, 2.5, 0.75], "yaw": 0.0, "size": [0.06, 0.06, 0.1]}],
            "place_locations": [{"name": "p", "position": [2.5, 2.4, 0.8]}],
            "task": [{"pick": "cup", "place": "p"}],
        }
    )


@pytest.mark.slow
def test_romeo_init_writes_the_wrist_pairs(tmp_path):
    out = tmp_path / "romeo.yaml"
    p = propose(romeo_urdf(), out)
    assert {q.links for q in p.ignore} == WRISTS
    assert all(0.5 <= q.fraction <= 1 for q in p.ignore)
    assert {q.arm for q in p.ignore} == {"left", "right"}
    text = render(p)
    assert re.search(r"LWristRollLink - l_wrist \d+% \(left arm\)", text)
    assert "# WARNING: these are taken as modelling artefacts" in text
    assert any("ignore_collisions" in w for w in p.warnings)
    out.write_text(text)
    robot = placement.load_robot(out)
    assert robot.ignore_collisions == {frozenset(w) for w in WRISTS}
    # the example preset is this very output (regenerated, not edited)
    assert yaml.safe_load(ROMEO.read_text())["ignore_collisions"] == yaml.safe_load(text)["ignore_collisions"]


def culprits(robot, qs) -> list[str | None]:
    """The culprit of each configuration of the left arm (None: free) with the base at the origin."""
    checker = SceneCollision(robot, empty_scene())
    out = []
    for q in qs:
        r = checker.check("left", q[None], (0.0, 0.0, 0.0))
        out.append(None if r.free else r.culprit)
    return out


def test_ignored_wrist_pair_no_longer_rejects_random_configurations(tmp_path):
    romeo_urdf()  # the preset names it as package://example-robot-data/...: valid from any folder
    doc = yaml.safe_load(ROMEO.read_text())
    del doc["ignore_collisions"]
    plain_path = tmp_path / "romeo_plain.yaml"
    plain_path.write_text(yaml.safe_dump(doc, sort_keys=False))
    plain, ignoring = placement.load_robot(plain_path), placement.load_robot(ROMEO)
    a = plain.arm("left")
    qs = np.random.default_rng(3).uniform(a.lower, a.upper, size=(40, a.dof))
    wrist = re.compile(r"^(LWristRollLink vs l_wrist|l_wrist vs LWristRollLink)$")
    before, after = culprits(plain, qs), culprits(ignoring, qs)
    # without the key the wrist pair rejects most configurations, as init measured
    assert sum(bool(c and wrist.match(c)) for c in before) >= 20
    assert not any(c and wrist.match(c) for c in after)
    assert sum(c is None for c in after) > sum(c is None for c in before) + 15
    # a configuration free before stays free: only the ignored pair left the check
    assert all(b is not None or c is None for b, c in zip(before, after))


def test_pr2_builtin_preset_is_unaffected(pr2):
    assert pr2.ignore_collisions == frozenset()
    assert artefact_pairs(pr2, samples=300) == []
