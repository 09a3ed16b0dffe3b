"""A torso of several joints held at postures: one build per posture (see :mod:`placement.maps.torso`).

Robots whose arms ride on a chain of held joints (talos's torso yaw and pitch, a legged robot's hip and
knee pitches holding the chest) cannot move one joint alone to a useful setting: a setting is a
POSTURE, a value of every one of those joints. The build spec names them ``torso: {joints: [j1, ..., jn],
postures: [[v1, ..., vn], ...]}`` [m or rad per joint]; the arm is built once per posture with the
robot at ``robot.with_fixed(posture)`` (:func:`placement.maps.torso_builds.build_torso_maps`), like one
joint's per-setting builds.

The planner carries a torso setting as one number; for postures it is the posture's index (0 .. k-1 in
the spec's order; k for the preset's own posture when it is not one of them): the record maps each index
to its joint values (:meth:`TorsoSettings.held`), the time between two postures is the slowest joint's
(:meth:`TorsoSettings.seconds`), and a planned step's ``joints`` hold every torso joint's value.
"""

from __future__ import annotations

from placement.errors import PlacementError
from placement.maps.buildspec import TorsoSpec
from placement.maps.torso import TorsoSettings, check_limits, checked_joint
from placement.robots import Robot
from placement.storage.schema import posture_array


def posture_settings(robot: Robot, arm: str, spec: TorsoSpec, where: str = "torso") -> TorsoSettings:
    """The posture record of ``spec`` (``spec.joints`` given) for ``arm`` of ``robot``: every joint one of
    the preset's fixed joints, prismatic or bounded revolute, not moving the base frame and carrying
    every joint of the arm (``{where}.joints[i]`` in errors), every value within its joint's URDF limits
    (``{where}.postures[i][k]``); PlacementError naming the key otherwise."""
    checked = [checked_joint(robot, arm, j, f"{where}.joints[{k}]") for k, j in enumerate(spec.joints)]
    units = tuple(u for u, _ in checked)
    for i, posture in enumerate(spec.postures):
        if len(posture) != len(spec.joints):  # the parser refuses it; a TorsoSpec made in code may not
            raise PlacementError(f"{where}.postures[{i}] has {len(posture)} values for {len(spec.joints)} joints")
        for k, (j, v) in enumerate(zip(spec.joints, posture)):
            check_limits(robot, j, v, units[k], f"{where}.postures[{i}][{k}]")
    preset = tuple(float(robot.fixed_joints[j]) for j in spec.joints)
    postures = tuple(tuple(float(v) for v in p) for p in spec.postures)
    reference = postures.index(preset) if preset in postures else len(postures)
    if reference == len(postures):
        postures += (preset,)
    values = tuple(float(i) for i in range(len(spec.postures)))
    arrays = tuple(arm if i == reference else posture_array(arm, i) for i in range(len(values)))
    velocities = tuple(v for _, v in checked)
    return TorsoSettings(
        spec.joint,
        values,
        float(reference),
        None,
        velocities[0],
        "index",
        arrays,
        spec.joints,
        postures,
        velocities,
        units,
    )


__all__ = ["posture_settings"]
