"""Opening a stored map: :func:`open_map` checks a map file against the robot before anything is read."""

from __future__ import annotations

from pathlib import Path

from placement.errors import GridError, MapError
from placement.maps.array_checks import check_arrays
from placement.maps.rmap import ReachabilityMap
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
    if t is not None and t.shift is None:
        missing = [a for a in t.arrays if a not in arms]
        if missing:
            raise MapError(
                f"{path}: the map of arm '{arm}' names the array '{missing[0]}' of a torso setting "
                "(torso.arrays), which the map does not hold; rebuild the map"
            )
    return rmap


__all__ = ["open_map"]
