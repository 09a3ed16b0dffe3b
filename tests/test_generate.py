"""Generated benchmark scenes: seeded, valid, laid out as SPEC section 8 says."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from placement.planning.generate import TABLE_HEIGHT, generate_scene, write_scenes
from placement.planning.scene import load_scene


def test_seeded_and_independent_of_count(tmp_path):
    a = write_scenes(tmp_path / "a", seed=3, count=3)
    b = write_scenes(tmp_path / "b", seed=3, count=2)
    assert a[0].read_text() == b[0].read_text() and a[1].read_text() == b[1].read_text()
    assert a[0].read_text() != a[1].read_text()
    assert generate_scene(4, 0) != generate_scene(3, 0)


@pytest.mark.parametrize("obstacles", [False, True])
def test_layout(tmp_path, obstacles):
    (path,) = write_scenes(tmp_path, seed=7, count=1, objects=6, obstacles=obstacles)
    scene = load_scene(path)
    assert len([o for o in scene.obstacles if o.table]) == 5  # pick and place tables
    tables = [o for o in scene.obstacles if o.name.startswith("pick_table")]
    assert len(tables) == 3
    for t in tables:
        np.testing.assert_allclose(t.shape.size[:2], [0.8, 0.6])  # PR2 default
    xs = [t.shape.center[0] for t in tables]
    lo, hi = min(xs) - 0.4, max(xs) + 0.4
    for o in scene.objects:
        assert lo < o.position[0] < hi and 3.7 < o.position[1] < 4.3
        assert o.position[2] == pytest.approx(TABLE_HEIGHT + o.size[2] / 2)
    assert [t.place for t in scene.task] == ["place_a", "place_b"] * 3
    crates = [o for o in scene.obstacles if o.name.startswith("crate")]
    assert len(crates) == (2 if obstacles else 0)
    from placement.planning.generate import SHADOW

    for o in scene.objects:  # no crate blocks the table edge in front of an object on its own side
        for c in crates:
            same_side = (c.shape.center[1] - 4.0) * (o.position[1] - 4.0) > 0
            assert not (same_side and abs(c.shape.center[0] - o.position[0]) < SHADOW)


def test_cli_generate_json(tmp_path):
    p = subprocess.run([sys.executable, "-m", "placement.cli.main", "scenes", "generate", "--seed", "2",
                        "--count", "2", "--obstacles", "--json", str(tmp_path)], capture_output=True, text=True,
                       env=dict(os.environ))
    assert p.returncode == 0, p.stderr
    assert len(json.loads(p.stdout)["scenes"]) == 2
