"""Property tests of the scene parser: random and mutated scenes give a Scene or one clean error."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.mutations import documents, mutated
from support.scenes import base_doc, v2_doc

from placement.scene import Scene, SceneError, parse_scene, scene_to_dict

KEYS = (
    "version",
    "resolution",
    "bounds",
    "robot",
    "preset",
    "start",
    "maps",
    "obstacles",
    "objects",
    "place_locations",
    "task",
    "planner",
    "name",
    "box",
    "cylinder",
    "polygon",
    "center",
    "size",
    "yaw",
    "radius",
    "height",
    "table",
    "position",
    "pick",
    "place",
    "threshold",
    "yaw_steps",
    "grasp_yaws",
    "orientation",
    "grasps",
    "poses",
    "orientations",
    "trajectories",
    "reach",
)
BASE = base_doc()
BASE_V2 = v2_doc()


def _check(doc, round_trip: bool = False) -> None:
    try:
        scene = parse_scene(doc, "/nonexistent-dir", "prop")
    except SceneError as exc:
        msg = str(exc)
        assert msg.startswith("prop") and "\n" not in msg and len(msg) < 2000
        return
    assert isinstance(scene, Scene)
    ny, nx = scene.grid_shape
    assert 1 <= nx * ny <= 20_000_000
    assert all(math.isfinite(b) for b in scene.bounds)
    if round_trip:
        assert parse_scene(scene_to_dict(scene), "/nonexistent-dir", "prop") == scene


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(doc=mutated(BASE, KEYS))
def test_mutated_scenes(doc):
    _check(doc)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    doc=documents(KEYS)
    | st.fixed_dictionaries({"version": st.just(1), "robot": documents(KEYS), "task": documents(KEYS)})
)
def test_random_documents(doc):
    _check(doc)


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(doc=mutated(BASE_V2, KEYS))
def test_mutated_v2_scenes(doc):
    _check(doc, round_trip=True)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    doc=st.fixed_dictionaries(
        {
            "version": st.just(2),
            "robot": st.just({"start": [0, 0, 0]}),
            "objects": documents(KEYS),
            "trajectories": documents(KEYS),
            "place_locations": documents(KEYS),
            "task": documents(KEYS),
        }
    )
)
def test_random_v2_documents(doc):
    _check(doc)
