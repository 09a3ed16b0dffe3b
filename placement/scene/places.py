"""The scene-wide rule of places: an object is set down as it is held.

A place location's ``orientations`` (version 2) are the orientations of the *object* set down
there, in the world frame. The gripper holds the object rigidly from its pick to its place, so
the object can only turn about the vertical: each listed orientation must be the picked
orientation of every object the task places there, turned about z, within
:data:`UPRIGHT_TOLERANCE_DEG`. (Before transfers, ``orientations`` were TCP orientations; a file
written for that meaning, for example top-down TCP quaternions for an upright cup, turns the
object over and gets this error.)
"""

from __future__ import annotations

import math

import numpy as np

from placement.scene.model import Scene
from placement.scene.poses import quaternion_matrix
from placement.validation import Checker

#: [deg] largest tilt between an object's picked orientation and an allowed place orientation.
UPRIGHT_TOLERANCE_DEG = 6.0


def check_place_orientations(scene: Scene, P: Checker) -> None:
    """Fail (``P.fail``, key path ``place_locations[i].orientations[k]``) on an orientation that no
    object placed there can take without tilting."""
    index = {p.name: i for i, p in enumerate(scene.place_locations)}
    objects = {o.name: o for o in scene.objects}
    for t in scene.task:
        if t.pick is None or t.place is None or t.place not in index or t.pick not in objects:
            continue
        i = index[t.place]
        loc, obj = scene.place_locations[i], objects[t.pick]
        if loc.orientations is None:
            continue
        assert obj.orientation is not None  # set by SceneObject.__post_init__
        R0 = quaternion_matrix(obj.orientation)
        for k, q in enumerate(loc.orientations):
            tilt = math.degrees(math.acos(float(np.clip((quaternion_matrix(q) @ R0.T)[2, 2], -1.0, 1.0))))
            if tilt > UPRIGHT_TOLERANCE_DEG:
                P.fail(
                    f"place_locations[{i}].orientations[{k}]",
                    f"would set object '{obj.name}' down tilted {tilt:.0f} deg from how it is picked; "
                    f"'orientations' are the object's orientations at the place (not the gripper's), and an "
                    f"object is set down as it is held: give its picked orientation turned about z (within "
                    f"{UPRIGHT_TOLERANCE_DEG:g} deg)",
                )
