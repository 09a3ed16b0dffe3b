"""Polygon base footprints: no feasible base pose comes near an obstacle shape (exact geometry), the
fast band kernel equals a brute-force reference, and a round base behaves as before."""

from __future__ import annotations

import math

import numpy as np
import pytest

from placement.planning.problems.manipulation import base_yaws
from placement.planning.settings import PlannerConfig
from placement.planning.world.footprints import BaseShape
from placement.planning.world.layers import add_shape, add_touched, world_from_occupancy
from placement.planning.world.navigation import distance_map
from placement.scene import Box, Cylinder, Polygon
from placement.scene.navgrid import NavGrid

SQUARE = np.array([[0.335, 0.335], [-0.335, 0.335], [-0.335, -0.335], [0.335, -0.335]])


# -- an independent oracle: distances between placed polygons and shapes ----------------------
def _point_seg(p, a, b):
    """Distances (...,) from points p (..., 2) to segments a-b (..., 2)."""
    d = b - a
    t = np.clip(np.sum((p - a) * d, -1) / np.maximum(np.sum(d * d, -1), 1e-300), 0, 1)
    return np.linalg.norm(p - a - t[..., None] * d, axis=-1)


def _cross(o, a, b):
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])


def _inside(p, poly):
    """Even-odd: points p (..., 2) inside polygons poly (..., k, 2) (broadcast)."""
    out = np.zeros(np.broadcast_shapes(p.shape[:-1], poly.shape[:-2]), bool)
    for i in range(poly.shape[-2]):
        a, b = poly[..., i, :], poly[..., (i + 1) % poly.shape[-2], :]
        with np.errstate(divide="ignore", invalid="ignore"):
            xi = a[..., 0] + (p[..., 1] - a[..., 1]) * (b[..., 0] - a[..., 0]) / (b[..., 1] - a[..., 1])
        out ^= ((a[..., 1] > p[..., 1]) != (b[..., 1] > p[..., 1])) & (p[..., 0] < xi)
    return out


def poly_distance(P, Q):
    """Distance (N,) between polygons P (N, k, 2) and polygon Q (m, 2), or each P[n] and its own Q[n] of Q
    (N, m, 2); 0 when they overlap."""
    N, k = P.shape[:2]
    m = Q.shape[-2]
    Qb = np.broadcast_to(Q, (N, m, 2))
    best = np.full(N, np.inf)
    hit = _inside(P[:, 0], Qb) | _inside(Qb[:, 0], P)
    for i in range(k):
        a, b = P[:, i], P[:, (i + 1) % k]
        for j in range(m):
            c, d = Qb[:, j], Qb[:, (j + 1) % m]
            hit |= (_cross(a, b, c) * _cross(a, b, d) < 0) & (_cross(c, d, a) * _cross(c, d, b) < 0)
            best = np.minimum.reduce(
                [best, _point_seg(c, a, b), _point_seg(d, a, b), _point_seg(a, c, d), _point_seg(b, c, d)]
            )
    return np.where(hit, 0.0, best)


def shape_distance(P, shape) -> np.ndarray:
    """Distance (N,) between placed footprints P (N, k, 2) and a scene shape, from its parameters."""
    if isinstance(shape, Cylinder):
        c = np.asarray(shape.center[:2], float)
        k = P.shape[1]
        edge = np.min([_point_seg(c, P[:, i], P[:, (i + 1) % k]) for i in range(k)], axis=0)
        return np.where(_inside(np.broadcast_to(c, (len(P), 2)), P), 0.0, np.maximum(edge - shape.radius, 0.0))
    if isinstance(shape, Box):
        u = np.array([math.cos(shape.yaw), math.sin(shape.yaw)])
        v = np.array([-u[1], u[0]])
        hx, hy = shape.size[0] / 2, shape.size[1] / 2
        Q = np.array([shape.center[:2] + sx * hx * u + sy * hy * v for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])
        return poly_distance(P, Q)
    return poly_distance(P, np.asarray(shape.points, float))


