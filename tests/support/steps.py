"""Step results for tests that need a planned step without planning one."""

from __future__ import annotations

from typing import Any

import numpy as np

from placement.planning import PlacedStep
from placement.planning.results import Cost


def placed_step(step: int = 0, action: str = "pick", target: str = "x", **fields: Any) -> PlacedStep:
    """A :class:`PlacedStep` with ``fields`` set and the rest neutral: arm "right", grasp "top", the base
    at the origin, one TCP pose at the identity, no arm joints, zero manipulability, cost and travel."""
    values: dict[str, Any] = {
        "arm": "right",
        "grasp": "top",
        "base": (0.0, 0.0, 0.0),
        "tcp": np.eye(4)[None],
        "q": np.zeros(0),
        "joints": {},
        "manipulability": 0.0,
        "cost": Cost(0.0, 0.0, 0.0),
        "travel_time_s": 0.0,
    }
    values.update(fields)
    return PlacedStep(step, action, target, **values)
