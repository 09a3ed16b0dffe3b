"""The checks an opened map's arrays pass before it is used: the measure's rank and complete chunks."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

from placement.errors import MapError
from placement.kinematics.manipulability import arm_rank
from placement.maps.witness import empty_value
from placement.robots import Robot
from placement.storage import StoredMap
from placement.storage.format import witness_name


class OpenedMap(Protocol):
    """What the checks read of an opened map (a :class:`~placement.maps.rmap.ReachabilityMap`)."""

    path: Path
    arm: str
    store: StoredMap
    meta: dict[str, Any]
    array: str

    @property
    def rank(self) -> int: ...


def check_arrays(rmap: OpenedMap, robot: Robot) -> None:
    """MapError unless the opened map's measure has the arm's rank and its arrays are complete."""
    path, arm, store = rmap.path, rmap.arm, rmap.store
    if rmap.meta["witness"]["empty"] != empty_value(rmap.meta["witness"]["dtype"]):
        raise MapError(f"{path}: metadata of arm '{arm}' is inconsistent (corrupt); rebuild the map")
    if rmap.rank != arm_rank(robot, arm):
        # e.g. a map of an arm spanning 5 dimensions built with the 6-dimensional measure: all zeros
        raise MapError(
            f"{path}: the map of arm '{arm}' holds the measure on {rmap.rank} dimensions (measure.rank), "
            f"the arm spans {arm_rank(robot, arm)}; rebuild the map"
        )
    store.check_arrays(rmap.array)
    for name, key in ((rmap.array, "stored_chunks"), (witness_name(rmap.array), "stored_witness_chunks")):
        want = rmap.meta.get(key)
        have = store.chunks_present(name)
        if want is not None and have is not None and have != want:
            raise MapError(
                f"{path}: arm '{arm}' has {have} of {want} {'witness' if name != rmap.array else 'data'} "
                f"chunks (half-written or corrupt); rebuild the map"
            )


__all__ = ["OpenedMap", "check_arrays"]
