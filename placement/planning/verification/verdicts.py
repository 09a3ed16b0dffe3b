"""What verification found for a placement, kept across the plans of a live planner.

The whole-task methods verify a placement (step, option, base cell) with IK of every pose and the
collision check. IK reads only the option's TCP poses, the base pose and the map's witness (its
starts do not depend on the steps before: see
:meth:`~placement.planning.methods.optimal.DynamicProgram.verify`), so its answer holds as long as the
step's options do. A collision result depends on the scene, but only on the pieces within its
:attr:`~placement.collision.CollisionResult.box`: a scene change whose pieces (before and after)
all lie outside that box leaves it exactly as it was.

:class:`Checks` holds both per (step, held torso value, option index, flat cell, facing yaw or best); a
dynamic update
(:meth:`~placement.planning.problems.cache.StepProblems.changed`) keeps the IK answers of the steps whose
options it keeps and the collision results whose box no moved object touches, so a re-plan after an
object moved verifies again only near the object, and plans exactly as a fresh planner would.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from placement.collision import CollisionResult
from placement.planning.arrays import FloatArray
from placement.planning.verification.ik import TrajectoryIK

#: (step, the torso value [m] the step is held at or None, option index, flat base cell, at the base yaw
#: facing the target (:mod:`placement.planning.facing`) rather than the cell's best)
CheckKey = tuple[int, float | None, int, int, bool]


@dataclass
class Checks:
    """IK answers and collision results by :data:`CheckKey` (see the module docstring)."""

    ik: dict[CheckKey, TrajectoryIK] = field(default_factory=dict)
    collision: dict[CheckKey, CollisionResult] = field(default_factory=dict)

    def kept(self, changed_steps: set[int], changed_boxes: Sequence[FloatArray]) -> Checks:
        """What stays valid after a scene change that changed the options of ``changed_steps`` and
        the scene pieces within ``changed_boxes`` ((2, 3) world (min, max) corners [m], each); the
        base grid must be unchanged (the options' cells and yaws are)."""
        boxes = np.array([np.asarray(b, dtype=float).reshape(2, 3) for b in changed_boxes]).reshape(-1, 2, 3)
        collision = {
            k: r
            for k, r in self.collision.items()
            if k[0] not in changed_steps and r.box is not None and not _touches(r.box, boxes)
        }
        return Checks({k: v for k, v in self.ik.items() if k[0] not in changed_steps}, collision)

    def tally(self, step: int) -> tuple[int, int, str | None]:
        """(IK failures, collisions, the commonest collision's culprit or None) among the placements of
        ``step`` checked so far."""
        ik = sum(1 for k, v in self.ik.items() if k[0] == step and not v.ok)
        hits = [r.culprit for k, r in self.collision.items() if k[0] == step and not r.free]
        named = Counter(c for c in hits if c).most_common(1)
        return ik, len(hits), named[0][0] if named else None


def _touches(box: tuple[float, float, float, float, float, float], boxes: FloatArray) -> bool:
    """Whether the box (x0, y0, z0, x1, y1, z1) [m] overlaps (or touches) any of ``boxes`` (k, 2, 3)."""
    lo, hi = np.array(box[:3]), np.array(box[3:])
    return bool(np.any(np.all((boxes[:, 0] <= hi) & (boxes[:, 1] >= lo), axis=1)))


__all__ = ["CheckKey", "Checks"]
