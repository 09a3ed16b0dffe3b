"""The planner's configuration: one frozen object, the single source of every default, with units.

A scene's ``planner:`` block overrides fields by name; :data:`PLANNER_KEYS` (the keys a scene may
set, with their help text) is derived from the fields, so the parser, the docs and the defaults
cannot drift apart. The methods only differ in their weights (:meth:`PlannerConfig.for_method`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

from placement.errors import PlacementError

METHODS = ("sequential", "single-step", "irm", "fixed", "optimal")

#: Largest weight a scene may set [1/m]: far beyond any sensible trade-off, small enough that
#: ``weight / m`` and ``weight * cost`` stay finite for every map value and grid.
MAX_WEIGHT = 1e6


def _key(default, help: str, **bounds):
    """A scene-settable field: its default, help text (with the unit) and bounds."""
    return field(default=default, metadata={"help": help, **bounds})


@dataclass(frozen=True)
class PlannerConfig:
    """Weights, thresholds and sizes of the planner (paper section IV, SPEC section 5).

    Scene-settable (``planner:`` block, see :data:`PLANNER_KEYS`):
        lambda_n: weight of the navigation cost [1/m].
        lambda_m: weight of the manipulation cost ``1/m`` (dimensionless).
        lambda_nh: weight of the heuristic cost towards the next step [1/m].
        yaw_steps: base yaws tried per cell [count].
        threshold: map value below which a placement is infeasible (dimensionless, > 0).
        velocity_lambda, velocity_k: lambda and k of the velocity model (Eq. 4), dimensionless.
        d_max: distance beyond which obstacles do not slow the base (Eq. 4) [m].
        grasp_yaws: gripper yaws of place steps: a count (evenly spaced) or a tuple of yaws [rad].
        collision_padding: robot-scene distance below which an arm configuration collides [m].
        footprint_padding: clearance a polygon base footprint keeps from obstacles [m] (Nav2's
            footprint_padding; round bases have their margin in footprint_radius).
        ik_budget_ms: time the IK search of one step may spend before the step is infeasible [ms].
    Fixed (not in scenes):
        ik_tries: placements tried best-first (per option and tier in the ranking) before the search
            spreads over every ranked placement [count] (see placement/planning/search.py).
        ik_cap: most placements the IK search of one step tries [count].
        min_region: smallest feasible region the heuristic steers to, as a fraction of the
            step's feasible area (smaller ones would each cost a full cost map for a negligible weight).
        fixed_margin: clearance of the ``fixed`` baseline's placements beyond the footprint's
            half-depth (the radius of a round base) [m].
    """

    lambda_n: float = _key(
        1 / 20, "weight of the navigation cost [1/m], 0 .. 1e6 (default 1/20)", minimum=0.0, maximum=MAX_WEIGHT
    )
    lambda_m: float = _key(
        0.002353, "weight of the manipulation cost 1/m, 0 .. 1e6 (default 0.002353)", minimum=0.0, maximum=MAX_WEIGHT
    )
    lambda_nh: float = _key(
        1 / 20,
        "weight of the heuristic cost towards the next step [1/m], 0 .. 1e6 (default 1/20)",
        minimum=0.0,
        maximum=MAX_WEIGHT,
    )
    yaw_steps: int = _key(
        100,
        "number of base yaws tried per cell, integer 1 .. 3600 (default 100)",
        integer=True,
        minimum=1,
        maximum=3600,
    )
    threshold: float = _key(
        0.0235,
        "manipulability below which a placement is infeasible, > 0 and <= 1 (default 0.0235)",
        minimum=0.0,
        strict=True,
        maximum=1.0,
    )
    velocity_lambda: float = _key(
        1.3, "lambda of the velocity model (Eq. 4), 0 .. 1e6 (default 1.3)", minimum=0.0, maximum=MAX_WEIGHT
    )
    velocity_k: float = _key(
        4.0,
        "exponent k of the velocity model (Eq. 4), > 0 and <= 100 (default 4)",
        minimum=0.0,
        strict=True,
        maximum=100.0,
    )
    d_max: float = _key(
        1.0,
        "distance [m] beyond which obstacles do not slow the base, > 0 and <= 1000 (default 1)",
        minimum=0.0,
        strict=True,
        maximum=1000.0,
    )
    grasp_yaws: int | tuple[float, ...] = _key(
        8,
        "gripper yaws of place steps: a count (integer 1 .. 360, evenly spaced) or a list of yaws [rad] (default 8)",
        integer=True,
        minimum=1,
        maximum=360,
        or_list=True,
    )
    collision_padding: float = _key(
        0.005,
        "distance [m] below which the robot's collision shapes touch the scene's, 0 .. 0.5 (default 0.005)",
        minimum=0.0,
        maximum=0.5,
    )
    footprint_padding: float = _key(
        0.02,
        "clearance [m] a polygon base footprint keeps from obstacles, 0 .. 1 (default 0.02; round bases ignore it)",
        minimum=0.0,
        maximum=1.0,
    )
    ik_budget_ms: float = _key(
        300.0,
        "time the IK search of one step may spend [ms], >= 1 and <= 60000 (default 300)",
        minimum=1.0,
        maximum=60000.0,
    )
    ik_tries: int = 25
    ik_cap: int = 2000
    min_region: float = 0.02
    fixed_margin: float = 0.02

    def for_method(self, method: str) -> PlannerConfig:
        """The weights of ``method``: ``single-step`` drops the heuristic, ``irm`` and ``fixed`` also
        the navigation cost; ``sequential`` and ``optimal`` keep all."""
        if method not in METHODS:
            raise PlacementError(f"unknown method '{method}'; choose from {', '.join(METHODS)}")
        out = self
        if method not in ("sequential", "optimal"):
            out = replace(out, lambda_nh=0.0)
        if method in ("irm", "fixed"):
            out = replace(out, lambda_n=0.0)
        return out

    @classmethod
    def from_overrides(cls, overrides: dict) -> PlannerConfig:
        """Defaults with a (validated) scene ``planner:`` block applied."""
        values = dict(overrides)
        if isinstance(values.get("grasp_yaws"), list):
            values["grasp_yaws"] = tuple(values["grasp_yaws"])
        return cls(**values)


#: Keys allowed in a scene's ``planner:`` block: name -> help text with unit and default.
PLANNER_KEYS: dict[str, str] = {f.name: f.metadata["help"] for f in fields(PlannerConfig) if f.metadata}

#: Their bounds, for the scene parser: name -> metadata (minimum, maximum, strict, integer, or_list).
PLANNER_BOUNDS: dict[str, dict] = {f.name: dict(f.metadata) for f in fields(PlannerConfig) if f.metadata}
