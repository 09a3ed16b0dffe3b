"""The scene file's 2D inputs for the base: the occupancy map and Nav2's keepout and speed masks.

A 2D map says where the base may stand and drive; it says nothing about height, so it is not part of
the arm's collision model (that is the scene's obstacles, tables, objects and the floor) unless the
user gives its cells a height::

    occupancy_map: floor.yaml                      # a map_server map; unknown cells occupied
    occupancy_map: {file: floor.yaml, unknown: free}   # or: unknown cells free for the base
    occupancy_map: {file: floor.yaml, unknown: cost, unknown_cost: 3}   # or open at 3x the travel cost
    occupancy_map: {file: shelves.yaml, arm_height: 2.0}   # its cells also 2 m tall boxes for the arm
    keepout_mask: keepout.yaml                     # Nav2 keepout filter mask
    speed_mask: speed.yaml                         # Nav2 speed filter mask, percent, base 0, multiplier 1
    speed_mask: {file: speed.yaml, type: absolute, base: 0.0, multiplier: 0.01}   # m/s

Paths are relative to the scene file. See :mod:`placement.scene.occupancy` and
:mod:`placement.scene.masks` for what the values mean.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from placement.scene.cloud import DEFAULT_VOXEL, CloudError, VoxelCloud, load_cloud
from placement.scene.masks import SPEED_TYPES, KeepoutMask, SpeedMask, load_keepout_mask, load_speed_mask
from placement.scene.occupancy import (
    DEFAULT_UNKNOWN_COST,
    MAX_UNKNOWN_COST,
    UNKNOWN_POLICIES,
    OccupancyMap,
    OccupancyMapError,
    load_occupancy_map,
)
from placement.validation import Checker, show

OCCUPANCY_KEYS = {
    "file": "the map YAML, relative to the scene file",
    "unknown": " or ".join(UNKNOWN_POLICIES),
    "arm_height": "[m] occupied cells as boxes this tall for the arm (default: not for the arm)",
    "unknown_cost": "travel cost multiplier of an unknown cell under unknown: cost (>= 1, default 3)",
}
#: [m] the tallest ``arm_height``.
MAX_ARM_HEIGHT = 100.0
SPEED_KEYS = {
    "file": "the mask's map YAML, relative to the scene file",
    "type": " or ".join(SPEED_TYPES),
    "base": "limit offset [% or m/s]",
    "multiplier": "limit per mask value [% or m/s]",
}


@dataclass(frozen=True)
class BaseLayers:
    """What the scene file's 2D inputs hold (any may be None); paths are absolute."""

    occupancy_map: Path | None = None
    occupancy: OccupancyMap | None = None
    keepout_mask: Path | None = None
    keepout: KeepoutMask | None = None
    speed_mask: Path | None = None
    speed: SpeedMask | None = None


def resolve(value: str, origin: Path) -> Path:
    """``value`` as an absolute, normalised path (relative ones against ``origin``)."""
    p = Path(value).expanduser()
    return Path(os.path.normpath(p if p.is_absolute() else origin / p))


def _file_or_mapping(P: Checker, value: Any, key: str, allowed: dict[str, str]) -> dict[str, Any]:
    """The short form (a path) as ``{file: path}``, or the long form checked against ``allowed``."""
    if isinstance(value, str):
        return {"file": P.string(value, key)}
    doc = P.mapping(value, key, allowed, ("file",))
    P.string(doc["file"], f"{key}.file")
    return doc


