"""Opening a stored map: :func:`open_map` checks a map file against the robot before anything is read."""

from __future__ import annotations

import math
from pathlib import Path

from placement.errors import GridError, MapError
from placement.maps.array_checks import check_arrays
from placement.maps.rmap import ReachabilityMap
from placement.maps.torso import VALUE_TOLERANCE, TorsoSettings
from placement.robots import Robot, load_robot
from placement.storage import open_store
from placement.storage.schema import arm_arrays
from placement.storage.validate import check_root, validate_arm, validate_robot


def open_map(path: str | Path, arm: str, robot: Robot | str | None = None) -> ReachabilityMap:
    """Open the map of ``arm`` at ``path`` (Zarr directory or HDF5 file), lazily.

    The map is validated against ``robot`` (a :class:`Robot` or preset name/path);
    by default against the preset recorded in the map. Checked here: the
    metadata is complete, the format version, robot name, URDF hash, base frame
    and fixed joints, the arm's joints (names, order, count), tip frame and TCP
    offset (to 1e-9), the rank of the measure against the arm's (:func:`arm_rank`), the chunk
    checksum table and (Zarr) the stored chunk count.
    Every later read checks each chunk's CRC32. Raises :class:`MapError` for a
    missing, half-written, corrupt, foreign or outdated map.
    """
    path = Path(path)
    store = open_store(path)
    root = store.root
    check_root(path, root)
    if not isinstance(robot, Robot):
        robot = load_robot(robot if robot is not None else str(root.get("preset") or root.get("robot")))
    validate_robot(path, root, robot)
    arms = list(root.get("arms") or [])
    if arm not in arm_arrays(arms):  # the arrays of torso settings are opened through their arm
        raise MapError(f"{path}: no map for arm '{arm}'; it has: {', '.join(arm_arrays(arms)) or 'none'}")
    try:
        rmap = ReachabilityMap(store, arm, robot)  # its metadata checked against its digest and for its types
    except GridError as exc:
        raise MapError(f"{path}: metadata of arm '{arm}': {exc} (corrupt); rebuild the map") from None
    validate_arm(path, rmap.meta, robot, arm)
    check_arrays(rmap, robot)
    t = rmap.torso
    if t is not None:
        check_settings(path, arm, t, robot)
    if t is not None and t.shift is None:
        missing = [a for a in t.arrays if a not in arms]
        if missing:
            raise MapError(
                f"{path}: the map of arm '{arm}' names the array '{missing[0]}' of a torso setting "
                "(torso.arrays), which the map does not hold; rebuild the map"
            )
    return rmap


def check_settings(path: Path, arm: str, t: TorsoSettings, robot: Robot) -> None:
    """MapError naming the map and the record's key unless every torso setting the map holds is one
    the robot can take: its joints fixed joints of the preset, every value within their URDF limits
    (the settings are read from the map, so a bad one is the map's, not the preset's)."""
    joints = t.joints or (t.joint,)
    for j in joints:
        if j not in robot.fixed_joints:
            raise MapError(
                f"{path}: the map of arm '{arm}' holds torso settings of '{j}', which is no fixed joint of "
                f"preset '{robot.name}' (fixed: {', '.join(robot.fixed_joints) or 'none'}); rebuild the map"
            )
    if t.joints:
        values = [
            (f"torso.postures[{i}][{k}]", j, float(v))
            for i, p in enumerate(t.postures)
            for k, (j, v) in enumerate(zip(t.joints, p))
        ]
    else:
        values = [(f"torso.values[{i}]", t.joint, float(v)) for i, v in enumerate(t.values)]
    model = robot.model
    for key, j, v in values:
        q = model.joints[model.getJointId(j)].idx_q
        lo, hi = float(model.lowerPositionLimit[q]), float(model.upperPositionLimit[q])
        if not (math.isfinite(v) and lo - VALUE_TOLERANCE <= v <= hi + VALUE_TOLERANCE):
            raise MapError(
                f"{path}: the map of arm '{arm}' holds {key} = {v:g} for '{j}', outside its URDF limits "
                f"[{lo:g}, {hi:g}]; rebuild the map"
            )


__all__ = ["check_settings", "open_map"]