def _random_shape(rng, lo, hi):
    c = [rng.uniform(lo, hi), rng.uniform(lo, hi), 0.5]
    kind = rng.integers(3)
    if kind == 0:  # thin ones too: thinner than a cell, they may cover no cell centre
        return Box(c, [rng.uniform(0.01, 0.6), rng.uniform(0.01, 0.6), 1.0], rng.uniform(-3, 3))
    if kind == 1:
        return Cylinder(c, rng.uniform(0.01, 0.3), 1.0)
    a = np.sort(rng.uniform(0, 2 * np.pi, 5))
    r = rng.uniform(0.05, 0.4, 5)
    return Polygon(np.c_[c[0] + r * np.cos(a), c[1] + r * np.sin(a)])


def _random_footprint(rng):
    a = np.sort(rng.uniform(0, 2 * np.pi, rng.integers(3, 7)))
    a[0] = 0.0 if len(a) > 3 else a[0]
    r = rng.uniform(0.15, 0.45, len(a))
    pts = np.c_[r * np.cos(a), r * np.sin(a)]
    # a star-shaped polygon around the origin; the origin inside needs no gap of pi or more
    gaps = np.diff(np.r_[a, a[0] + 2 * np.pi])
    return pts if gaps.max() < np.pi - 0.1 else SQUARE * rng.uniform(0.4, 1.0, 2)


def _world(shapes, polygon, nav, yaws, padding):
    occ, touched = np.zeros(nav.shape, bool), np.zeros(nav.shape, bool)
    for s in shapes:
        add_shape(occ, s, nav)
        add_touched(touched, s, nav)
    base = BaseShape(float(np.max(np.hypot(*polygon.T))), polygon, padding, yaws)
    return world_from_occupancy(nav, occ, base, PlannerConfig(), touched), base


def _bits(masks, K):
    return np.array([[(int(m[k >> 6]) >> (k & 63)) & 1 for k in range(K)] for m in masks], bool).reshape(-1, K)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(8))
def test_no_feasible_pose_comes_near_an_obstacle_shape(seed):
    rng = np.random.default_rng(seed)
    res = [0.05, 0.1, 0.07][seed % 3]
    nav = NavGrid((rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1)), res, (int(2.0 / res), int(2.0 / res)))
    shapes = [_random_shape(rng, 0.2, 1.8) for _ in range(4)]
    polygon = SQUARE if seed % 4 == 0 else _random_footprint(rng)
    yaws = base_yaws(12 if seed % 2 else 66)  # 66: two mask words
    pad = [0.0, 0.02, 0.05][seed % 3]
    world, base = _world(shapes, polygon, nav, yaws, pad)
    cells = np.arange(nav.shape[0] * nav.shape[1])
    allowed = _bits(world.yaw_masks(cells), len(yaws))
    assert np.array_equal(allowed.any(axis=1), world.feasible.ravel())
    xs, ys = nav.centres()
    iy, ix = np.divmod(cells, nav.shape[1])
    n_ok = 0
    for k, yaw in enumerate(yaws):
        sel = allowed[:, k]
        P = np.stack([base.placed(xs[i], ys[j], yaw) for j, i in zip(iy[sel], ix[sel])]) if sel.any() else None
        if P is None:
            continue
        for s in shapes:
            d = shape_distance(P, s)
            assert d.min() >= pad - 1e-9, (k, s, d.min())
        n_ok += sel.sum()
    assert n_ok > 0.05 * allowed.size  # not everything rejected


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_band_masks_equal_a_brute_force_reference(seed):
    """Every cell and yaw: blocked iff the placed footprint comes within the padding of a touched square."""
    rng = np.random.default_rng(100 + seed)
    res = 0.1 if seed % 2 else 0.08
    nav = NavGrid((0.0, 0.0), res, (int(1.6 / res), int(1.8 / res)))
    shapes = [_random_shape(rng, 0.3, 1.4) for _ in range(2)]
    polygon = _random_footprint(rng)
    yaws = base_yaws(int(rng.integers(1, 12)) if seed else 66)  # 66: two mask words
    pad = float(rng.uniform(0, 0.05))
    world, base = _world(shapes, polygon, nav, yaws, pad)
    allowed = _bits(world.yaw_masks(np.arange(world.feasible.size)), len(yaws))
    xs, ys = nav.centres()
    iy, ix = np.divmod(np.arange(world.feasible.size), nav.shape[1])
    h = res / 2
    squares = np.array(
        [
            [[xs[b] - h, ys[a] - h], [xs[b] + h, ys[a] - h], [xs[b] + h, ys[a] + h], [xs[b] - h, ys[a] + h]]
            for a, b in zip(*np.nonzero(world.touched))
        ]
    ).reshape(-1, 4, 2)
    for k, yaw in enumerate(yaws):
        P = np.stack([base.placed(xs[i], ys[j], yaw) for j, i in zip(iy, ix)])
        # every (cell, touched square) pair in one call: row n * len(squares) + s is cell n and square s
        pairs = poly_distance(np.repeat(P, len(squares), axis=0), np.tile(squares, (len(P), 1, 1)))
        d = pairs.reshape(len(P), len(squares)).min(axis=1, initial=np.inf)
        unsure = np.abs(d - pad) < 1e-5
        assert np.array_equal(allowed[~unsure, k], d[~unsure] > pad), k
    assert 0 < allowed.sum() < allowed.size


