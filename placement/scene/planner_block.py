"""A scene's ``planner:`` block: the planner settings a scene may override, checked against their bounds."""

from __future__ import annotations

from typing import Any

from placement.scene.parts import SceneParser
from placement.scene.planner_keys import PLANNER_BOUNDS, PLANNER_KEYS


def parse_planner(P: SceneParser, raw: Any) -> dict[str, Any]:
    """The overrides of the planner defaults in ``raw`` (the block as read), each checked against its bounds."""
    out: dict[str, Any] = {}
    if raw is None:
        return out
    for key, value in P.mapping(raw, "planner", PLANNER_KEYS).items():
        p, b = f"planner.{key}", PLANNER_BOUNDS[key]
        if b.get("or_list") and isinstance(value, list):
            if not value:
                P.fail(p, "expected a count or a non-empty list of yaws [rad], got an empty list")
            if len(value) > b["maximum"]:
                P.fail(p, f"expected at most {b['maximum']} yaws, got {len(value)}")
            out[key] = [P.number(v, f"{p}[{j}]") for j, v in enumerate(value)]
        elif b.get("integer"):
            out[key] = P.integer(value, p, b["minimum"], b["maximum"])
        else:
            out[key] = P.number(value, p, b["minimum"], b.get("strict", False), b["maximum"])
    return out
