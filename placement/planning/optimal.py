"""The ``optimal`` yardstick: the whole task at once by dynamic programming.

Each step keeps a candidate set: the base cells on a 3-cell lattice whose 3 x 3
neighbourhood keeps the map threshold, with their best (arm, grasp, yaw), the
``CANDIDATES`` lowest manipulation costs per step. Exact navigation costs link
consecutive candidate sets (one Dijkstra per candidate, stopped once the next
step's candidates are settled), and the DP minimises the task's summed Eq. 6
cost without heuristic, ``sum_i lambda_n nav(r_{i-1}, r_i) + lambda_m / m(r_i)``,
which the one-step heuristic approximates. Chosen placements are IK-checked;
one that fails is removed and the DP rerun.
"""

from __future__ import annotations

import time

import numpy as np
from scipy import ndimage

from .navigation import navigation_cost

CANDIDATES = 40
LATTICE = 3
MAX_REPAIRS = 30


def _candidates(planner, i):
    """(flat cells (k,), option index (k,), yaw (k,), value (k,)) of step i."""
    p = planner.params
    nav = planner.world.nav
    best_val = np.zeros(nav.shape, np.float32)
    best_opt = np.full(nav.shape, -1, np.int64)
    for k, o in enumerate(planner.options(i)):
        inner = ndimage.minimum_filter(o.value, size=3, mode="constant", cval=0.0) >= p["threshold"]
        v = np.where(inner, o.value, 0.0)
        better = v > best_val
        best_val[better] = v[better]
        best_opt[better] = k
    lattice = np.zeros(nav.shape, bool)
    lattice[::LATTICE, ::LATTICE] = True
    flat = np.flatnonzero(lattice & (best_opt >= 0))
    if flat.size == 0:  # tiny feasible set: fall back to every inner cell
        flat = np.flatnonzero(best_opt >= 0)
    flat = flat[np.argsort(-best_val.flat[flat], kind="stable")[:CANDIDATES]]
    opts = planner.options(i)
    yaws = np.array([planner.yaws[opts[best_opt.flat[f]].yaw_index.flat[f]] for f in flat])
    return flat, best_opt.flat[flat], yaws, best_val.flat[flat].astype(float)


def plan_optimal(planner, start_cell) -> dict:
    """The SPEC section 7 document of the DP plan (``status`` infeasible if a step has no candidate)."""
    p = planner.params
    nav = planner.world.nav
    steps = planner.steps()
    t0 = time.perf_counter()
    cands = [_candidates(planner, i) for i in range(len(steps))]
    removed = [set() for _ in steps]
    prev_q = {arm: planner.robot.arm(arm).home.copy() for arm in planner.maps}
    for _ in range(MAX_REPAIRS):
        live = [np.array([j for j in range(len(c[0])) if j not in removed[i]], dtype=np.int64)
                for i, c in enumerate(cands)]
        for i, l in enumerate(live):
            if l.size == 0:
                action, target = steps[i]
                return _infeasible(planner, i, action, target)
        # DP over steps: cost[j] of reaching candidate j of step i
        shape = nav.shape

        def targets(i):
            m = np.zeros(shape, bool)
            m.flat[cands[i][0][live[i]]] = True
            return m

        nav0, _ = navigation_cost(planner.world.factor, planner.world.feasible, start_cell, nav.resolution,
                                  targets=targets(0))
        cost = p["lambda_n"] * nav0.flat[cands[0][0][live[0]]] + p["lambda_m"] / cands[0][3][live[0]]
        back = []
        for i in range(1, len(steps)):
            tgt = targets(i)
            nxt_cells = cands[i][0][live[i]]
            trans = np.empty((live[i - 1].size, live[i].size))
            for a, j in enumerate(live[i - 1]):
                src = divmod(int(cands[i - 1][0][j]), shape[1])
                c, _ = navigation_cost(planner.world.factor, planner.world.feasible, src, nav.resolution,
                                       targets=tgt)
                trans[a] = c.flat[nxt_cells]
            total = cost[:, None] + p["lambda_n"] * trans
            arg = np.argmin(total, axis=0)
            back.append(arg)
            cost = total[arg, np.arange(live[i].size)] + p["lambda_m"] / cands[i][3][live[i]]
        # backtrack
        choice = [int(np.argmin(cost))]
        for arg in reversed(back):
            choice.append(int(arg[choice[-1]]))
        choice.reverse()
        chosen = [int(live[i][c]) for i, c in enumerate(choice)]
        # verify with IK, in order
        out, prev_cell, failed = [], start_cell, None
        q_state = {k: v.copy() for k, v in prev_q.items()}
        for i, j in enumerate(chosen):
            flat, k, yaw, value = (cands[i][0][j], cands[i][1][j], cands[i][2][j], cands[i][3][j])
            o = planner.options(i)[k]
            iy, ix = divmod(int(flat), shape[1])
            xs, ys = nav.centres()
            base = (float(xs[ix]), float(ys[iy]), float(yaw))
            q = planner._ik(o, base, q_state[o.arm])
            if q is None:
                failed = (i, j)
                break
            here = np.zeros(shape, bool)
            here[iy, ix] = True
            navc, _ = navigation_cost(planner.world.factor, planner.world.feasible, prev_cell, nav.resolution,
                                      targets=here)
            action, target = steps[i]
            step = planner._step_json(i, action, target, o, base, q, navc[iy, ix], 0.0, value, {})
            out.append(step)
            prev_cell = (iy, ix)
            q_state[o.arm] = q
        if failed is None:
            ms = (time.perf_counter() - t0) * 1e3
            for s in out:
                s["timings_ms"] = {"total": round(ms / len(out), 3)}
            return {"scene": planner.scene.name, "method": "optimal", "robot": planner._robot_json(),
                    "status": "ok", "steps": out}
        removed[failed[0]].add(failed[1])
    return _infeasible(planner, len(steps) - 1, *steps[-1], reason="IK kept failing on the DP's choices")


def _infeasible(planner, i, action, target, reason="no base placement keeps the map threshold"):
    return {"scene": planner.scene.name, "method": "optimal", "robot": planner._robot_json(), "status": "infeasible",
            "steps": [{"step": i, "action": action, "target": target, "status": "infeasible", "reason": reason,
                       "timings_ms": {}}]}