@pytest.mark.slow
def test_touched_squares_cover_the_shapes_and_spare_shared_edges():
    rng = np.random.default_rng(5)
    nav = NavGrid((0.0, 0.0), 0.05, (60, 60))
    for _ in range(30):
        s = _random_shape(rng, 0.4, 2.6)
        touched = np.zeros(nav.shape, bool)
        add_touched(touched, s, nav)
        pts = rng.uniform(0, 3, (20000, 2))
        P = np.repeat(pts[:, None], 3, axis=1)  # a point as a degenerate polygon
        inside = shape_distance(P, s) == 0
        cells = np.floor(pts[inside] / 0.05).astype(int)
        assert touched[cells[:, 1], cells[:, 0]].all()
    # a box on cell boundaries marks its own cells only
    touched = np.zeros(nav.shape, bool)
    add_touched(touched, Box([1.0, 1.0, 0.5], [0.5, 0.3, 1.0], 0.0), nav)
    assert touched.sum() == 10 * 6 and touched[17:23, 15:25].all()


def test_round_base_is_the_distance_test_at_every_yaw():
    nav = NavGrid((0.0, 0.0), 0.05, (40, 50))
    occ = np.zeros(nav.shape, bool)
    add_shape(occ, Box([1.2, 1.0, 0.5], [0.4, 0.3, 1.0], 0.4), nav)
    yaws = base_yaws(100)
    world = world_from_occupancy(nav, occ, BaseShape(0.47, None, 0.02, yaws), PlannerConfig())
    assert np.array_equal(world.feasible, distance_map(occ, 0.05) >= 0.47) and world.masks is None
    masks = _bits(world.yaw_masks(np.arange(occ.size)), 100)
    assert np.array_equal(masks.all(axis=1), world.feasible.ravel())
    assert not masks[~world.feasible.ravel()].any()


@pytest.mark.slow
def test_the_square_base_parks_flush_facing_a_table_but_not_across():
    """An aligned 0.67 m square fits 0.375 m from a table edge facing it (0.335 + 0.02 padding, the
    next cell centre), but not diagonally: its corner would reach the table."""
    nav = NavGrid((0.0, 0.0), 0.05, (80, 80))
    table = Box([2.0, 1.0, 0.375], [1.2, 0.6, 0.75], 0.0)  # edge at y = 1.3
    yaws = base_yaws(8)
    world, base = _world([table], SQUARE, nav, yaws, 0.02)
    iy, ix = nav.cell(2.0, 1.675)
    allowed = _bits(world.yaw_masks(np.array([iy * 80 + ix])), 8)[0]
    assert allowed[[0, 2, 4, 6]].all() and not allowed[[1, 3, 5, 7]].any()
    assert not world.pose_clear(2.0, 1.625, 0.0) and world.pose_clear(2.0, 1.66, 0.0)
    assert not world.pose_clear(2.0, 1.66, math.pi / 4)