def parse_base_layers(P: Checker, doc: dict[str, Any], origin: Path) -> BaseLayers:
    """The ``occupancy_map``, ``keepout_mask`` and ``speed_mask`` keys of a scene document, loaded."""
    out: dict[str, Any] = {}
    if doc.get("occupancy_map") is not None:
        spec = _file_or_mapping(P, doc["occupancy_map"], "occupancy_map", OCCUPANCY_KEYS)
        unknown = spec.get("unknown", "occupied")
        if unknown not in UNKNOWN_POLICIES:
            P.fail("occupancy_map.unknown", f"expected {' or '.join(UNKNOWN_POLICIES)}, got {show(unknown)}")
        height = None
        if spec.get("arm_height") is not None:
            height = P.positive(spec["arm_height"], "occupancy_map.arm_height")
            if height > MAX_ARM_HEIGHT:
                P.fail("occupancy_map.arm_height", f"must be <= {MAX_ARM_HEIGHT:g} m, got {height:g}")
        cost = DEFAULT_UNKNOWN_COST
        if spec.get("unknown_cost") is not None:
            if unknown != "cost":
                P.fail("occupancy_map.unknown_cost", f"applies to unknown: cost only (unknown is {unknown})")
            cost = P.number(spec["unknown_cost"], "occupancy_map.unknown_cost", 1.0)
            if cost > MAX_UNKNOWN_COST:
                P.fail("occupancy_map.unknown_cost", f"must be <= {MAX_UNKNOWN_COST:g}, got {cost:g}")
        path = out["occupancy_map"] = resolve(spec["file"], origin)
        try:
            out["occupancy"] = load_occupancy_map(path, unknown, height, cost)
        except OccupancyMapError as exc:
            P.fail("occupancy_map", str(exc))
    if doc.get("keepout_mask") is not None:
        path = out["keepout_mask"] = resolve(P.string(doc["keepout_mask"], "keepout_mask"), origin)
        try:
            out["keepout"] = load_keepout_mask(path)
        except OccupancyMapError as exc:
            P.fail("keepout_mask", str(exc))
    if doc.get("speed_mask") is not None:
        spec = _file_or_mapping(P, doc["speed_mask"], "speed_mask", SPEED_KEYS)
        kind = spec.get("type", "percent")
        if kind not in SPEED_TYPES:
            P.fail("speed_mask.type", f"expected {' or '.join(SPEED_TYPES)}, got {show(kind)}")
        base = P.number(spec.get("base", 0.0), "speed_mask.base")
        multiplier = P.number(spec.get("multiplier", 1.0), "speed_mask.multiplier")
        if abs(base) > 1e6 or abs(multiplier) > 1e6:
            P.fail("speed_mask", f"base and multiplier must be within +-1e6, got {base:g} and {multiplier:g}")
        path = out["speed_mask"] = resolve(spec["file"], origin)
        try:
            out["speed"] = load_speed_mask(path, kind, base, multiplier)
        except OccupancyMapError as exc:
            P.fail("speed_mask", str(exc))
    return BaseLayers(**out)


CLOUD_KEYS = {"file": "a PCD point cloud, relative to the scene file", "voxel": "[m] voxel edge, 0.01 .. 1"}


def parse_cloud(P: Checker, value: Any, origin: Path, exclude: Any = None) -> tuple[Path | None, VoxelCloud | None]:
    """The ``obstacle_cloud`` key (a path, or ``{file, voxel}``), loaded without the voxels that meet the
    ``exclude`` (m, 2, 3) boxes (the scene's objects): see :mod:`placement.scene.cloud`."""
    if value is None:
        return None, None
    spec = _file_or_mapping(P, value, "obstacle_cloud", CLOUD_KEYS)
    voxel = P.positive(spec.get("voxel", DEFAULT_VOXEL), "obstacle_cloud.voxel")
    path = resolve(spec["file"], origin)
    try:
        return path, load_cloud(path, voxel, exclude)
    except CloudError as exc:
        P.fail("obstacle_cloud", str(exc))


def base_layers_to_dict(scene: Any, path: Any) -> dict[str, Any]:
    """The scene file keys of ``scene``'s 2D inputs (``path``: how a path is written)."""
    out: dict[str, Any] = {}
    if scene.occupancy_map is not None:
        occ = scene.occupancy
        spec: dict[str, Any] = {"file": path(scene.occupancy_map)}
        if occ is not None and occ.unknown != "occupied":
            spec["unknown"] = occ.unknown
        if occ is not None and occ.arm_height is not None:
            spec["arm_height"] = occ.arm_height
        if occ is not None and occ.unknown == "cost":
            spec["unknown_cost"] = occ.unknown_cost
        out["occupancy_map"] = spec if len(spec) > 1 else spec["file"]
    if scene.keepout_mask is not None:
        out["keepout_mask"] = path(scene.keepout_mask)
    if scene.speed_mask is not None:
        s = scene.speed
        out["speed_mask"] = {"file": path(scene.speed_mask), "type": s.type, "base": s.base, "multiplier": s.multiplier}
    if scene.obstacle_cloud is not None:
        out["obstacle_cloud"] = {"file": path(scene.obstacle_cloud), "voxel": scene.cloud.voxel}
    return out
