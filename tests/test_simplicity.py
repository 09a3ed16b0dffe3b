"""The sweep-line simplicity test against a naive O(n^2) reference, on random and degenerate polygons."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from placement.simplicity import edges_meet, orient, self_crossing


def naive_crossing(points) -> tuple[int, int] | None:
    """Every pair of edges, with the same exact predicates: the first meeting pair, or None."""
    pts = [(float(x), float(y)) for x, y in points]
    k = len(pts)
    for i in range(k):
        for j in range(i + 1, k):
            if edges_meet(pts, i, j):
                return (i, j)
    return None


def _no_repeats(points) -> bool:
    return all(tuple(points[i]) != tuple(points[i - 1]) for i in range(len(points)))


def _agree(points):
    fast, slow = self_crossing(points), naive_crossing(points)
    assert (fast is None) == (slow is None), (points, fast, slow)
    if fast is not None:  # the pair the sweep names really meets
        assert edges_meet([tuple(map(float, p)) for p in points], *fast)


# small integer grids: vertical edges, shared vertices, collinear overlaps and spikes are common
grid_polygons = st.lists(st.tuples(st.integers(0, 4), st.integers(0, 4)), min_size=3, max_size=9).filter(_no_repeats)
float_polygons = st.lists(
    st.tuples(st.floats(-10, 10, allow_nan=False), st.floats(-10, 10, allow_nan=False)), min_size=3, max_size=12
).filter(_no_repeats)


@settings(deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(points=grid_polygons)
def test_sweep_agrees_with_the_naive_test_on_degenerate_grids(points):
    _agree(points)


@settings(deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(points=float_polygons)
def test_sweep_agrees_with_the_naive_test_on_random_polygons(points):
    _agree(points)


@settings(deadline=None)
@given(
    n=st.integers(3, 60),
    seed=st.integers(0, 2**32 - 1),
    scale=st.sampled_from([1e-3, 1.0, 1e5]),
    offset=st.sampled_from([0.0, 1e5, -3e5]),
)
def test_star_shaped_polygons_are_simple(n, seed, scale, offset):
    """Random radii at sorted angles: always simple, also tiny or far from the origin."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * math.pi, n))
    if len(np.unique(t)) < n:
        return
    r = rng.uniform(0.2, 1.0, n) * scale
    pts = np.c_[r * np.cos(t), r * np.sin(t)] + offset
    if not _no_repeats(pts.tolist()):
        return
    _agree(pts)


@pytest.mark.parametrize(
    "points, simple",
    [
        ([(0, 0), (1, 0), (1, 1), (0, 1)], True),
        ([(0, 0), (1, 1), (1, 0), (0, 1)], False),  # bow tie
        ([(0, 0), (4, 0), (4, 4), (2, 0.0), (0, 4)], False),  # a vertex on another edge
        ([(0, 0), (2, 0), (1, 0), (1, 1)], False),  # a spike back along an edge
        ([(0, 0), (3, 0), (3, 1), (1, 1), (1, 0.0), (0, 1)], False),  # a vertex touching an edge from above
        ([(0, 0), (4, 0), (4, 1), (2, 1), (2, 0), (1, 1)], False),  # collinear edges overlapping
        ([(0, 0), (2, 0), (2, 2), (1, 2), (1, 1), (1, 2), (0, 2)], False),  # a vertex visited twice
        ([(0, 0), (10, 0), (10, 10), (1, 1), (1, 9), (0, 10)], True),
        # a self-crossing polygon with unequal lobes (its area is not zero, so the area test misses it)
        ([(0, 0), (4, 0), (4, 3), (-1, -1), (-1, 1)], False),
    ],
)
def test_known_polygons(points, simple):
    assert (self_crossing(points) is None) == simple
    assert (naive_crossing(points) is None) == simple


def test_orientation_is_exact_where_floats_round():
    # points that are collinear in exact arithmetic but whose float determinant is not 0, and back
    eps = math.ulp(0.5)
    assert orient((0.5, 0.5), (12.0, 12.0), (24.0, 24.0)) == 0
    assert orient((0.5, 0.5 + eps), (12.0, 12.0), (24.0, 24.0)) == 1  # above the line: a left turn
    assert orient((0.5, 0.5 - eps), (12.0, 12.0), (24.0, 24.0)) == -1


@pytest.mark.slow
def test_a_100000_vertex_circle_is_simple_in_seconds():
    """Neighbouring edges turn by 6e-5 rad: nearly collinear, never touching."""
    for n, centre, radius in ((100_000, 0.0, 1.0), (20_000, 1e5, 0.3)):
        t = np.linspace(0, 2 * math.pi, n, endpoint=False)
        pts = np.c_[centre + radius * np.cos(t), centre - radius * np.sin(t)]
        t0 = time.perf_counter()
        assert self_crossing(pts) is None
        assert time.perf_counter() - t0 < 20  # about 3 s on a loaded 2-core machine
    # one vertex pushed across the circle is found
    t = np.linspace(0, 2 * math.pi, 100_000, endpoint=False)
    pts = np.c_[np.cos(t), np.sin(t)]
    pts[50_000] = (2.0, 0.0)
    assert self_crossing(pts) is not None


def _comb(teeth: int) -> list[tuple[float, float]]:
    top = []
    for i in range(teeth):
        top += [(2.0 * i, 1.0), (2.0 * i, 10.0), (2.0 * i + 1, 10.0), (2.0 * i + 1, 1.0)]
    pts = [(2.0 * teeth, 0.0), (2.0 * teeth, 1.0), *top[::-1], (0.0, 0.0)]
    return [p for k, p in enumerate(pts) if p != pts[k - 1]]


def test_a_comb_is_checked_in_n_log_n():
    """A comb of 4,000 teeth (16,000 vertices): thousands of edges cross the sweep line at once."""
    pts = _comb(4000)
    t0 = time.perf_counter()
    assert self_crossing(pts) is None
    assert time.perf_counter() - t0 < 20
    for shift in (0.5, 1.0, 2.5):  # one tooth's tip moved right: inside its gap, onto, across the next
        small = _comb(30)
        small[41] = (small[41][0] + shift, small[41][1])
        _agree(small)
    bad = list(pts)
    bad[8001] = (bad[8001][0] + 2.5, bad[8001][1])
    found = self_crossing(bad)
    assert found is not None and edges_meet(bad, *found)
