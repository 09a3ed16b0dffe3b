"""Turning the base to face what the arm works on (the ``face_target`` planner key).

A placement's base yaw is the one with the best map value at its cell. A robot whose head camera
must see the object, or a user who expects it to face the table, may prefer the yaw that points the
base at the target, if that keeps most of the value: with ``face_target`` s in (0, 1], a placement
at a cell takes, among the base yaws whose map value is at least ``(1 - s)`` times the cell's best
and at least the step's threshold, and at which the footprint fits, the one closest to the bearing
of the trajectory's last TCP position; IK and the collision check verify it, and when they reject it
the best yaw is verified as before. ``face_target: 0`` (the default) keeps the best yaw: plans are
as without it.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from placement.planning.context import PlanningContext
from placement.planning.problems import Option, yaw_values
from placement.planning.torso import option_map


def cell_yaws(
    ctx: PlanningContext, o: Option, x: float, y: float, flat: int
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.bool_]]:
    """Option ``o``'s map value (K,) at (x, y) [m] (grid cell ``flat``) at each of the K base yaws,
    and whether the footprint fits there at that yaw (K,) bool."""
    yaws = ctx.yaws
    values = yaw_values(option_map(ctx, o), o.candidate.poses, np.array([x]), np.array([y]), yaws)[0]
    masks = ctx.world.yaw_masks(np.array([flat], dtype=np.int64))[0]
    k = np.arange(len(yaws))
    fits = ((masks[k >> 6] >> (k & 63).astype(np.uint64)) & np.uint64(1)).astype(bool)
    return values, fits


def facing_yaw(
    ctx: PlanningContext, o: Option, x: float, y: float, flat: int, yaw: float
) -> tuple[float, float] | None:
    """(the base yaw [rad] facing option ``o``'s target from (x, y) [m] at grid cell ``flat``, its map
    value), or None when ``face_target`` is 0 or that yaw is ``yaw`` (the cell's best) already."""
    share = float(ctx.config.face_target)
    if share <= 0.0:
        return None
    yaws = ctx.yaws
    values, fits = cell_yaws(ctx, o, x, y, flat)
    if not fits.any():
        return None
    best = float(values[fits].max())  # the cell's best among the yaws the footprint allows
    keep = fits & (values >= max(ctx.option_threshold(o), (1.0 - share) * best)) & (values > 0)
    if not keep.any():
        return None
    tx, ty = float(o.candidate.poses[-1][0, 3]), float(o.candidate.poses[-1][1, 3])
    bearing = math.atan2(ty - y, tx - x)
    off = np.abs((yaws - bearing + math.pi) % (2 * math.pi) - math.pi)
    j = int(np.argmin(np.where(keep, off, np.inf)))
    if abs(float(yaws[j]) - yaw) < 1e-12:
        return None
    return float(yaws[j]), float(values[j])


def off_heading(base: tuple[float, float, float], target: tuple[float, float]) -> float:
    """|angle| [deg] between a base pose's heading (x [m], y [m], yaw [rad]) and the direction from it
    to ``target`` (x, y) [m]: 0 when the base faces it."""
    d = math.atan2(target[1] - base[1], target[0] - base[0]) - base[2]
    return abs(math.degrees(math.atan2(math.sin(d), math.cos(d))))