@pytest.mark.parametrize(("value", "ok"), [(0.0, True), (0.05, True), (-0.01, False), (1.5, False), ("a", False)])
def test_footprint_padding_key(value, ok):
    import yaml

    from placement.scene import SceneError, parse_scene

    doc = yaml.safe_load(open("examples/table_clearing.yaml"))
    doc["planner"] = {"footprint_padding": value}
    if ok:
        assert PlannerConfig.from_overrides(parse_scene(doc, "examples", "s").planner).footprint_padding == value
    else:
        with pytest.raises(SceneError, match=r"planner\.footprint_padding") as e:
            parse_scene(doc, "examples", "s")
        assert "\n" not in str(e.value)


@pytest.mark.parametrize(("preset", "gap"), [("pr2", 0.375), ("tests/data/pr2_round.yaml", 0.475)])
def test_fixed_parks_at_the_footprints_half_depth(maps_dir, preset, gap):
    """The example's tables have their edges on cell boundaries: the square PR2 parks 0.335 + 0.02 m
    from each side (0.375 m, the next cell centre), the round one 0.47 + 0.02 m (0.475 m)."""
    from dataclasses import replace
    from pathlib import Path

    from placement.planning.methods.fixed import fixed_placements
    from placement.planning.planner import Planner
    from placement.scene import load_scene

    scene = load_scene("examples/table_clearing.yaml")
    planner = Planner(
        replace(scene, robot_preset=str(Path(preset).resolve()) if "/" in preset else preset), "fixed", maps_dir
    )
    xs, ys = planner.world.nav.centres()
    placements = fixed_placements(planner)
    assert len(placements) >= 10
    for flat, yaw in placements:
        iy, ix = divmod(flat, len(xs))
        gaps = [
            max(
                abs(xs[ix] - t.shape.center[0]) - t.shape.size[0] / 2,
                abs(ys[iy] - t.shape.center[1]) - t.shape.size[1] / 2,
            )
            for t in scene.tables
        ]
        assert min(gaps) == pytest.approx(gap, abs=1e-9)
        assert planner.world.pose_clear(xs[ix], ys[iy], yaw)


@pytest.mark.parametrize("seed", range(6))
def test_an_obstacle_change_gives_the_world_built_anew(seed):
    """After obstacles are added or removed, the yaw masks taken from the previous world far from the
    change and recomputed near it equal a world computed from scratch, bit for bit."""
    from placement.planning.world.layers import changed_occupancy

    rng = np.random.default_rng(200 + seed)
    res = 0.05 if seed % 2 else 0.1
    nav = NavGrid((0.0, 0.0), res, (int(3.0 / res), int(3.5 / res)))
    shapes = [_random_shape(rng, 0.2, 2.8) for _ in range(5)]
    polygon = SQUARE * 0.8 if seed % 3 == 0 else _random_footprint(rng)
    yaws = base_yaws(66 if seed == 1 else 16)
    world, base = _world(shapes, polygon, nav, yaws, 0.02)

    class Ob:  # what changed_occupancy needs of a scene obstacle
        def __init__(self, shape):
            self.shape = shape

    obs = [Ob(s) for s in shapes]
    for step in range(3):
        removed = [obs.pop(int(rng.integers(len(obs))))] if step != 1 and len(obs) > 1 else []
        added = [Ob(_random_shape(rng, 0.2, 2.8))] if step != 2 else []
        occ = changed_occupancy(world.occupied, nav, removed, obs, added)
        touched = changed_occupancy(world.touched, nav, removed, obs, added, draw=add_touched)
        obs += added
        updated = world_from_occupancy(nav, occ, base, PlannerConfig(), touched, world)
        fresh, _ = _world([o.shape for o in obs], polygon, nav, yaws, 0.02)
        fresh = world_from_occupancy(nav, fresh.occupied, base, PlannerConfig(), fresh.touched)
        assert np.array_equal(updated.touched, fresh.touched) and np.array_equal(updated.feasible, fresh.feasible)
        assert np.array_equal(updated.masks.cells, fresh.masks.cells)
        assert np.array_equal(updated.masks.bits, fresh.masks.bits), step
        world = updated
