"""The planner's configuration: one frozen object, the single source of every default, with units.

A scene's ``planner:`` block overrides fields by name; the scene-settable fields are built from
:data:`placement.scene.planner_keys.PLANNER_SETTINGS` (default, help text and bounds of each), so the
parser, the docs and the defaults cannot drift apart. The methods set their own weights from it (see
:meth:`placement.planning.methods.base.Method.configure`).

The fixed fields (not in scenes) are the tuning constants of the stages (search, optimal, verify,
fixed); each stage reads them from the configuration it is given.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from placement.scene.model import SceneError
from placement.scene.planner_keys import EXCLUSIVE, MAX_WEIGHT, PLANNER_BOUNDS, PLANNER_KEYS, PLANNER_SETTINGS


def _key(name: str) -> Any:
    """A scene-settable field: its default, help text (with the unit) and bounds, from the scene's table."""
    setting = dict(PLANNER_SETTINGS[name])
    return field(default=setting.pop("default"), metadata=setting)


@dataclass(frozen=True)
class PlannerConfig:
    """Weights, thresholds and sizes of the planner (paper section IV; docs/design.md, Online).

    Scene-settable (``planner:`` block, see :data:`PLANNER_KEYS`):
        lambda_n: weight of the navigation cost [1/m].
        lambda_m: weight of the manipulation cost ``1/m`` (dimensionless).
        lambda_nh: weight of the heuristic cost towards the next step [1/m].
        yaw_steps: base yaws tried per cell [count].
        threshold: map value below which a placement is infeasible (dimensionless, > 0). Given in
            the scene, the same value on every arm; otherwise the planner resolves
            ``threshold_quantile`` per arm (and per torso setting of a map built once per setting) at
            load and sets this to the smallest of those values (they are kept once, as a
            :class:`~placement.planning.problems.thresholds.Thresholds`: ``PlanningContext.thresholds``).
        threshold_quantile: fraction of each arm's reached map cells, the lowest-valued, that are
            infeasible (dimensionless, 0 .. 1): each arm's threshold is this quantile of its map's
            non-zero values (see :mod:`placement.maps.quantiles`); None when ``threshold`` is given.
        velocity_lambda, velocity_k: lambda and k of the velocity model (Eq. 4), dimensionless.
        d_max: distance beyond which obstacles do not slow the base (Eq. 4) [m].
        grasp_yaws: gripper yaws of place steps: a count (evenly spaced) or a tuple of yaws [rad].
        collision_padding: robot-scene distance below which an arm configuration collides [m].
        footprint_padding: clearance a polygon base footprint keeps from obstacles [m] (Nav2's
            footprint_padding; round bases have their margin in footprint_radius).
        ik_budget_ms: time the IK solves and collision checks of one step's placements may take before
            the step is infeasible [ms] (ranking the placements is bounded by ``time_budget_s``).
        face_target: share of a cell's best map value a base yaw facing the step's target may give up
            (dimensionless, 0 .. 1; 0: the best yaw), see :mod:`placement.planning.facing`.
        time_polish: 1: ``global`` moves the verified placements to nearby cells and ``global`` and
            ``optimal`` turn them where that shortens the task time; 0: the least travel at each cell's
            best map yaw (see :mod:`placement.planning.program.turning`).
        time_budget_s: time planning the whole task may take [s] (``placement query`` counts from its
            start, ``placement.plan`` from building its planner, see ``Planner.plan``'s ``spent_s``); a
            step not verified by then is infeasible and says so (:meth:`PlanningContext.out_of_budget`).
        memory_budget_gib: resident memory planning the whole task may add to the process [GiB]; a
            step not verified by then is infeasible and says so (as ``time_budget_s``).
    Fixed (not in scenes; the stages' tuning constants):
        ik_tries: placements tried best-first (per option and tier in the ranking) before the search
            spreads over every ranked placement [count] (see placement/planning/methods/search.py).
        ik_cap: most placements the IK search of one step tries [count].
        min_region: smallest feasible region the heuristic steers to, as a fraction of the
            step's feasible area (smaller ones would each cost a full cost map for a negligible weight).
        fixed_margin: clearance of the ``fixed`` baseline's placements beyond the footprint's
            half-depth (the radius of a round base) [m].
        fixed_steps_out: cells further out along a table side's normal the ``fixed`` baseline tries
            when a polygon base does not fit on the first [count] (its cell centre can be up to
            half a cell nearer the table than the standoff).
        search_shortfall_m: a failure whose TCP stopped this far or more short of its target
            teaches the search [m].
        search_shortfall_cos: the fraction of the TCP error that must lie along the horizontal
            reach direction for a failure to count as "fell short" (a cosine, dimensionless).
        search_same_direction_rad: base yaws and target bearings this close count as the same
            direction [rad].
        search_sectors: bearing and base yaw sectors per turn of the search's round-robin groups [count].
        search_band_m: width of the distance bands of those groups [m].
        optimal_max_repairs: rejected placements ``optimal`` removes one by one (exactly) before
            each rejection removes its 3 x 3 neighbourhood, as ``global`` does [count].
        dp_max_solves: solves of the dynamic program (one per verification pass that rejected
            something) after which ``optimal`` and ``global`` call the step infeasible [count].
        global_exact_repairs: rejected placements ``global`` removes one by one, as ``optimal`` does,
            before each rejection removes its 3 x 3 neighbourhood [count].
        global_repair_candidates: cells ``global`` verifies, in order of the detour they add, when
            it moves a rejected step between its neighbours' cells [count].
        optimal_probe: cells each way around a rejected placement that ``optimal`` verifies at
            once (removing those that fail) before it solves the program again [cells].
        optimal_manipulability_weight: weight of Eq. 6's manipulation term ``1 / m`` in the
            objective of ``optimal`` and ``global`` [m of travel per unit of 1 / m]; 0: travel only.
        ik_pos_tol_m: position tolerance of a verified TCP pose [m].
        ik_rot_tol_rad: rotation tolerance of a verified TCP pose [rad].
        ik_seeds: start configurations per pose after the witness: the given seed, then random
            ones [count].
    """

    lambda_n: float = _key("lambda_n")
    lambda_m: float = _key("lambda_m")
    lambda_nh: float = _key("lambda_nh")
    yaw_steps: int = _key("yaw_steps")
    threshold: float = _key("threshold")
    threshold_quantile: float | None = _key("threshold_quantile")
    velocity_lambda: float = _key("velocity_lambda")
    velocity_k: float = _key("velocity_k")
    d_max: float = _key("d_max")
    grasp_yaws: int | tuple[float, ...] = _key("grasp_yaws")
    collision_padding: float = _key("collision_padding")
    footprint_padding: float = _key("footprint_padding")
    ik_budget_ms: float = _key("ik_budget_ms")
    time_budget_s: float = _key("time_budget_s")
    memory_budget_gib: float = _key("memory_budget_gib")
    face_target: float = _key("face_target")
    time_polish: int = _key("time_polish")
    ik_tries: int = 25
    ik_cap: int = 2000
    min_region: float = 0.02
    fixed_margin: float = 0.02
    fixed_steps_out: int = 2
    search_shortfall_m: float = 0.02
    search_shortfall_cos: float = 0.7
    search_same_direction_rad: float = 0.35
    search_sectors: int = 8
    search_band_m: float = 0.1
    optimal_max_repairs: int = 500
    dp_max_solves: int = 400
    optimal_manipulability_weight: float = 0.0
    optimal_probe: int = 0
    global_exact_repairs: int = 8
    global_repair_candidates: int = 40
    ik_pos_tol_m: float = 2e-3
    ik_rot_tol_rad: float = 2e-2
    ik_seeds: int = 4

    @classmethod
    def from_overrides(cls, overrides: Mapping[str, Any], where: str = "planner") -> PlannerConfig:
        """Defaults with a (validated) scene ``planner:`` block applied; SceneError naming ``where``
        and both keys when the block gives two keys that replace each other (``threshold`` and
        ``threshold_quantile``)."""
        values = dict(overrides)
        for a, b in EXCLUSIVE:
            if a in values and b in values:
                raise SceneError(
                    f"{where}: both {a} and {b} are given; give one ({a}: a map value, the same on every "
                    f"arm; {b}: the fraction of each arm's reached cells below its threshold)"
                )
        if "threshold" in values:  # a map value given: it replaces the quantile on every arm
            values["threshold_quantile"] = None
        if isinstance(values.get("grasp_yaws"), list):
            values["grasp_yaws"] = tuple(values["grasp_yaws"])
        return cls(**values)


#: Re-exported: the table lives with the scene, which checks a block against it.
__all__ = ["MAX_WEIGHT", "PLANNER_BOUNDS", "PLANNER_KEYS", "PlannerConfig"]
