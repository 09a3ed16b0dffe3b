"""The priced torso program, solved with the torso held while that provably is the optimum.

:class:`~placement.planning.program.priced_torso.TorsoProgram` costs about k Dijkstras per step (k torso
settings; k per arm and grasp at a grouped transfer's place). Most tasks never move the torso in
their optimum: a PR2's lift takes 11.5 s per 0.15 m, the base drives 5.8 m meanwhile. So
:class:`HeldFirst` first solves the plain program (:class:`~placement.planning.program.forward.Program`, one
Dijkstra per step) over the groups at the start setting t_0 only: its optimum U is a chain of the
priced program (no torso term: the torso never moves). Any chain that moves the torso costs at least
``R + T_min``: ``R`` the least travel over every setting's cells (the certificate's bound of the
maps' regions, a lower bound after any rejection, which only removes cells) and ``T_min`` the least
torso term from t_0 to another setting (every term is >= 0). So when ``U <= R + T_min`` the held
chain is the priced optimum (up to rounding); otherwise, or when some step has no cell at t_0, the
priced program is solved, and is from then on (the regions only shrink, but the test is not redone).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

from placement.planning.arrays import BoolArray, Cell, FloatArray
from placement.planning.program.forward import Chain, Layer, Program, Stop
from placement.planning.program.priced_torso import Term, TorsoProgram, settings_of
from placement.planning.program.regions import Regions


def held_view(reg: Regions, setting: float) -> tuple[Regions, list[int]]:
    """``reg``'s groups at ``setting`` as a plain region (settings dropped), and their indices in ``reg``."""
    index = [k for k, s in enumerate(settings_of(reg)) if s == setting]
    return replace(reg.take(index), settings=None), index


class HeldFirst:
    """The priced program (:class:`~placement.planning.program.priced_torso.TorsoProgram`'s interface) that
    answers with the plain program at the start setting while the module docstring's test proves
    it optimal.

    Args:
        grid: (factor (ny, nx), feasible (ny, nx) bool, cell size [m], start cell (iy, ix)).
        linked: per step, True for a place right after its pick.
        start_torso: t_0, the setting the robot starts at; settings: every setting of the maps.
        term: the torso term [m]; floor: ``R`` [m], a lower bound on the travel of every chain.
    """

    def __init__(
        self,
        grid: tuple[FloatArray, BoolArray, float, Cell],
        linked: Sequence[bool],
        start_torso: float,
        settings: Sequence[float],
        term: Term,
        floor: float,
    ):
        self.held = Program(*grid, linked)
        self.priced = TorsoProgram(grid, linked, start_torso, term)
        self.start_torso, self.term, self.floor = start_torso, term, floor
        #: T_min [m]: the least torso term of any move away from the start setting
        self.jump = min((term(start_torso, t) for t in settings if t != start_torso), default=math.inf)
        #: the priced program answers (the held chain was not provably optimal once)
        self.escalated = False
        self.lazy = False
        self.loose: list[int] = []
        self.layers: Sequence[Layer] = []

    @property
    def stop(self) -> Stop | None:
        """Called before each step of a solve (both programs'; see
        :func:`~placement.planning.program.forward.forward`)."""
        return self.held.stop

    @stop.setter
    def stop(self, stop: Stop | None) -> None:
        self.held.stop = self.priced.stop = stop

    def group(self, places: Sequence[int]) -> int:
        """Not used (``lazy`` is False): the programs group their own transfers."""
        return self.priced.group(places)

    def solve(self, regions: Sequence[Regions], first: int = 0) -> Chain | None:
        """The priced optimum over ``regions`` (of :func:`~placement.planning.program.priced_torso.torso_regions`),
        its groups indices into them; the layers kept before step ``first``."""
        if not self.escalated:
            views = [held_view(r, self.start_torso) for r in regions]
            if all(v.groups for v, _ in views):
                chain = self.held.solve([v for v, _ in views], first)
                self.layers = self.held.layers
                if chain is not None and chain.total <= self.floor + self.jump:
                    groups = [index[g] for (_, index), g in zip(views, chain.groups)]
                    return Chain(chain.cells, groups, chain.labels)
            self.escalated, first = True, 0
        chain = self.priced.solve(regions, first)
        self.layers = self.priced.layers
        return chain


__all__ = ["HeldFirst", "held_view"]
