"""``face_target``: the base yaw facing the target among those that keep most of the map value."""

from __future__ import annotations

import dataclasses
import math
import statistics
from pathlib import Path

import numpy as np
import pytest

from placement.planning import Planner, facing
from placement.planning.facing import facing_yaw
from placement.planning.problems.manipulation import yaw_values
from placement.planning.torso import option_map
from placement.scene import load_scene

LAB = Path(__file__).resolve().parents[1] / "examples" / "buildings" / "brsu_home_lab" / "tidy_up.yaml"


def off_heading(step) -> float:
    """The angle [deg] between a planned step's base heading and its last TCP position."""
    return facing.off_heading(step.base, (float(step.tcp[-1][0, 3]), float(step.tcp[-1][1, 3])))


def planner(maps_dir, method: str, share: float) -> Planner:
    scene = load_scene(LAB)
    overrides = {"face_target": share, "time_budget_s": 3600.0, "ik_budget_ms": 60000.0}
    return Planner(dataclasses.replace(scene, planner=overrides), method, maps_dir)


def test_facing_yaw_is_the_nearest_bearing_among_the_yaws_that_keep_the_value(maps_dir):
    p = planner(maps_dir, "sequential", 0.4)
    ctx, nav = p.context, p.world.nav
    xs, ys = nav.centres()
    checked = 0
    for o in p.problems.options(0):
        for iy, ix in zip(*np.nonzero(o.value >= ctx.threshold(o.arm, o.torso))):
            iy, ix = iy + o.window.y0, ix + o.window.x0
            flat = int(iy * nav.shape[1] + ix)
            if not p.world.feasible.flat[flat]:
                continue
            x, y = float(xs[ix]), float(ys[iy])
            best = float(ctx.yaws[o.yaw_at(iy, ix)])
            got = facing_yaw(ctx, o, x, y, flat, best)
            # reference: every yaw, its value, its footprint bit (unpacked byte-wise), the bearing, by hand
            v = yaw_values(option_map(ctx, o), o.candidate.poses, np.array([x]), np.array([y]), ctx.yaws)[0]
            words = p.world.yaw_masks(np.array([flat]))[0]  # bit k of word k >> 6: yaw k fits
            fits = np.unpackbits(words.astype("<u8").view(np.uint8), bitorder="little")[: len(ctx.yaws)]
            floor = max(ctx.threshold(o.arm, o.torso), 0.6 * float(v[fits.astype(bool)].max()))
            ok = [k for k in range(len(ctx.yaws)) if fits[k] and v[k] >= floor and v[k] > 0]
            assert ok  # the cell keeps the threshold at its best yaw, which fits
            tx, ty = o.candidate.poses[-1][:2, 3]
            bearing = math.atan2(ty - y, tx - x)
            want = min(ok, key=lambda k: (abs((ctx.yaws[k] - bearing + math.pi) % (2 * math.pi) - math.pi), k))
            if abs(float(ctx.yaws[want]) - best) < 1e-12:
                assert got is None
            else:
                assert got == (pytest.approx(float(ctx.yaws[want])), pytest.approx(float(v[want])))
            checked += 1
            if checked >= 40:
                return
    assert checked > 10


def test_facing_turns_the_base_towards_the_target_and_every_step_verifies(maps_dir):
    plain = planner(maps_dir, "sequential", 0.0).plan()
    facing_planner = planner(maps_dir, "sequential", 1.0)
    facing = facing_planner.plan()
    assert plain.ok and facing.ok
    assert facing.verify(facing_planner.robot) == []
    before = statistics.median(off_heading(s) for s in plain.steps)
    after = statistics.median(off_heading(s) for s in facing.steps)
    assert after < before - 10, (before, after)
