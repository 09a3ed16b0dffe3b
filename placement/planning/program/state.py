"""One whole-task plan's dynamic program: :class:`DynamicProgram`, the state ``optimal`` and ``global``
(:mod:`placement.planning.methods.optimal`) solve and verify: the regions (changed by rejections),
the program and its layers, what verification found.
"""

from __future__ import annotations

import math

import numpy as np

from placement.planning.arrays import Cell
from placement.planning.context import PlanningContext
from placement.planning.facing import facing_yaw
from placement.planning.problems import Option, Step
from placement.planning.program.forward import Chain, Layer, Program, WholeTaskProgram, linked_steps, travel_bound
from placement.planning.program.held_first import HeldFirst
from placement.planning.program.priced_torso import settings_of, torso_regions, torso_reweighted, torso_term
from placement.planning.program.regions import (
    PREFETCH_STEPS,
    Group,
    Regions,
    held_torso,
    map_regions,
    prefetch_program_options,
    program_options,
    reweighted,
)
from placement.planning.program.repair import Verified
from placement.planning.torso import option_collisions, option_map, option_robot, start_torso, torso_first
from placement.planning.verification import CheckKey, TrajectoryIK, trajectory_ik

#: distinct cells of a (step, group, torso setting) rejected, none verified, after which a rejection
#: probes the group's whole region (:meth:`DynamicProgram.hopeless`; when, :meth:`DynamicProgram.gives_up`)
#: and ``optimal`` removes the rejections around it (:meth:`DynamicProgram.reject_around`)
PROBE_AFTER = 16
#: sectors around a group's region whose best cell by map value a probe verifies
PROBE_SECTORS = 12


