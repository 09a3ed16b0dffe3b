"""The planning methods: strategies over one :class:`~placement.planning.context.PlanningContext`.

:class:`Method` (:mod:`.base`) is the family; :mod:`.registry` maps names to them. Whole-task:
``global`` (the default) and ``optimal`` (:mod:`.optimal`, over :mod:`placement.planning.program`).
Step by step (:mod:`.stepwise`): the paper's ``sequential``, ``single-step`` and ``irm``, which rank
placements by the paper's Eq. 6 with their weights (:mod:`.weighted`, :mod:`.ranking`), and the
``fixed`` baseline (:mod:`.fixed`); the IK search over ranked placements (:mod:`.search`) and why a
step is infeasible (:mod:`.explain`).
"""

from placement.planning.methods.base import Method
from placement.planning.methods.ranking import rank_by_cost
from placement.planning.methods.registry import DEFAULT_METHOD, METHODS, method_named

__all__ = ["DEFAULT_METHOD", "METHODS", "Method", "method_named", "rank_by_cost"]
