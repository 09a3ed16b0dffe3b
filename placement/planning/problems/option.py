"""The per-step manipulation map of one (arm, candidate): :class:`Option`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from placement.maps.rmap import ReachabilityMap
from placement.planning.problems.grasps import Candidate
from placement.scene.navgrid import Window


@dataclass(frozen=True)
class Option:
    """One (arm, candidate, torso setting) of a step and its manipulation map over the base grid.

    The map is kept only over ``window``, the part of the grid within the arm's reach of the
    target (plus one cell): everywhere else it is 0, and a whole-grid copy per option and step
    would dominate the planner's memory on large scenes.

    Attributes:
        arm: arm name. candidate: the TCP trajectory (world frame).
        window: where the map is kept.
        value: (h, w) float32 over ``window``, the IRM value of the best base yaw (0 = unreachable).
        yaw_index: (h, w) int16, that yaw's index into the planner's base yaws (-1 if none).
        out_of_range: True when a pose of the trajectory is outside the map's height range.
        torso: the torso value [m] the option's map and IK hold the lift at (None: the preset's,
            for maps without a torso record; see :mod:`placement.planning.torso`).
        blocked: the gripper alone collides along the candidate, wherever the base stands: the
            collision in words (``"r_gripper_palm_link vs table at the grasp pose"``); its map is then
            0 everywhere and was not computed (see :mod:`placement.planning.problems.screening`).
        exact: True when ``value`` and ``yaw_index`` are each cell's best; False for an option that says
            only where its threshold is kept (the kernel's first yaw keeping it, see
            :meth:`~placement.planning.problems.StepProblems.threshold_options`): the same cells keep
            the threshold, and :meth:`~placement.planning.problems.StepProblems.exact_values` gives the
            best value and yaw of any cell.
    """

    arm: str
    candidate: Candidate
    window: Window
    value: np.ndarray
    yaw_index: np.ndarray
    out_of_range: bool = False
    torso: float | None = None
    blocked: str | None = None
    exact: bool = True

    def value_at(self, iy: int, ix: int) -> float:
        """The IRM value at grid cell (iy, ix) (0 outside the window)."""
        w = self.window
        return float(self.value[iy - w.y0, ix - w.x0]) if w.y0 <= iy < w.y1 and w.x0 <= ix < w.x1 else 0.0

    def yaw_at(self, iy: int, ix: int) -> int:
        """The best yaw's index at grid cell (iy, ix) (-1 outside the window)."""
        w = self.window
        return int(self.yaw_index[iy - w.y0, ix - w.x0]) if w.y0 <= iy < w.y1 and w.x0 <= ix < w.x1 else -1

    def full_value(self, shape: tuple[int, int]) -> np.ndarray:
        """The map over the whole grid of ``shape`` (ny, nx) (for plots)."""
        out = np.zeros(shape, np.float32)
        out[self.window.slices] = self.value
        return out


def height_range(rmap: ReachabilityMap) -> tuple[float, float]:
    """The TCP heights [m] above the base frame that ``rmap`` covers."""
    g = rmap.grid
    return float(g.origin[2]), float(g.origin[2] + g.shape[2] * g.resolution)
