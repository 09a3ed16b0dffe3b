"""What a planning method is: its name, what it ranks by and weighs, and how it plans.

A method is a small strategy object (see :mod:`placement.planning.methods.registry` for the
names). The stages ask it instead of comparing names: :attr:`Method.uses_heuristic` and
:attr:`Method.uses_navigation` decide its weights (:meth:`Method.configure`),
:attr:`Method.ranks_fixed_placements` whether it ranks pre-defined placements rather than the
cells of the manipulation maps, :meth:`Method.plan` plans a whole task.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import replace
from typing import ClassVar

from placement.planning.arrays import Cell
from placement.planning.context import PlanningContext
from placement.planning.program import Regions, map_regions
from placement.planning.results import StepResult
from placement.planning.settings import PlannerConfig


class Method(ABC):
    """A planning method (stateless; one instance serves any number of plans).

    Class attributes:
        name: the method's name (``--method``, the ``method`` of plan documents).
        uses_heuristic: weighs the heuristic towards the next step (``lambda_nh``).
        uses_navigation: weighs the navigation cost (``lambda_n``).
        ranks_fixed_placements: ranks the pre-defined placements beside the tables, by
            manipulability, instead of the manipulation maps' cells by Eq. 6.
        region_kind: what :meth:`regions` ranges over (the certificate's ``regions``).
    """

    name: ClassVar[str]
    uses_heuristic: ClassVar[bool] = True
    uses_navigation: ClassVar[bool] = True
    ranks_fixed_placements: ClassVar[bool] = False
    region_kind: ClassVar[str] = "maps"

    def configure(self, base: PlannerConfig) -> PlannerConfig:
        """``base`` (the scene's configuration) with the weights this method does not use set to 0."""
        out = base
        if not self.uses_heuristic:
            out = replace(out, lambda_nh=0.0)
        if not self.uses_navigation:
            out = replace(out, lambda_n=0.0)
        return out

    @abstractmethod
    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        """Every step's result from the ``start`` cell (up to the first infeasible one); with
        ``keep_maps`` each step's layers are kept in ``StepResult.maps``."""

    def regions(self, ctx: PlanningContext, i: int) -> Regions:
        """The cells where this method may stand for step i, per (arm, grasp) group (the
        certificate's bound ranges over them): by default where the maps keep the threshold."""
        return map_regions(ctx, i, regional=True)

    def prefetch_regions(self, ctx: PlanningContext, i: int) -> None:
        """Start what :meth:`regions` ``(ctx, i)`` will compute, its kernel passes in the background
        (:meth:`~placement.planning.problems.StepProblems.prefetch_regions`)."""
        ctx.problems.prefetch_regions(i, ctx.check_budget)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


__all__ = ["Method"]