class DynamicProgram:
    """One plan's program: regions (changed by repairs), layers, the verified and rejected placements.

    ``priced`` (with torso settings): the regions have a group per (arm, grasp, setting), each
    verified at its setting, and the program prices the torso
    (:class:`~placement.planning.program.held_first.HeldFirst`); otherwise the hold rule (:attr:`hold`)."""

    def __init__(
        self,
        ctx: PlanningContext,
        start: Cell,
        neighbourhood: int = 0,
        exact_repairs: int | None = None,
        priced: bool = False,
    ):
        self.ctx, self.start, self.neighbourhood = ctx, start, neighbourhood
        #: rejections removed one (cell, group) at a time before ``neighbourhood`` applies (None: always)
        self.exact_repairs = exact_repairs
        steps = ctx.problems.steps
        self.linked = linked_steps(ctx)
        w = ctx.world
        held = start_torso(ctx)
        self.program: WholeTaskProgram
        if priced and held is not None:
            # the torso priced (:mod:`placement.planning.program.priced_torso`): a group per (arm, grasp,
            # setting), no hold rule; the plain program at the start setting while provably optimal
            self.hold: list[float | None] = [None] * len(steps)
            self.full = []
            for i in range(len(steps)):
                ctx.check_budget()
                self.full.append(torso_regions(ctx, i))
            grid = (w.factor, w.feasible, w.nav.resolution, start)
            floor = ctx.problems.bounds.get(("maps", start))
            if floor is None:  # the certificate's bound of the maps' regions: computed once, kept for it
                floor = ctx.problems.bounds["maps", start] = travel_bound(ctx, start)
            settings = [t for t in ctx.problems.settings if t is not None]
            self.program = HeldFirst(grid, self.linked, held, settings, torso_term(ctx), floor)
        else:
            #: per step, the torso value [m] its region and verification hold the lift at (None: any)
            self.hold = []
            self.full = []
            for i in range(len(steps)):
                ctx.check_budget()
                for ahead in range(i, min(i + PREFETCH_STEPS + 1, len(steps))):
                    prefetch_program_options(ctx, ahead, held)
                self.hold.append(held_torso(ctx, i))
                self.full.append(map_regions(ctx, i, held=self.hold[-1]))
            self.program = Program(w.factor, w.feasible, w.nav.resolution, start, self.linked)
        # the task's time budget ends a solve between two steps (BudgetSpent, caught by the method)
        self.program.stop = ctx.check_budget
        self.regions = self.weighted()
        # what verification found, kept by the planner's per-step cache: a later plan of the same
        # scene replays the same program with the IK answers looked up (same plan, without the IK
        # time); the cache of a changed scene starts empty
        #: (step, flat cell, group, the torso value held or None) -> what verification found
        self.verified: dict[tuple[int, int, Group, float | None], Verified | None] = ctx.problems.verdicts
        self.repairs = 0
        self.rejected = [0] * len(steps)
        #: a rejection took its neighbours with it (see :meth:`exact_again`)
        self.coarse = False
        self.solves = 0
        self.first_total = math.inf  # the first solve's optimum [m]
        #: per (step, group, torso value held or None): the distinct cells verification rejected,
        #: and whether one verified (True), or a probe found none (False: see :meth:`hopeless`)
        self.tally: dict[tuple[int, Group, float | None], set[int]] = {}
        self.settled: dict[tuple[int, Group, float | None], bool] = {}
        #: (step, group, torso value) dropped whole by a probe
        self.dropped: list[tuple[int, Group, float | None]] = []
        #: whether a hopeless group is dropped (not after :meth:`exact_again`: what the probes dropped
        #: left no chain, so the groups are searched cell by cell)
        self.probing = True
        #: a rejected placement is first moved to the least detour that verifies (:mod:`.repair`)
        self.local = False
        self.repairs_local = 0
        #: the torso value [m] the robot holds at the step being verified (None: no torso settings)
        self.torso: float | None = start_torso(ctx)
        #: a chain and the placements verified along it from its first step on (the partial plan
        #: a method keeps when the time budget runs out)
        self.verified_prefix: tuple[Chain | None, list[Verified]] = (None, [])
        #: id of an options list -> (that list, group -> its members' indices): see :meth:`members`
        self._members: dict[int, tuple[list[Option], dict[Group, list[int]]]] = {}

    def solve(self, first: int = 0) -> Chain | None:
        """The cheapest chain over the current regions, recomputing the layers from step ``first``
        (the transfer rule applied where it binds: :class:`~placement.planning.program.forward.Program`)."""
        self.solves += 1
        chain = self.program.solve(self.regions, first)
        if self.solves == 1 and not self.program.loose:  # a chain with loose transfers is no bound
            self.first_total = chain.total if chain is not None else math.inf
        return chain

    @property
    def layers(self) -> list[Layer]:
        """The layers of the last solve."""
        return list(self.program.layers)

    def verify(self, i: int, flat: int, g: int) -> Verified | None:
        """The first of step i's options of group g at ``flat`` that passes IK and the collision check
        (by map value; with torso settings, those at the torso value the robot holds (:attr:`torso`)
        first, see :mod:`placement.planning.torso`)."""
        hold = self.setting(i, g)
        key = (i, flat, self.regions[i].groups[g], hold)
        if key not in self.verified:
            self.verified[key] = self._verify(i, flat, g, hold)
        found = self.verified[key]
        group_key = (i, self.regions[i].groups[g], hold)
        if found is not None:
            self.settled[group_key] = True
        else:
            self.tally.setdefault(group_key, set()).add(flat)
        return found

    def _verify(self, i: int, flat: int, g: int, hold: float | None) -> Verified | None:
        """:meth:`verify` of a (step, cell, group) not checked before (``hold``: its torso setting)."""
        ctx = self.ctx.for_step(i)
        nav = ctx.world.nav
        iy, ix = divmod(flat, nav.shape[1])
        xs, ys = nav.centres()
        step = ctx.problems.steps[i]
        group = self.regions[i].groups[g]
        opts = self.options(i, g)
        members = self.members(opts, group)
        # each member's best value and yaw at the cell (the options may say only where they keep the threshold)
        got, yaw_of = ctx.problems.exact_values([opts[k] for k in members], np.array([flat]))
        value = {k: float(v) for k, v in zip(members, got[:, 0])}
        best_yaw = {k: int(a) for k, a in zip(members, yaw_of[:, 0])}
        order = sorted(members, key=lambda k: -value[k])
        order = [
            k
            for k in order
            if value[k] >= ctx.threshold(opts[k].arm, opts[k].torso) and (hold is None or opts[k].torso == hold)
        ]
        found = None
        for k in torso_first(opts, order, self.torso):
            o = opts[k]
            x, y, best = float(xs[ix]), float(ys[iy]), float(ctx.yaws[best_yaw[k]])
            face = facing_yaw(ctx, o, x, y, flat, best)
            tries: list[tuple[CheckKey, float, float]] = [] if face is None else [((i, hold, k, flat, True), *face)]
            for ck, yaw, value_k in [*tries, ((i, hold, k, flat, False), best, value[k])]:
                found = self._check(ck, step, o, k, (x, y, yaw), value_k)
                if found is not None:
                    break
            if found is not None:
                break
        return found

    def check_at(self, i: int, g: int, k: int, base: tuple[float, float, float], value: float) -> Verified | None:
        """IK and the collision check of step i's option ``k`` of group ``g`` at ``base`` (x [m], y [m],
        yaw [rad]) of map value ``value``, not cached (any yaw, where :meth:`verify` tries a cell's best)."""
        return self._check(None, self.ctx.problems.steps[i], self.options(i, g)[k], k, base, value)

    def _check(
        self, ck: CheckKey | None, step: Step, o: Option, k: int, base: tuple[float, float, float], value: float
    ) -> Verified | None:
        """IK and the collision check of option ``o`` (index ``k``) at ``base`` (kept in the problems'
        checks under ``ck``, unless None): its :class:`Verified`, or None."""
        ctx = self.ctx
        checks = ctx.problems.checks
        ik = None if ck is None else checks.ik.get(ck)
        if ik is None:
            ik = self._ik(o, base)
            if ck is not None:
                checks.ik[ck] = ik
        if not ik.ok:
            return None
        clearance = None
        checker = option_collisions(ctx, o)
        if checker is not None:
            check = None if ck is None else checks.collision.get(ck)
            if check is None:
                check = checker.check(o.arm, ik.qs, base, **ctx.collision_args(step, o))
                if ck is not None:
                    checks.collision[ck] = check
            if not check.free:
                return None
            clearance = float(check.clearance_m)
        return Verified(k, base, ik, clearance, value)

    def _ik(self, o: Option, base: tuple[float, float, float]) -> TrajectoryIK:
        """IK of option ``o``'s poses with the base at ``base``, started from the map's witness, then
        the arm's home and random restarts: not from the arm's configuration after the step before,
        so that the answer is the placement's alone and stays valid when earlier steps change (see
        :mod:`placement.planning.verification.verdicts`)."""
        witness = getattr(option_map(self.ctx, o), "witness_q", None)
        robot = option_robot(self.ctx, o)
        home = self.ctx.robot.arm(o.arm).home
        return trajectory_ik(robot, o.arm, o.candidate.poses, base, home, witness, self.ctx.config)

    def remove(self, i: int, flat: int, g: int, count: bool = True) -> None:
        """Take the rejected (cell, group) (and its neighbourhood, for ``global``) out of step i's region."""
        late = count and self.exact_repairs is not None and self.repairs >= self.exact_repairs
        r = self.neighbourhood if late else 0
        self.coarse = self.coarse or r > 0
        self.regions[i] = self.regions[i].without(g, flat, r)
        if count:
            self.rejected[i] += 1
            self.repairs += 1
        if count and self.gives_up(i, g, late):
            self.dropped.append((i, self.regions[i].groups[g], self.setting(i, g)))
            self.regions[i] = self.regions[i].without_group(g)
            self.coarse = True

    def forget_rejected(self, i: int) -> None:
        """Take every (cell, group) of step i that verification rejected out of its region (those a
        repair tried too), not counted as repairs: the program's next chain cannot stand on them."""
        reg = self.regions[i]
        off = {}
        for g, group in enumerate(reg.groups):
            flats = self.tally.get((i, group, self.setting(i, g)))
            if flats:
                off[g] = sorted(flats)
        if off:
            self.regions[i] = reg.without_cells(off)

    def rejected_at(self, i: int) -> int:
        """How many (cell, group, torso setting) placements of step i verification rejected."""
        return sum(len(flats) for (k, _, _), flats in self.tally.items() if k == i)

    def gives_up(self, i: int, g: int, late: bool = False, after: int = PROBE_AFTER) -> bool:
        """Whether step i's group g is to be dropped: :meth:`hopeless`, asked by ``global`` (local
        repairs) from the start, by ``optimal`` once its rejections remove neighbourhoods (``late``),
        and by neither after :meth:`exact_again`; ``after``: as :meth:`hopeless` takes it."""
        return self.probing and (late or self.local) and self.hopeless(i, g, after)

    def hopeless(self, i: int, g: int, after: int = PROBE_AFTER) -> bool:
        """Whether step i's group g verifies nowhere, as far as a probe tells: once
        :data:`PROBE_AFTER` distinct cells of it were rejected and none verified, the best cell by map
        value in each of :data:`PROBE_SECTORS` sectors around its region's centre is verified, and the
        group is hopeless when none of them verifies (a grasp whose fingers meet the table wherever the
        base stands, a place whose forearm meets the counter's edge: rejections that a map of the arm
        alone cannot foresee, and that otherwise take the program through the group's region cell by
        cell). A heuristic: the plan may then miss a group's rare verifying cells, never a verified plan
        (when no chain is left, the caller solves again over every group, :meth:`exact_again`, and
        drops none after that). ``after``: the rejected cells that start a probe (a repair's
        :data:`~placement.planning.program.repair.REPAIR_PROBE_AFTER` asks sooner)."""
        reg = self.regions[i]
        key = (i, reg.groups[g], self.setting(i, g))
        if key in self.settled:
            return not self.settled[key]
        if len(self.tally.get(key, ())) < after:
            return False
        self.settled[key] = False  # the probe's own rejections do not probe again
        for flat in self.probe_cells(i, g):
            if self.verify(i, flat, g) is not None:
                return False
        return True

    def probe_cells(self, i: int, g: int) -> list[int]:
        """Step i's group g's cells a probe verifies: in each of :data:`PROBE_SECTORS` equal sectors
        around the centre of the group's region, the cell of the best map value (any option of the
        group), in sector order."""
        reg = self.regions[i]
        cells = reg.cells[reg.masks[g]]
        if not cells.size:
            return []
        opts = self.options(i, g)
        members = [opts[k] for k in self.members(opts, reg.groups[g])]
        values, _ = self.ctx.problems.exact_values(members, cells)
        best = values.max(axis=0)
        ys, xs = np.divmod(cells, reg.shape[1])
        angle = np.arctan2(ys - ys.mean(), xs - xs.mean())
        sector = np.minimum(((angle + math.pi) / (2 * math.pi) * PROBE_SECTORS).astype(int), PROBE_SECTORS - 1)
        out = []
        for s in range(PROBE_SECTORS):
            k = np.flatnonzero(sector == s)
            if k.size:
                out.append(int(cells[k[np.argmax(best[k])]]))
        return out

    def members(self, opts: list[Option], group: Group) -> list[int]:
        """The indices of ``opts`` (a step's options as :meth:`options` gives them) of ``group`` (arm,
        grasp), in order (per list, cached: a place of a hundred grasps holds thousands of options,
        and each verification asks)."""
        key = id(opts)
        hit = self._members.get(key)
        if hit is None or hit[0] is not opts:  # the list is kept with them: its id is not reused meanwhile
            by_group: dict[Group, list[int]] = {}
            for k, o in enumerate(opts):
                by_group.setdefault((o.arm, o.candidate.grasp), []).append(k)
            hit = self._members[key] = (opts, by_group)
        return hit[1].get(group, [])

    def setting(self, i: int, g: int) -> float | None:
        """The torso setting step i's group g is verified at: the group's own (the priced program),
        the held lift value, or None (any)."""
        sets = self.regions[i].settings
        return sets[g] if sets is not None else self.hold[i]

    def options(self, i: int, g: int) -> list[Option]:
        """The options step i's group g is verified with (a ``Verified``'s index is into them): those
        at :meth:`setting`, or all of them."""
        return program_options(self.ctx, i, self.setting(i, g))

    def torso_m(self, chain: Chain, i: int) -> float:
        """The torso term [m] in step i's label of ``chain`` (0 unless the program prices the torso)."""
        if not isinstance(self.program, HeldFirst):
            return 0.0
        before = self.program.start_torso if i == 0 else settings_of(self.regions[i - 1])[chain.groups[i - 1]]
        return self.program.term(before, settings_of(self.regions[i])[chain.groups[i]])

    def release_lift(self) -> Chain | None:
        """Solve again with the lift free (every torso setting, see
        :func:`~placement.planning.program.forward.map_regions`) at the first step no chain reaches when that
        step held it, else at every step; the rejections made with the lift held stay removed."""
        i = next((k for k, layer in enumerate(self.layers) if not np.isfinite(layer.labels).any()), None)
        free = [i] if i is not None and self.hold[i] is not None else range(len(self.hold))
        for k in free:
            self.hold[k] = None
            self.full[k] = map_regions(self.ctx, k)
        return self.exact_again()

    def exact_again(self) -> Chain | None:
        """Solve again over the maps' regions less only the placements verification rejected, never
        removing neighbours again (when removing them left no chain)."""
        self.exact_repairs, self.coarse = None, False
        self.regions = self.weighted()
        self.dropped, self.probing = [], False
        for (i, flat, group, hold), v in self.verified.items():
            if v is not None or i >= len(self.full):
                continue
            reg = self.full[i]
            sets = reg.settings if reg.settings is not None else (self.hold[i],) * len(reg.groups)
            k = next((k for k, gt in enumerate(zip(reg.groups, sets)) if gt == (group, hold)), None)
            if k is not None:
                self.remove(i, flat, k, count=False)
        return self.solve()

    def weighted(self) -> list[Regions]:
        """The maps' regions (:attr:`full`) with their node costs (``optimal_manipulability_weight``)."""
        weigh = torso_reweighted if isinstance(self.program, HeldFirst) else reweighted
        return [weigh(self.ctx, i, r) for i, r in enumerate(self.full)]

    def reject_around(self, i: int, flat: int, g: int) -> None:
        """Verify the cells around a rejected one (``ctx.config.optimal_probe`` cells each way) now and
        remove those that fail too: rejections cluster (at the frontier of reach, beside an
        obstacle), and an IK call costs less than solving the program again for each of them. Around a
        rejection of a group that :data:`PROBE_AFTER` cells rejected and none verified, at least one
        cell each way (the kitchen's lying can: a grasp no cell of some 470 verifies, which ``optimal``
        otherwise took out one solve per cell). Exact either way: only rejected cells are removed."""
        reg = self.regions[i]
        key = (i, reg.groups[g], self.setting(i, g))
        r = self.ctx.config.optimal_probe
        if not self.settled.get(key) and len(self.tally.get(key, ())) >= PROBE_AFTER:
            r = max(r, 1)
        iy, ix = divmod(flat, reg.shape[1])
        ys, xs = np.divmod(reg.cells, reg.shape[1])
        near = reg.cells[reg.masks[g] & (np.abs(ys - iy) <= r) & (np.abs(xs - ix) <= r)]
        for f in near.tolist():  # row by row, as the grid is laid out
            if self.regions[i].has(g, f) and self.verify(i, f, g) is None:
                self.remove(i, f, g)


__all__ = ["DynamicProgram"]
