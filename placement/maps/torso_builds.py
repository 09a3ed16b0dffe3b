"""One build per torso setting: the maps of a joint that turns the arm's chain (a revolute torso pitch).

A revolute joint the preset holds and that carries every joint of an arm moves the arm's reach, but not
rigidly along a line, so no one map stands for two settings (see :mod:`placement.maps.torso`): the arm is
sampled again with the robot at ``robot.with_fixed({joint: v})`` for every setting ``v``, with the same
seed, samples and grid parameters. The map at ``v`` is the map a build of that robot without the
``torso`` key writes (bit for bit), and has its own grid, witnesses and value quantiles.

Stored: the arm's own array holds the map at the preset's held value (the reference; built whether or
not it is among the values, so that the arm's map is the one a build without the key writes), with the
record ``torso: {joint, kind: per_setting, unit: rad, values, reference, shift: null, velocity, arrays}``;
every other setting's map is an array ``arm@joint=value`` (:func:`placement.storage.schema.setting_array`)
whose metadata holds ``setting: {joint, value}``. Every array is sealed like an arm's (chunk CRC32s,
metadata digests); ``ReachabilityMap.at_torso(v)`` opens and checks the one of ``v``.

A torso of several joints held at postures (:mod:`placement.maps.torso`) is built the same
way, once per posture with ``robot.with_fixed(posture)``: the record has ``kind: posture``, the other
postures' arrays are ``arm@posture=i`` (:func:`placement.storage.schema.posture_array`) whose
``setting`` holds the index (``value``) and ``posture: {joint: value}``.

The build time multiplies by the number of settings (``len(allowed)``: the values and the reference).
"""

from __future__ import annotations

import logging
from typing import Any

from placement.maps.build import build_map
from placement.maps.buildspec import TorsoSpec
from placement.maps.torso import TorsoSettings, torso_settings
from placement.robots import Robot
from placement.storage.format import BuiltMap

log = logging.getLogger("placement")


def build_torso_maps(robot: Robot, arm: str, *, torso: TorsoSpec, **options: Any) -> dict[str, BuiltMap]:
    """{stored array name: map} of ``arm`` with the torso settings ``torso``.

    ``options``: those of :func:`placement.build_map` (samples, seed, resolution, bins, index, progress,
    client, self_collision, self_distance, completion, ...), the same for every setting. A prismatic lift
    gives the one shifted map ``{arm: build_map(..., torso=torso)}``; a revolute joint gives one build
    per setting: ``arm`` at the reference (with the record) and ``arm@joint=value`` at every other value
    (see the module). Checked against the robot before any sampling (PlacementError naming the key).
    """
    self_collision = bool(options.get("self_collision") or options.get("self_distance"))
    settings = torso_settings(robot, arm, torso, self_collision=self_collision)
    if settings.shift is not None:
        return {arm: build_map(robot, arm, torso=torso, **options)}
    label = options.pop("label", None) or f"{robot.name}/{arm}"
    order = sorted(settings.allowed, key=lambda v: v != settings.reference)  # the reference first
    if settings.joints:
        log.info(
            "%s: torso %s held at postures: %d builds, one per posture (%s), the build time times %d",
            label,
            settings.label,
            len(order),
            "; ".join(settings.describe(v) for v in order),
            len(order),
        )
    else:
        log.info(
            "%s: %s is a revolute joint: %d builds, one per setting (%s %s), the build time times %d",
            label,
            settings.joint,
            len(order),
            ", ".join(f"{v:g}" for v in order),
            settings.unit,
            len(order),
        )
    out: dict[str, BuiltMap] = {}
    for k, v in enumerate(order, 1):
        held = robot.with_fixed(settings.held(v))
        m = build_map(held, arm, label=f"{label} {settings.describe(v)} ({k}/{len(order)})", **options)
        out[settings.array(arm, v)] = _recorded(m, settings, v)
    return out


def _recorded(m: BuiltMap, settings: TorsoSettings, value: float) -> BuiltMap:
    """``m`` (a build at setting ``value``) with its metadata saying what it stands for: the record on the
    reference's map, ``setting: {joint, value}`` on another setting's."""
    meta = dict(m.meta)
    if value == settings.reference:
        meta["torso"] = settings.to_dict()
    else:
        meta["setting"] = {"joint": settings.joint, "value": float(value), "unit": settings.unit}
        if settings.joints:  # a posture: its index (``value``) and every joint's value
            meta["setting"]["posture"] = settings.held(value)
    return BuiltMap(m.values, meta, m.witness)


def built_seconds(maps: dict[str, BuiltMap]) -> float:
    """The build time [s] of all settings' maps together."""
    return float(sum(m.meta["build_time_s"] for m in maps.values()))


__all__ = ["build_torso_maps", "built_seconds"]
