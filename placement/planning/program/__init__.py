"""The whole-task program: the default method's (``global``) and ``optimal``'s dynamic program.

A plan stands at step i on a cell of step i's regions (:mod:`.regions`: where some option keeps its
arm's threshold). The forward program (:mod:`.forward`, :class:`Program`) finds the least travel over
every chain of such cells exactly; with torso settings the program prices the torso's motion too
(:mod:`.priced_torso`, :class:`TorsoProgram`), solved with the torso held while that provably is the
optimum (:mod:`.held_first`, :class:`HeldFirst`); all three are a :class:`WholeTaskProgram`.
:class:`DynamicProgram` (:mod:`.state`) is one plan's program with what verification rejected;
``global`` repairs a rejected placement locally (:mod:`.repair`) and polishes the verified chain for
the task time, turns included (:mod:`.turning`). The same program over a method's regions, IK
ignored, is the plan's lower bound (:mod:`.certificate`).
"""

from placement.planning.program.certificate import RegionSource, certify
from placement.planning.program.forward import Chain, Program, WholeTaskProgram
from placement.planning.program.held_first import HeldFirst
from placement.planning.program.priced_torso import TorsoProgram
from placement.planning.program.regions import Regions, map_regions, reweighted
from placement.planning.program.repair import Verified, repair
from placement.planning.program.state import DynamicProgram
from placement.planning.program.turning import polishes, task_seconds, time_cells, time_yaws

__all__ = [
    "Chain",
    "DynamicProgram",
    "HeldFirst",
    "Program",
    "RegionSource",
    "Regions",
    "TorsoProgram",
    "Verified",
    "WholeTaskProgram",
    "certify",
    "map_regions",
    "polishes",
    "repair",
    "reweighted",
    "task_seconds",
    "time_cells",
    "time_yaws",
]
