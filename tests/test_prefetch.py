"""What a planner reads when it is built: every map slice of its candidates, and the witness slices of
a step's slices in a map only where they are few (placement/planning/prepare.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import placement
from placement.maps.grid import pose_from_zyx
from placement.maps.rmap import ReachabilityMap
from placement.planning import Planner
from placement.planning.prepare import WITNESS_SLICES
from placement.planning.problems import distinct_slices, pose_slices

ROOT = Path(__file__).resolve().parents[1]
YCB = ROOT / "examples" / "buildings" / "wrs_arena" / "tidy_up_ycb.yaml"


@pytest.mark.parametrize("seed", range(4))
def test_distinct_slices_are_the_set_of_every_poses_slice(tiny_maps, pr2, seed):
    """Against pose_slices pose by pose: random poses, some below or above the map's heights (none
    of their slices), each (z, pitch, roll) bin once, ascending."""
    rmap = placement.open_map(tiny_maps, "right", pr2)
    rng = np.random.default_rng(seed)
    n = 400
    T = pose_from_zyx(
        np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-1.0, 3.0, n)]),
        rng.uniform(-math.pi, math.pi, n),
        rng.uniform(-math.pi / 2, math.pi / 2, n),
        rng.uniform(-math.pi, math.pi, n),
    )
    want = sorted({key for pose in T for key in pose_slices(rmap, pose[None])})
    assert distinct_slices(rmap, T) == want
    assert 0 < len(want) < n and len(pose_slices(rmap, T)) < n  # some poses off the heights
    assert distinct_slices(rmap, T[:0]) == []


def test_only_a_steps_few_witness_slices_are_read_before_planning(tiny_maps, monkeypatch):
    """The published grasps' arena on the tiny maps: every slice of every candidate is read when the
    planner is built (one by one or together), a witness slice only when its step's slices in that map
    are at most WITNESS_SLICES (its places' hundreds are not); the plan is the plan of a planner built without
    reading anything."""
    asked: dict[str, set] = {"slice": set(), "witness_slice": set()}
    for name, kept in asked.items():
        method = getattr(ReachabilityMap, name)

        def reading(self, *key, method=method, kept=kept):
            kept.add((self.arm, self.torso_value, tuple(int(k) for k in key)))
            return method(self, *key)

        monkeypatch.setattr(ReachabilityMap, name, reading)
    read_slices = ReachabilityMap.read_slices

    def reading_together(self, keys, witness=False):
        keys = list(keys)
        asked["witness_slice" if witness else "slice"].update(
            (self.arm, self.torso_value, tuple(int(k) for k in key)) for key in keys
        )
        return read_slices(self, keys, witness)

    monkeypatch.setattr(ReachabilityMap, "read_slices", reading_together)
    planner = Planner(YCB, "global", tiny_maps)
    problems = planner.problems
    values, witnesses, skipped = set(), set(), 0
    for i in range(len(problems.steps)):
        poses = np.concatenate([c.poses for c in problems.candidates(i)])
        for rmap in (m for maps in problems.variants.values() for m in maps):
            keys = {(rmap.arm, rmap.torso_value, k) for k in distinct_slices(rmap, poses)}
            values |= keys
            if len(keys) <= WITNESS_SLICES:
                witnesses |= keys
            else:
                skipped += 1
    assert values <= asked["slice"] and witnesses <= asked["witness_slice"] and skipped > 0
    # beyond the prefetch: the one witness lookup per arm of the warm-up
    assert len(asked["witness_slice"] - witnesses) <= len(problems.variants)
    monkeypatch.undo()
    cold = Planner(YCB, "global", tiny_maps, warm=False).plan()
    assert [s.base for s in planner.plan().steps] == [s.base for s in cold.steps]


def test_the_polar_bounds_of_the_large_steps_are_made_when_the_planner_is_built(tiny_maps, monkeypatch):
    """A built planner holds the polar bounds of the slices of its steps with many candidates (the
    published grasps' places), at the torso value it starts with; one built without them makes them
    as its kernel passes need them, and plans the same."""
    from placement.planning import prepare
    from placement.planning.problems import THRESHOLD_PASS_FROM

    built = Planner(YCB, "global", tiny_maps)
    problems = built.problems
    large = [i for i in range(len(problems.steps)) if len(problems.candidates(i)) >= THRESHOLD_PASS_FROM]
    assert large and len(large) < len(problems.steps)  # the places, not the picks
    for maps in problems.variants.values():
        rmap = maps[0]
        poses = np.concatenate([c.poses for i in large for c in problems.candidates(i)])
        corner = (float(rmap.grid.origin[0]), float(rmap.grid.origin[1]))
        made = {key for (c, key) in rmap._shared.polar if c == corner}
        assert {((z,), p, r) for z, p, r in distinct_slices(rmap, poses)} <= made
    monkeypatch.setattr(prepare, "prefetch_polar", lambda ctx, seconds=0.0: True)
    monkeypatch.setattr("placement.planning.planner.prefetch_polar", lambda ctx, seconds=0.0: True)
    lazy = Planner(YCB, "global", tiny_maps)
    assert all(not m._shared.polar for maps in lazy.problems.variants.values() for m in maps)
    first, second = built.plan(), lazy.plan()
    assert [(s.status, s.arm, s.grasp, s.base) for s in first.steps] == [
        (s.status, s.arm, s.grasp, s.base) for s in second.steps
    ]


LOADS = """
import importlib, json, pkgutil, sys
import placement.kernels
from placement.planning import Planner

def loaded():
    out = set()
    for info in pkgutil.iter_modules(placement.kernels.__path__):
        module = importlib.import_module(f"placement.kernels.{info.name}")
        for name, obj in vars(module).items():
            if hasattr(obj, "overloads") and hasattr(obj, "py_func"):
                out |= {f"{info.name}.{name}{tuple(sig)}" for sig in obj.overloads}
    return out

planner = Planner(sys.argv[1], sys.argv[2], sys.argv[3])
before = loaded()
assert planner.plan().ok
print(json.dumps(sorted(loaded() - before)))
"""


@pytest.mark.slow
@pytest.mark.parametrize("method", ["global", "sequential"])
def test_a_built_planner_plans_without_loading_a_kernel(tiny_maps, method):
    """In a fresh process, the kernels a plan calls are loaded from numba's cache when the planner is
    built (a few milliseconds each), with the array types the plan passes them: none while it plans."""
    import json
    import subprocess
    import sys

    scene = ROOT / "examples" / "table_clearing.yaml"
    p = subprocess.run(
        [sys.executable, "-c", LOADS, str(scene), method, str(tiny_maps)], capture_output=True, text=True, cwd=ROOT
    )
    assert p.returncode == 0, p.stderr[-3000:]
    assert json.loads(p.stdout.splitlines()[-1]) == []
