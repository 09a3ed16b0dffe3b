"""The online placement method (paper section IV): step by step through a scene's task.

For each manipulation step (pick an object, place it), the best base placement
minimises Eq. 6 over every grasp candidate and arm:
``c = lambda_n * nav + lambda_m / m + lambda_nh * heuristic`` on the cells where the
inverse reachability value m reaches the threshold, and passes an IK check.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage

from ..errors import PlacementError
from ..ik import solve_ik
from ..rmap import open_map
from ..robots import load_robot, matrix_to_pose
from .grasps import Candidate, place_candidates, top_grasps
from .manipulation import base_yaws, cells_within, manipulation_map, reach_xy
from .navigation import extract_path, navigation_cost
from .scene import Scene, load_scene
from .world import build_world

log = logging.getLogger("placement")

METHODS = ("sequential", "single-step", "irm", "fixed", "optimal")
DEFAULTS = {"lambda_n": 1 / 20, "lambda_m": 0.002353, "lambda_nh": 1 / 20, "yaw_steps": 100,
            "threshold": 0.0235, "velocity_lambda": 1.3, "velocity_k": 4, "d_max": 1.0, "grasp_yaws": 8}
IK_TRIES = 25
MIN_REGION = 0.02
FIXED_MARGIN = 0.02  # [m] clearance of the fixed baseline's placements beyond the footprint radius  # smallest feasible region (fraction of the step's feasible area) the heuristic steers to  # candidate placements tried in cost order before a step is declared infeasible


@dataclass
class Option:
    """The manipulation map of one (arm, candidate): value (ny, nx), best yaw index (ny, nx)."""

    arm: str
    candidate: Candidate
    value: np.ndarray
    yaw_index: np.ndarray


@dataclass
class StepMaps:
    """Everything computed for one step (kept for plots and for re-planning)."""

    navigation: np.ndarray | None = None
    heuristic: np.ndarray | None = None
    manipulation: np.ndarray | None = None
    combined: np.ndarray | None = None
    path: np.ndarray | None = None
    extra: dict = field(default_factory=dict)


class Planner:
    """A long-lived planner for one scene: world layers, maps and per-step caches.

    Args:
        scene: a :class:`Scene` or the path of a scene file.
        method: "sequential" (all terms), "single-step" (no heuristic) or "irm" (manipulability only).
        maps: reachability map path (default: the scene's ``maps``, else ``maps/<robot name>``).
    """

    def __init__(self, scene: Scene | str | Path, method: str = "sequential", maps: str | Path | None = None):
        self.scene = scene if isinstance(scene, Scene) else load_scene(scene)
        self.set_method(method)
        self.robot = load_robot(self.scene.robot_preset)
        map_path = Path(maps or self.scene.maps or Path("maps") / self.robot.name)
        self.maps = {arm: open_map(map_path, arm, self.robot) for arm in self._mapped_arms(map_path)}
        p = self.params
        self.world = build_world(self.scene, self.robot.footprint_radius, p["velocity_lambda"], p["velocity_k"],
                                 p["d_max"])
        self.yaws = base_yaws(int(p["yaw_steps"]))
        self._options: dict[int, list[Option]] = {}
        self._heuristic: dict[tuple[int, bool], np.ndarray] = {}
        self._full_maps = False
        self._fixed: list[tuple[int, float]] | None = None

    def set_method(self, method: str) -> None:
        """Switch the method (weights); the scene's maps, world and IRM caches are kept."""
        if method not in METHODS:
            raise PlacementError(f"unknown method '{method}'; choose from {', '.join(METHODS)}")
        self.method = method
        self.params = {**DEFAULTS, **self.scene.planner}
        if method not in ("sequential", "optimal"):
            self.params["lambda_nh"] = 0.0
        if method in ("irm", "fixed"):
            self.params["lambda_n"] = 0.0

    def update(self, change: dict) -> dict:
        """Apply a scene change (see planning/updates.py), redoing only what it invalidates."""
        from .updates import apply_update

        return apply_update(self, change)

    def _mapped_arms(self, path: Path) -> list[str]:
        from ..storage import open_store

        store = open_store(path)
        arms = [a for a in self.robot.arms if a in (store.root.get("arms") or [])]
        store.close()
        if not arms:
            raise PlacementError(f"{path}: no map for any arm of robot '{self.robot.name}'")
        return arms

    # -- steps -----------------------------------------------------------
    def steps(self) -> list[tuple[str, str]]:
        """(action, target) for every manipulation step of the task, in order."""
        out = []
        for t in self.scene.task:
            out += [("pick", t.pick), ("place", t.place)]
        return out

    def candidates(self, action: str, target: str) -> list[Candidate]:
        if action == "pick":
            o = self.scene.object(target)
            return top_grasps(o.position, o.yaw, o.size)
        return place_candidates(self.scene.place_location(target).position, self.params["grasp_yaws"])

    def options(self, i: int) -> list[Option]:
        """Manipulation maps of step i for every arm and candidate (cached: they do not depend on the start)."""
        if i not in self._options:
            action, target = self.steps()[i]
            opts = []
            nav = self.world.nav
            near: dict[tuple, np.ndarray] = {}  # candidates of a step share their target position
            for arm, rmap in self.maps.items():
                for cand in self.candidates(action, target):
                    key = (cand.poses[-1, 0, 3], cand.poses[-1, 1, 3], reach_xy(rmap.grid))
                    if key not in near:
                        cells = cells_within(nav, *key)
                        near[key] = cells[self.world.feasible.flat[cells]]
                    value, yaw = manipulation_map(rmap, cand.poses, nav, self.yaws, near[key])
                    opts.append(Option(arm, cand, value, yaw))
            self._options[i] = opts
        return self._options[i]

    def feasible_region(self, i: int) -> np.ndarray:
        """(ny, nx) bool: base cells from which some arm and candidate of step i reach the threshold."""
        mask = np.zeros(self.world.nav.shape, dtype=bool)
        for o in self.options(i):
            mask |= o.value >= self.params["threshold"]
        return mask

    def heuristic(self, i: int, at: np.ndarray | None = None) -> np.ndarray:
        """Section IV-C: navigation cost towards step i's feasible regions, area-weighted (cached).

        ``at``: optional (ny, nx) bool of the cells where the heuristic will be read (the
        previous step's candidates); the region cost maps then stop once those are settled.
        """
        key = (i, at is None)
        if key not in self._heuristic:
            region = self.feasible_region(i)
            labels, n = ndimage.label(region, structure=np.ones((3, 3)))
            total = np.zeros(self.world.nav.shape)
            if n == 0:
                self._heuristic[key] = total
                return total
            sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
            # regions under MIN_REGION of the feasible area would add a full cost map each for a
            # negligible weight: they are dropped and the weights renormalised
            keep = [lab + 1 for lab in range(n) if sizes[lab] >= MIN_REGION * sizes.sum()]
            area = sum(sizes[lab - 1] for lab in keep)
            for lab in keep:
                cells = np.argwhere(labels == lab)
                centroid = cells.mean(axis=0)
                centre = cells[np.argmin(((cells - centroid) ** 2).sum(axis=1))]
                cost, _ = navigation_cost(self.world.factor, self.world.feasible, centre, self.world.nav.resolution,
                                          targets=at)
                total += (len(cells) / area) * cost
            self._heuristic[key] = total
        return self._heuristic[key]

    # -- planning --------------------------------------------------------
    def plan(self, keep_maps: bool = False) -> dict:
        """Plan every step from the scene's start pose: the JSON document of SPEC section 7.

        With ``keep_maps``, ``self.step_maps`` holds each step's cost maps (for plots).
        """
        self.step_maps: list[StepMaps] = []
        self._full_maps = keep_maps
        start = self.scene.start
        nav = self.world.nav
        try:
            start_cell = nav.cell(start[0], start[1])
        except PlacementError:
            raise PlacementError(f"start pose ({start[0]}, {start[1]}) is outside the scene bounds") from None
        if not self.world.feasible[start_cell]:
            raise PlacementError(f"start pose ({start[0]:.2f}, {start[1]:.2f}) is inside an obstacle or closer "
                                 f"than the base footprint radius {self.robot.footprint_radius} m to one")
        if self.method == "optimal":
            from .optimal import plan_optimal

            return plan_optimal(self, start_cell)
        prev_cell, prev_yaw = start_cell, float(start[2])
        prev_q = {arm: self.robot.arm(arm).home.copy() for arm in self.maps}
        steps_out = []
        status_ok = True
        for i, (action, target) in enumerate(self.steps()):
            t0 = time.perf_counter()
            step, cell, yaw, q = self._plan_step(i, action, target, prev_cell, prev_q)
            step["timings_ms"]["total"] = round((time.perf_counter() - t0) * 1e3, 3)
            steps_out.append(step)
            if keep_maps:
                self.step_maps.append(self.last_maps)
            if step.get("status") == "infeasible":
                status_ok = False
                break
            prev_cell, prev_yaw = cell, yaw
            prev_q[step["arm"]] = q
        return {"scene": self.scene.name, "method": self.method, "robot": self._robot_json(),
                "status": "ok" if status_ok else "infeasible", "steps": steps_out}

    def _plan_step(self, i, action, target, prev_cell, prev_q):
        p = self.params
        nav = self.world.nav
        timings = {}
        t = time.perf_counter()
        opts = self.options(i)
        has_next = i + 1 < len(self.steps())
        steer = has_next and p["lambda_nh"] > 0
        if steer:
            self.options(i + 1)  # the next step's IRMs: manipulation work, cached for that step
        timings["manipulation"] = (time.perf_counter() - t) * 1e3
        # only the candidate cells of this step are read from the cost maps (all cells for plots)
        needed = None if self._full_maps or self.method == "fixed" else self.feasible_region(i)
        t = time.perf_counter()
        nav_cost, pred = navigation_cost(self.world.factor, self.world.feasible, prev_cell, nav.resolution,
                                         targets=needed)
        timings["navigation"] = (time.perf_counter() - t) * 1e3
        t = time.perf_counter()
        heur = self.heuristic(i + 1, needed) if steer else np.zeros(nav.shape)
        timings["heuristic"] = (time.perf_counter() - t) * 1e3
        t = time.perf_counter()
        best_combined = np.full(nav.shape, np.inf)
        if self.method == "fixed":
            ranked = self._rank_fixed(opts)
        else:
            ranked = []  # (tier, cost, option index, flat cell, base yaw)
            for k, o in enumerate(opts):
                reach = (o.value >= p["threshold"]) & np.isfinite(nav_cost) & np.isfinite(heur)
                if not reach.any():
                    continue
                c = np.full(nav.shape, np.inf)
                c[reach] = (p["lambda_n"] * nav_cost[reach] + p["lambda_m"] / o.value[reach]
                            + p["lambda_nh"] * heur[reach])
                np.minimum(best_combined, c, out=best_combined)
                # tier 0: the threshold holds on the 3 x 3 cells around the placement; at the frontier
                # of a map cell's reach the cell is reachable somewhere, not reliably at its centre,
                # so frontier cells (tier 1) are only tried after the inner ones
                inner = ndimage.minimum_filter(o.value, size=3, mode="constant", cval=0.0) >= p["threshold"]
                for tier, mask in ((0, reach & inner), (1, reach & ~inner)):
                    flat = np.flatnonzero(mask)
                    top = flat[np.argsort(c.flat[flat], kind="stable")[:IK_TRIES]]
                    ranked += [(tier, float(c.flat[f]), k, int(f), float(self.yaws[o.yaw_index.flat[f]]))
                               for f in top]
            ranked.sort(key=lambda r: (r[0], r[1], r[2], r[3]))
            ranked = [r[1:] for r in ranked]
        timings["combine"] = (time.perf_counter() - t) * 1e3
        self.last_maps = StepMaps(nav_cost, heur, np.max([o.value for o in opts], axis=0) if opts else None,
                                  best_combined)
        t = time.perf_counter()
        failed = []  # (option, row, column) of placements where IK failed
        tries = 0
        for cost, k, f, yaw in ranked:
            if tries >= IK_TRIES:
                break
            o = opts[k]
            iy, ix = divmod(f, nav.shape[1])
            if not np.isfinite(nav_cost[iy, ix]):
                continue  # a fixed placement the base cannot get to from here
            # the next cell of the same candidate almost always fails the same way: spend the
            # IK budget on distinct placements instead
            if any(fk == k and abs(fy - iy) <= 1 and abs(fx - ix) <= 1 for fk, fy, fx in failed):
                continue
            tries += 1
            xs, ys = nav.centres()
            base = (float(xs[ix]), float(ys[iy]), yaw)
            q = self._ik(o, base, prev_q[o.arm])
            if q is None:
                failed.append((k, iy, ix))
                continue
            timings["ik"] = (time.perf_counter() - t) * 1e3
            path = extract_path(pred, (iy, ix))
            self.last_maps.path = path
            value = o.value[iy, ix] if self.method != "fixed" else -cost
            return self._step_json(i, action, target, o, base, q, nav_cost[iy, ix], heur[iy, ix],
                                   value, timings), (iy, ix), yaw, q
        timings["ik"] = (time.perf_counter() - t) * 1e3
        reason = ("no base placement reaches the target with the map threshold "
                  f"{p['threshold']}" if not ranked else f"IK failed for the best {tries} distinct placements")
        return ({"step": i, "action": action, "target": target, "status": "infeasible", "reason": reason,
                 "timings_ms": {k: round(v, 3) for k, v in timings.items()}}, None, None, None)

    def fixed_placements(self) -> list[tuple[int, float]]:
        """The ``fixed`` baseline's placements: (flat cell, yaw [rad]) centred on each free side of
        each ``table: true`` obstacle, facing it, the base centre ``footprint_radius + 0.02`` m from
        the side (free: that cell is base-feasible)."""
        if self._fixed is None:
            out = []
            nav = self.world.nav
            standoff = self.robot.footprint_radius + FIXED_MARGIN
            for ob in self.scene.tables:
                sh = ob.shape
                if hasattr(sh, "size"):
                    c, s_ = math.cos(sh.yaw), math.sin(sh.yaw)
                    half = (sh.size[0] / 2, sh.size[1] / 2)
                    sides = [((c, s_), half[0]), ((-c, -s_), half[0]), ((-s_, c), half[1]), ((s_, -c), half[1])]
                else:  # cylinder: four sides along the world axes
                    sides = [((1.0, 0.0), sh.radius), ((-1.0, 0.0), sh.radius), ((0.0, 1.0), sh.radius),
                             ((0.0, -1.0), sh.radius)]
                for (nx_, ny_), h in sides:
                    x = sh.center[0] + nx_ * (h + standoff)
                    y = sh.center[1] + ny_ * (h + standoff)
                    try:
                        iy, ix = nav.cell(x, y)
                    except PlacementError:
                        continue
                    if self.world.feasible[iy, ix]:
                        out.append((iy * nav.shape[1] + ix, math.atan2(-ny_, -nx_)))
            self._fixed = out
        return self._fixed

    def _rank_fixed(self, opts: list[Option]) -> list[tuple]:
        """Fixed placements by decreasing manipulability of each (arm, candidate) at the placement's yaw."""
        nav = self.world.nav
        ranked = []
        for flat, yaw in self.fixed_placements():
            for k, o in enumerate(opts):
                rmap = self.maps[o.arm]
                v, _ = manipulation_map(rmap, o.candidate.poses, nav, np.array([yaw]), np.array([flat]))
                value = float(v.flat[flat])
                if value >= self.params["threshold"]:
                    ranked.append((-value, k, flat, yaw))
        ranked.sort(key=lambda r: (r[0], r[1], r[2]))
        return ranked

    def _ik(self, o: Option, base, seed):
        x, y, yaw = base
        B = np.eye(4)
        B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
        B[:2, 3] = (x, y)
        Binv = np.linalg.inv(B)
        q = np.asarray(seed, dtype=float)
        for pose in o.candidate.poses:
            res = solve_ik(self.robot, o.arm, Binv @ pose, q, seeds=4, pos_tol=2e-3, rot_tol=2e-2)
            if not res.success:
                return None
            q = res.q
        return q

    def _step_json(self, i, action, target, o, base, q, nav_c, heur_c, value, timings):
        p = self.params
        cost = p["lambda_n"] * float(nav_c) + p["lambda_m"] / float(value) + p["lambda_nh"] * float(heur_c)
        arm = self.robot.arm(o.arm)
        joints = {name: float(v) for name, v in zip(arm.joints, q)}
        joints.update(self.robot.fixed_joints)
        return {
            "step": i, "action": action, "target": target, "arm": o.arm, "grasp": o.candidate.name,
            "base": [round(base[0], 6), round(base[1], 6), round(base[2], 6)],
            "tcp": [matrix_to_pose(T) for T in o.candidate.poses],
            "joints": joints,
            "manipulability": float(value),
            "cost": {"total": cost, "navigation": p["lambda_n"] * float(nav_c),
                     "manipulation": p["lambda_m"] / float(value), "heuristic": p["lambda_nh"] * float(heur_c)},
            "travel_time_s": float(nav_c) / self.robot.v_max,
            "timings_ms": {k: round(v, 3) for k, v in timings.items()},
        }

    def _robot_json(self) -> dict:
        return {"name": self.robot.name, "base_frame": self.robot.base_frame,
                "arms": {a: {"joints": list(self.robot.arm(a).joints), "tip_frame": self.robot.arm(a).tip_frame,
                             "tcp_offset": matrix_to_pose(self.robot.arm(a).tcp_offset)} for a in self.maps}}


def plan(scene: Scene | str | Path, method: str = "sequential", maps: str | Path | None = None) -> dict:
    """Plan a scene's whole task (SPEC section 9): the JSON document of SPEC section 7 as a dict."""
    return Planner(scene, method, maps).plan()
