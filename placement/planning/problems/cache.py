"""Per-step problems: each step's manipulation maps (IRMs) and heuristic, in one explicit cache.

What a scene change invalidates (used by dynamic updates, paper Table III):

* a moved object: the IRMs of the steps that pick and place it, and every heuristic (they read those IRMs);
  the verification checks of those steps, and the collision results near the object (:mod:`.checks`);
* added or removed obstacles: everything (the feasible base cells and their allowed yaws changed);
* a new start pose: nothing.

Nothing here depends on the start pose or on the method's weights, so one cache serves all
methods of a scene (evaluation plans each scene with every method).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np

from placement.collision import SceneCollision
from placement.collision.scene import object_aabb
from placement.collision.tables import CollisionResult
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import BoolArray, Float32Array, FloatArray, IntArray
from placement.planning.problems.grasps import GRIPPER_OPENING, Candidate
from placement.planning.problems.manipulation import cells_within, manipulation_maps, pose_reaches, reach_maps
from placement.planning.problems.option import Option, height_range
from placement.planning.problems.refresh import refreshed_options
from placement.planning.problems.screening import blocked_words, screen
from placement.planning.problems.steps import Step, step_candidates, task_steps
from placement.planning.problems.thresholds import Thresholds
from placement.planning.problems.torso_maps import map_variants, torso_value
from placement.planning.settings import PlannerConfig
from placement.planning.verification import Checks
from placement.planning.world import World, costs_at, reachable_from, region_heuristic
from placement.scene import Scene
from placement.scene.navgrid import Window

#: Called between pieces of long work: raises (a task's budget check) to end it.
Stop = Callable[[], None]
#: Legs kept at most (each holds the costs on its targets only): past it the cache starts again.
MAX_LEGS = 4096
#: A step none of whose options keeps its threshold anywhere is planned with its thresholds lowered to
#: this share of its best map value (relative to its threshold): see :meth:`StepProblems.relaxed`.
RELAX = 0.5
#: [m] candidates whose targets lie this close share one pass of the inverse-map kernel (see _clusters).
CLUSTER_M = 0.5
#: Candidates of a step from which a whole-task program reads threshold-only options (see
#: threshold_options): the pass saves about 40 % of the kernel's work, and each verified cell then
#: costs a small kernel call of its own, which a step of few candidates does not win back
THRESHOLD_PASS_FROM = 32
#: Candidates per kernel pass at most: the budget is checked between passes, and a pass of 720 (360
#: grasp yaws per object) took most of a second (each candidate's maps are its own either way)
PASS_CANDIDATES = 256


class StepProblems:
    """The cache of a scene's per-step IRMs and heuristics (see the module docstring).

    Args:
        scene, world: the scene and its rasterised layers.
        maps: arm -> reachability map. config: the planner configuration (threshold, grasp yaws).
        yaws: (K,) base yaws tried per cell [rad].
        opening_m: the gripper's widest opening [m] (generated grasps close across chords up to it).
        thresholds: the map thresholds (:class:`~placement.planning.problems.thresholds.Thresholds`, the
            planner's; default: ``config.threshold`` on every arm).
        collisions: the planner's collision checker: candidates whose gripper alone collides get no map
            (see :mod:`placement.planning.problems.screening`); None: every candidate gets its map.
    """

    def __init__(
        self,
        scene: Scene,
        world: World,
        maps: Mapping[str, ReachabilityMap],
        config: PlannerConfig,
        yaws: FloatArray,
        opening_m: float = GRIPPER_OPENING,
        thresholds: Thresholds | None = None,
        collisions: SceneCollision | None = None,
    ):
        self.scene, self.world, self.maps, self.config, self.yaws = scene, world, maps, config, yaws
        self.collisions = collisions
        # (step, arm) -> per candidate, what rules it out by the gripper alone (words) or None
        self._blocked: dict[tuple[int, str], list[str | None]] = {}
        #: the gripper screens behind ``_blocked`` (a twin hand's is read from them)
        self._screened: dict[tuple[int, str], list[CollisionResult | None]] = {}
        self.opening_m = opening_m
        self.thresholds = thresholds if thresholds is not None else Thresholds(default=float(config.threshold))
        self.steps: list[Step] = task_steps(scene)
        #: arm -> its map at each torso setting (one map without a torso record)
        self.variants = map_variants(maps)
        #: the torso values [m] of the maps' settings, ascending ([None] without torso records)
        self.settings: list[float | None] = sorted(
            {torso_value(m) for ms in self.variants.values() for m in ms}, key=lambda t: -1.0 if t is None else t
        )
        self._options: dict[int, list[Option]] = {}
        # (step, torso value [m]) -> the options at that lift setting alone (see held_options)
        self._held: dict[tuple[int, float], list[Option]] = {}
        # (step, torso value [m] or None, factor on the thresholds) -> options that only say where the
        # threshold is kept (see region_options, threshold_options)
        self._regional: dict[tuple[int, float | None, float], list[Option]] = {}
        # (step, torso value [m] or None) -> what threshold_options gave (one list: verdicts index into it)
        self._thresholded: dict[tuple[int, float | None], list[Option]] = {}
        # (step, torso value [m] or None, threshold factor or None: exact) -> options started by prefetch
        self._pending: dict[tuple[int, float | None, float | None], Callable[[], list[Option]]] = {}
        # options computed for another world (obstacles changed since): refreshed when used
        self._stale: dict[int, tuple[list[Option], World]] = {}
        self._heuristic: dict[tuple[int, bool], FloatArray] = {}
        # step -> the cells its heuristic for given cells holds values on (the others are inf)
        self._heuristic_at: dict[int, BoolArray] = {}
        self._reachable: BoolArray | None = None
        #: called before each kernel pass when a caller gives no ``stop`` (see :meth:`stopping`)
        self.stop: Stop | None = None
        self._relaxed: dict[int, float] = {}
        #: id(options list) -> (that list, its region by the maps): see placement.planning.program.forward
        self.regions: dict[int, tuple[Sequence[Option], Any]] = {}
        # step -> its grasp or place candidates (the options of each torso setting share them)
        self._candidates: dict[int, list[Candidate]] = {}
        #: (region kind, start cell) -> the task's least travel [m] (see placement.planning.program.forward)
        self.bounds: dict[tuple[str, tuple[int, int]], float] = {}
        #: (step, flat cell, (arm, grasp), torso value held or None) -> what the whole-task methods'
        #: verification found there (a ``Verified``, or None: rejected)
        self.verdicts: dict[tuple[int, int, tuple[str, str | None], float | None], Any] = {}
        #: the IK answers and collision results behind the verdicts (kept by an update where valid)
        self.checks = Checks()
        #: (cell (iy, ix), reversed, flat targets' bytes) -> the travel costs [m] between the cell and each
        #: target (see :meth:`legs`); they read the world only
        self._legs: dict[tuple[tuple[int, int], bool, bytes], FloatArray] = {}
        #: id(option) -> (option, and over its window: which cells exact_values computed, their best
        #: values and yaw indices)
        self._exact: dict[int, tuple[Option, BoolArray, Float32Array, IntArray]] = {}

    def legs(self, cell: tuple[int, int], at: IntArray, reverse: bool = False) -> FloatArray:
        """(n,) travel cost [m] from ``cell`` to each flat cell of ``at`` (n,) (``reverse``: from each of
        them to ``cell``), inf where unreachable (cached: a re-plan after an update that left the world
        as it was repairs the same chains again)."""
        cell = (int(cell[0]), int(cell[1]))
        at = np.ascontiguousarray(at, dtype=np.int64)
        key = (cell, reverse, at.tobytes())
        hit = self._legs.get(key)
        if hit is None:
            w = self.world
            hit, _ = costs_at(w.factor, w.feasible, cell, w.nav.resolution, at, reverse=reverse)
            if len(self._legs) >= MAX_LEGS:
                self._legs.clear()
            hit.flags.writeable = False  # handed out as it is kept
            self._legs[key] = hit
        return hit

    def candidates(self, i: int) -> list[Candidate]:
        """Step i's grasp or place candidates (cached: the options of every arm and torso setting, and
        the planner's prefetch of map slices, share them)."""
        hit = self._candidates.get(i)
        if hit is None:
            hit = self._candidates[i] = step_candidates(self.scene, self.steps[i], self.config, self.opening_m)
        return hit

    def map_for(self, arm: str, torso: float | None) -> ReachabilityMap:
        """``arm``'s map (view) at torso value ``torso`` [m] (None: the map without a torso record)."""
        for rmap in self.variants[arm]:
            if torso_value(rmap) == torso:
                return rmap
        raise KeyError(f"arm '{arm}' has no map at torso value {torso}")

    def threshold(self, arm: str, torso: float | None = None) -> float:
        """The map value below which a placement of ``arm`` with the torso at ``torso`` [m or rad] is
        infeasible (dimensionless)."""
        return self.thresholds.at(arm, torso)

    def option_threshold(self, o: Option) -> float:
        """The threshold of option ``o``: its arm's at its torso setting (dimensionless)."""
        return self.thresholds.of(o)

    def relaxed(self, i: int) -> float:
        """The factor (0, 1] step i's thresholds are multiplied by: 1 when some option keeps its threshold
        on some base cell, else :data:`RELAX` times the best ratio of a map value to its threshold (the
        threshold prefers well-manipulable placements; where the maps give a step none, the best of what
        they reach is verified by IK rather than the step called infeasible)."""
        if i not in self._relaxed:

            def best(opts: Sequence[Option]) -> float:
                ratio = 0.0
                for o in opts:
                    if o.value.size:
                        ratio = max(ratio, float(o.value.max()) / self.option_threshold(o))
                        if ratio >= 1.0:  # settled: the thresholds stand
                            break
                return ratio

            # the options at hand first (a held lift's, those that say where the unrelaxed threshold is
            # kept): one that keeps its threshold settles it, without the inverse maps of every other
            # setting (a value of a threshold-only option keeps it: a lower bound of the best ratio)
            known = self._options.get(i) or [o for (k, _), opts in self._held.items() if k == i for o in opts]
            known = known + [o for (k, _, f), opts in self._regional.items() if k == i and f == 1.0 for o in opts]
            ratio = best(known)
            if ratio < 1.0:
                ratio = best(self.options(i))
            self._relaxed[i] = 1.0 if ratio >= 1.0 or ratio <= 0.0 else RELAX * ratio
        return self._relaxed[i]

    def options(self, i: int) -> list[Option]:
        """Manipulation maps of step i for every arm and candidate (cached)."""
        if i not in self._options:
            if i in self._stale:
                opts, was = self._stale.pop(i)
                self._options[i] = refreshed_options(opts, self.map_for, self.yaws, was, self.world)
            elif self.settings == [None]:
                self._options[i] = self._compute_options(self.steps[i])
            else:  # setting by setting: the blocks already given by held_options are reused
                self._options[i] = [o for t in self.settings if t is not None for o in self.held_options(i, t)]
        return self._options[i]

    @contextmanager
    def stopping(self, stop: Stop) -> Iterator[None]:
        """Within the block, every kernel pass that no caller gave a ``stop`` calls ``stop`` first (a
        plan's task budget check: the step-by-step methods and the certificate ask for options in many
        places)."""
        self.stop = stop
        try:
            yield
        finally:
            self.stop = None

    def held_options(self, i: int, torso: float, stop: Stop | None = None) -> list[Option]:
        """Step i's options at torso value ``torso`` [m] alone (cached; the whole-task methods plan a
        step with the lift held without the inverse maps of the other settings). Once given, the same
        list is given again (verdicts index into it). ``stop``: called before each kernel pass (a
        task's budget check, raising to end the work; nothing is kept then)."""
        key = (i, torso)
        if key not in self._held:
            if i in self._options or i in self._stale:
                self._held[key] = [o for o in self.options(i) if o.torso == torso]
            else:
                self._held[key] = self._compute_options(self.steps[i], torso, stop=stop)
        return self._held[key]

    def blocked(self, i: int, arm: str) -> list[str | None]:
        """Per candidate of step i: why ``arm``'s gripper alone rules it out (words), or None (cached;
        every candidate None without a collision checker)."""
        key = (i, arm)
        if key not in self._blocked:
            candidates = self.candidates(i)
            if self.collisions is None:
                self._blocked[key] = [None] * len(candidates)
            else:
                step = self.steps[i]
                twin = self.collisions.gripper_twin(arm)
                if twin is not None:  # the other hand's screen, its culprits renamed
                    self.blocked(i, twin)
                    hits = self.collisions.twin_results(self._screened[i, twin], twin, arm)
                else:
                    hits = screen(self.collisions, self.config, self.steps, step, arm, candidates)
                self._screened[key] = hits
                self._blocked[key] = [
                    None
                    if h is None or h.culprit is None
                    else blocked_words(h.culprit, h.pose, step.action, len(c.poses))
                    for h, c in zip(hits, candidates)
                ]
        return self._blocked[key]

    def region_options(self, i: int, stop: Stop | None = None) -> list[Option]:
        """Step i's options as far as its regions read them (the certificate's bound, on every lift
        setting): those :meth:`options` and :meth:`held_options` already gave, and for each setting
        they did not, options whose maps say only where the threshold (relaxed as the step's) is kept:
        there some value that keeps it and its yaw, the first the kernel finds (not the best), 0 and -1
        elsewhere (:func:`~placement.planning.problems.manipulation.reach_maps` ``at_least``). The same
        cells keep the threshold, for a fraction of the work. Cached apart: no planning reads them.
        ``stop``: as :meth:`held_options` takes it."""
        factor = self.relaxed(i)  # before any map: it may compute the step's options, then used here
        if i in self._options or i in self._stale:
            return self.options(i)
        return [o for t in self._views(None) for o in self._rough(i, t, factor, stop)]

    def threshold_options(self, i: int, torso: float | None = None, stop: Stop | None = None) -> list[Option]:
        """Step i's options at torso value ``torso`` [m] (None: at every setting), index-aligned with
        :meth:`held_options` (:meth:`options`), as a whole-task program reads them: where each keeps its
        threshold. For a step of :data:`THRESHOLD_PASS_FROM` candidates or more, unless the exact options
        are computed already, their maps say only that (``Option.exact`` False: :meth:`region_options`'
        pass, a fraction of the work), and :meth:`exact_values` gives the best value and yaw of the cells
        a program verifies; the exact options for fewer candidates, and when no option of the step keeps
        its threshold (the relaxed thresholds need each option's best). Cached: the same list is given
        again. ``stop``: as :meth:`held_options` takes it."""
        key = (i, torso)
        hit = self._thresholded.get(key)
        if hit is not None:
            return hit
        exact = i in self._options or i in self._stale or (torso is not None and key in self._held)
        if not exact and len(self.candidates(i)) >= THRESHOLD_PASS_FROM:
            parts = [self._rough(i, t, 1.0, stop) for t in self._views(torso)]
            if self.relaxed(i) == 1.0:
                hit = self._thresholded[key] = [o for p in parts for o in p]
                return hit
        return self.options(i) if torso is None else self.held_options(i, torso, stop)

    def _views(self, torso: float | None) -> list[float | None]:
        """The torso values [m] whose maps a step's options at ``torso`` read: that one, or every
        setting for None (the maps without a torso record: [None])."""
        if torso is not None or self.settings == [None]:
            return [torso]
        return [t for t in self.settings if t is not None]

    def _rough(self, i: int, torso: float | None, factor: float, stop: Stop | None) -> list[Option]:
        """Step i's options at torso value ``torso`` [m]: the exact ones if given already, else those
        that say where the thresholds times ``factor`` are kept."""
        held = None if torso is None else self._held.get((i, torso))
        return held if held is not None else self._regional_at(i, torso, factor, stop)

    def _regional_at(self, i: int, torso: float | None, factor: float, stop: Stop | None) -> list[Option]:
        """Step i's threshold-only options at torso value ``torso`` [m] (None: the maps without a torso
        record) for the thresholds times ``factor`` (cached)."""
        key = (i, torso, factor)
        if key not in self._regional:
            self._regional[key] = self._compute_options(self.steps[i], torso, factor, stop)
        return self._regional[key]

    def exact_values(self, opts: Sequence[Option], flats: IntArray) -> tuple[Float32Array, IntArray]:
        """Each option's best map value at each flat cell of ``flats`` (n,) over the base yaws the
        footprint allows there, and that yaw's index into the base yaws (the first of equal values; 0
        and -1 where none reaches, off the feasible cells and for a blocked option): what an exact
        option holds there (read from its arrays), computed by the kernel on those cells for an option
        that says only where its threshold is kept (``Option.exact`` False). Returns (values
        (len(opts), n) float32, yaw indices (len(opts), n) int64)."""
        flats = np.asarray(flats, dtype=np.int64).reshape(-1)
        nav = self.world.nav
        values = np.zeros((len(opts), flats.size), np.float32)
        yaw = np.full((len(opts), flats.size), -1, np.int64)
        ys, xs = np.divmod(flats, nav.shape[1])
        todo: dict[tuple[str, float | None], list[int]] = {}
        for j, o in enumerate(opts):
            if o.exact:
                w = o.window
                inside = (ys >= w.y0) & (ys < w.y1) & (xs >= w.x0) & (xs < w.x1)
                values[j, inside] = o.value[ys[inside] - w.y0, xs[inside] - w.x0]
                yaw[j, inside] = o.yaw_index[ys[inside] - w.y0, xs[inside] - w.x0]
            elif o.blocked is None:
                todo.setdefault((o.arm, o.torso), []).append(j)
        live = self.world.feasible.flat[flats]
        if not todo or not live.any():
            return values, yaw
        for (arm, torso), js in todo.items():
            # each option's cells within its window (0 beyond, where its last pose is out of reach),
            # computed once: the kernel runs on those no call has asked for yet
            kept = [self._exact_kept(opts[j]) for j in js]
            need: list[IntArray] = []
            for o, (known, _, _) in zip((opts[j] for j in js), kept):
                w = o.window
                inside = live & (ys >= w.y0) & (ys < w.y1) & (xs >= w.x0) & (xs < w.x1)
                unknown = inside.copy()
                unknown[inside] = ~known[ys[inside] - w.y0, xs[inside] - w.x0]
                need.append(flats[unknown])
            cells = np.unique(np.concatenate(need))
            if cells.size:
                window = Window.around(cells, nav.shape)
                masks = self.world.yaw_masks(cells)
                ask = [k for k, n in enumerate(need) if n.size]
                rmap = self.map_for(arm, torso)
                found = manipulation_maps(
                    rmap, [opts[js[k]].candidate.poses for k in ask], nav, self.yaws, cells, window, masks
                )
                cy, cx = np.divmod(cells, nav.shape[1])
                for k, (v, a) in zip(ask, found):
                    o, (known, kv, ka) = opts[js[k]], kept[k]
                    w = o.window
                    at = (cy >= w.y0) & (cy < w.y1) & (cx >= w.x0) & (cx < w.x1)
                    local = (cy[at] - w.y0, cx[at] - w.x0)
                    kv[local] = v[cy[at] - window.y0, cx[at] - window.x0]
                    ka[local] = a[cy[at] - window.y0, cx[at] - window.x0]
                    known[local] = True
            for j, (_, kv, ka) in zip(js, kept):
                w = opts[j].window
                inside = live & (ys >= w.y0) & (ys < w.y1) & (xs >= w.x0) & (xs < w.x1)
                values[j, inside] = kv[ys[inside] - w.y0, xs[inside] - w.x0]
                yaw[j, inside] = ka[ys[inside] - w.y0, xs[inside] - w.x0]
        return values, yaw

    def _exact_kept(self, o: Option) -> tuple[BoolArray, Float32Array, IntArray]:
        """(known (h, w), best value (h, w), its yaw index (h, w)) over option ``o``'s window: what
        :meth:`exact_values` computed for it so far (kept with the option, which no one changes)."""
        hit = self._exact.get(id(o))
        if hit is None or hit[0] is not o:  # the option is kept with it: its id is not reused meanwhile
            shape = o.window.shape
            hit = self._exact[id(o)] = (
                o,
                np.zeros(shape, bool),
                np.zeros(shape, np.float32),
                np.full(shape, -1, np.int64),
            )
        return hit[1], hit[2], hit[3]

    def _compute_options(
        self, step: Step, torso: float | None = None, regional: float | None = None, stop: Stop | None = None
    ) -> list[Option]:
        """The options of ``step`` for every arm and candidate, at every lift setting (``torso``: at
        that torso value [m] only); ``regional``: the factor on the thresholds (see :meth:`relaxed`) of
        options that only say where they are kept (:meth:`region_options`); ``stop``: called before
        each kernel pass (with a hundred grasps per object one pass may take a second). Those
        :meth:`prefetch` started are waited for."""
        key = (step.index, torso, regional)
        pending = self._pending.pop(key, None)
        if pending is not None:
            return pending()
        return self._launch_options(step, torso, regional, stop, background=False)()

    def prefetch(self, i: int, torso: float | None, exact: bool = False, stop: Stop | None = None) -> None:
        """Start computing what :meth:`threshold_options` ``(i, torso)`` will read (``exact``: what
        :meth:`held_options` ``(i, torso)`` will; torso None: :meth:`options`), its kernel passes in the
        background thread (:mod:`~placement.planning.problems.background`), so that a whole-task program
        makes one step's kernel arguments while the kernel runs for the step before. The options are
        the same; nothing is started for what is cached or started already. ``stop``: as
        :meth:`held_options` takes it (when it raises, what was started stays started)."""
        if i in self._options or i in self._stale or (i, torso) in self._thresholded:
            return
        settings = self._views(torso)
        keys: list[tuple[int, float | None, float | None]]
        if not exact and len(self.candidates(i)) >= THRESHOLD_PASS_FROM:
            keys = [(i, t, 1.0) for t in settings if (i, t, 1.0) not in self._regional and (i, t) not in self._held]
        else:
            keys = [(i, t, None) for t in settings if t is None or (i, t) not in self._held]
        for key in keys:
            if key not in self._pending:
                self._pending[key] = self._launch_options(self.steps[i], key[1], key[2], stop)

    def prefetch_regions(self, i: int, stop: Stop | None = None) -> None:
        """Start computing what :meth:`region_options` ``(i)`` will read, as :meth:`prefetch` does for
        :meth:`threshold_options`; only once the step's threshold factor is known (:meth:`relaxed` may
        need every exact option)."""
        factor = self._relaxed.get(i)
        if factor is None or i in self._options or i in self._stale:
            return
        for t in self._views(None):
            key = (i, t, factor)
            if (t is None or (i, t) not in self._held) and key not in self._regional and key not in self._pending:
                self._pending[key] = self._launch_options(self.steps[i], t, factor, stop)

    def _launch_options(
        self, step: Step, torso: float | None, regional: float | None, stop: Stop | None, background: bool = True
    ) -> Callable[[], list[Option]]:
        """:meth:`_compute_options`, its kernel passes started (in the background thread when
        ``background``): returns the function that waits for them and gives the options."""
        nav = self.world.nav
        stop = stop or self.stop
        candidates = self.candidates(step.index)
        views = ((a, m) for a, ms in self.variants.items() for m in ms)
        # each candidate's lowest and highest pose [m] (a step has hundreds of candidates)
        heights = np.concatenate([c.poses[:, 2, 3] for c in candidates]) if candidates else np.zeros(0)
        firsts = np.cumsum([0] + [len(c.poses) for c in candidates[:-1]]).astype(np.int64)
        low = np.minimum.reduceat(heights, firsts) if candidates else heights
        high = np.maximum.reduceat(heights, firsts) if candidates else heights
        passes = []
        for arm, rmap in ((a, m) for a, m in views if torso is None or torso_value(m) == torso):
            blocked = self.blocked(step.index, arm)
            # a place of one grasp turned by a half turn is often another grasp's place: one IRM
            distinct = list({c.poses.tobytes(): c for c, why in zip(candidates, blocked) if why is None}.values())
            maps = []
            for near in (
                c[k : k + PASS_CANDIDATES] for c in _clusters(distinct) for k in range(0, len(c), PASS_CANDIDATES)
            ):
                if stop is not None:
                    stop()
                # base cells farther from a target than its slice's reach get 0 from the kernel anyway:
                # only those within some candidate's reach are evaluated (the results are the same)
                cells = self._cells_near(rmap, near)
                # the threshold ctx.for_step(i).option_threshold gives these options
                least = None if regional is None else self.thresholds.relaxed(regional).at(arm, torso_value(rmap))
                found = reach_maps(
                    rmap, [c.poses for c in near], nav, self.yaws, cells, self.world.yaw_masks(cells), least, background
                )
                maps.append((near, found))
            passes.append((arm, rmap, blocked, maps))

        def options() -> list[Option]:
            opts = []
            for arm, rmap, blocked, maps in passes:
                results = {}
                for near, found in maps:
                    results.update({c.poses.tobytes(): m for c, m in zip(near, found())})
                lo, hi = height_range(rmap)
                outside = (low < lo) | (high >= hi)  # some pose beyond the map's heights
                for cand, why, out in zip(candidates, blocked, outside.tolist()):
                    if why is None:
                        opts.append(
                            Option(
                                arm,
                                cand,
                                *results[cand.poses.tobytes()],
                                out,
                                torso_value(rmap),
                                exact=regional is None,
                            )
                        )
                    else:  # no map: an empty window, 0 everywhere (as for a target no base cell reaches)
                        nothing = np.zeros((0, 0), np.float32), np.full((0, 0), -1, np.int16)
                        opts.append(Option(arm, cand, Window(0, 0, 0, 0), *nothing, out, torso_value(rmap), why))
            return opts

        return options

    def _cells_near(self, rmap: ReachabilityMap, candidates: Sequence[Candidate]) -> IntArray:
        """The feasible base cells within the reach of ``rmap``'s slice of some candidate's last pose
        from that pose (a disc around their centre holding every candidate's disc)."""
        reaches = pose_reaches(rmap, np.array([c.poses[-1] for c in candidates])) if candidates else []
        discs = [(float(c.poses[-1, 0, 3]), float(c.poses[-1, 1, 3]), r) for c, r in zip(candidates, reaches)]
        discs = [d for d in discs if d[2] >= 0]
        if not discs:
            return np.zeros(0, np.int64)
        xy = np.array([d[:2] for d in discs])
        centre = 0.5 * (xy.min(axis=0) + xy.max(axis=0))
        radius = max(float(np.hypot(*(np.array(d[:2]) - centre))) + d[2] for d in discs)
        cells = cells_within(self.world.nav, float(centre[0]), float(centre[1]), radius)
        return cells[self.world.feasible.flat[cells]]

    def pairs(self, i: int) -> set[tuple[str, str | None]]:
        """The (arm, grasp) pairs of step i's options that keep the threshold somewhere: for a place,
        the arms and grasps with which the object picked before can be set down."""
        return {
            (o.arm, o.candidate.grasp)
            for o in self.options(i)
            if o.value.size and float(o.value.max()) >= self.option_threshold(o) * self.relaxed(i)
        }

    def feasible_region(self, i: int, options: Sequence[Option] | None = None) -> BoolArray:
        """(ny, nx) bool: base cells from which some arm and candidate of step i (of ``options``,
        default all of the step's) reach their arm's threshold."""
        mask = np.zeros(self.world.nav.shape, dtype=bool)
        for o in self.options(i) if options is None else options:
            mask[o.window.slices] |= o.value >= self.option_threshold(o) * self.relaxed(i)
        return mask

    @property
    def reachable(self) -> BoolArray:
        """(ny, nx) bool: the cells the base can drive to from the scene's start (cached)."""
        if self._reachable is None:
            self._reachable = reachable_from(self.world.feasible, self.world.nav, *self.scene.start[:2])
        return self._reachable

    def heuristic(self, i: int, at: BoolArray | None = None) -> FloatArray:
        """Navigation cost [m] towards step i's feasible regions that the base can reach (cached);
        ``at``: optional (ny, nx) bool of the cells that will be read (see :func:`region_heuristic`):
        a call that reads cells the cached costs left out computes them again over both."""
        key = (i, at is None)
        hit = self._heuristic.get(key)
        if hit is not None and at is not None:
            covered = self._heuristic_at[i]
            if (at & ~covered).any():  # a pick planned again with other grasps reads other cells
                at, hit = at | covered, None
        if hit is None:
            region = self.feasible_region(i)
            hit = self._heuristic[key] = region_heuristic(
                region, self.world, self.config.min_region, at, self.reachable
            )
            if at is not None:
                self._heuristic_at[i] = at
        return hit

    def changed(self, scene: Scene, world: World, moved_objects: set[str]) -> StepProblems:
        """A cache for the changed ``scene`` (and ``world``) that keeps what the change left valid.

        The IRMs of steps that do not pick or place a moved object (or place on a changed obstacle) are kept; with a new ``world`` (obstacles
        changed) they are refreshed on the cells whose allowed yaws changed (see refresh.py) when a
        step first needs them, and the heuristics are dropped. ``self`` is not modified.
        """
        new = StepProblems(
            scene, world, self.maps, self.config, self.yaws, self.opening_m, self.thresholds, self.collisions
        )
        # a moved object's place poses follow its orientation when picked: its place too
        moved = {i for i, s in enumerate(self.steps) if s.carries is not None and s.carries in moved_objects}
        # a candidate the gripper ruled out may be free now: its culprit moved (or an obstacle changed)
        moved |= (
            {i for (i, _), why in self._blocked.items() if any(w is not None for w in why)}
            if world is not self.world
            else {
                i
                for (i, _), why in self._blocked.items()
                if any(_names(w, moved_objects) for w in why if w is not None)
            }
        )
        if world is not self.world:  # a place rests on the obstacles: one added or removed may move it
            moved |= {
                i
                for i, s in enumerate(self.steps)
                if s.action == "place"
                and i in self._options | self._stale
                and not _same_places(self._candidates_of(i), step_candidates(scene, s, self.config, self.opening_m))
            }
        kept = {i: o for i, o in self._options.items() if i not in moved}
        new._stale = {i: v for i, v in self._stale.items() if i not in moved}
        if world is not self.world:  # refreshed on first use: an update touches only what it re-plans
            new._stale.update({i: (o, self.world) for i, o in kept.items()})
        else:
            new._options = kept
            new._held = {k: v for k, v in self._held.items() if k[0] not in moved}
            new._regional = {k: v for k, v in self._regional.items() if k[0] not in moved}
            # the same options and base grid: their checks stand, but near a moved object (its
            # pieces before and after the move)
            boxes = [object_aabb(o) for sc in (self.scene, scene) for o in sc.objects if o.name in moved_objects]
            new.checks = self.checks.kept(moved, boxes)
            new._legs = self._legs
            # step i's heuristic reads step i's regions and stops once step i - 1's cells are settled
            stale = moved | {i + 1 for i in moved}
            # ... and only the cells the start reaches: a start moved to another part of the floor changes them
            if self._reachable is not None and np.array_equal(new.reachable, self._reachable):
                new._heuristic = {k: h for k, h in self._heuristic.items() if k[0] not in stale}
                new._heuristic_at = {k: a for k, a in self._heuristic_at.items() if k not in stale}
        return new

    def _candidates_of(self, i: int) -> list[Candidate]:
        """The candidates step i's cached options were computed for (one per option of the first arm)."""
        opts = self._options[i] if i in self._options else self._stale[i][0]
        per_map = sum(len(v) for v in self.variants.values())
        return [o.candidate for o in opts[: len(opts) // max(per_map, 1)]]


def _clusters(candidates: Sequence[Candidate]) -> list[list[Candidate]]:
    """``candidates`` in groups whose targets (last poses) lie within :data:`CLUSTER_M` of the group's
    first (in order): the grasps and places of one object are one group, trajectories far apart (the
    named trajectories of a reach step) are not, so that no group's maps span a whole floor."""
    out: list[tuple[np.ndarray, list[Candidate]]] = []
    for c in candidates:
        at = c.poses[-1, :2, 3]
        home = next((g for anchor, g in out if float(np.hypot(*(at - anchor))) <= CLUSTER_M), None)
        if home is None:
            out.append((at, [c]))
        else:
            home.append(c)
    return [g for _, g in out]


def _names(words: str, names: set[str]) -> bool:
    """Whether a collision in words (``"LINK vs PIECE at ..."``) names one of ``names`` as its piece."""
    return any(f" vs {n} at " in words or words.endswith(f" vs {n}") for n in names)


def _same_places(a: Sequence[Candidate], b: Sequence[Candidate]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x.poses, y.poses) for x, y in zip(a, b))
