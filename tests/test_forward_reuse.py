"""A step whose region only lost cells keeps its layer (no Dijkstra): the same labels and chains as a
program solved from scratch, on random tasks."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_bound import RES, random_task

import placement.planning.program.forward as bound
from placement.planning.program.forward import Regions, backtrack, forward


@pytest.mark.parametrize("seed", range(10))
def test_a_narrowed_step_keeps_its_layer_and_the_result(seed, monkeypatch):
    rng = np.random.default_rng(500 + seed)
    linked = [False, True, False, True, False]
    factor, feasible, start, regions = random_task(rng, 9, 10, 5, linked)
    layers = forward(factor, feasible, RES, start, regions, linked)
    i = int(rng.integers(0, 5))
    masks = regions[i].masks & (rng.random(regions[i].masks.shape) > 0.3)  # a few cells rejected
    changed = [*regions[:i], replace(regions[i], masks=masks), *regions[i + 1 :]]
    calls = []
    real = bound.costs_at
    monkeypatch.setattr(bound, "costs_at", lambda *a, **k: calls.append(1) or real(*a, **k))
    again = forward(factor, feasible, RES, start, changed, linked, layers, first=i, before=regions)
    monkeypatch.undo()
    fresh = forward(factor, feasible, RES, start, changed, linked)
    for a, b in zip(again, fresh):
        np.testing.assert_array_equal(a.labels, b.labels)
    a, b = backtrack(again, changed, linked), backtrack(fresh, changed, linked)
    assert (a is None) == (b is None)
    if a is not None:
        assert a.total == b.total
    # step i cost no Dijkstra: only the later steps did, as many as they do on their own
    later = []
    monkeypatch.setattr(bound, "costs_at", lambda *a, **k: later.append(1) or real(*a, **k))
    forward(factor, feasible, RES, start, changed, linked, again, first=i + 1)
    assert len(calls) == len(later)


def test_a_step_that_gained_cells_is_computed_again():
    rng = np.random.default_rng(3)
    linked = [False, False, False]
    factor, feasible, start, regions = random_task(rng, 8, 8, 3, linked)
    layers = forward(factor, feasible, RES, start, regions, linked)
    assert regions[2].node is None  # the same node costs (none): only the cells differ
    grown = Regions.of(regions[2].groups, regions[2].dense() | feasible[None])
    changed = [regions[0], regions[1], grown]
    again = forward(factor, feasible, RES, start, changed, linked, layers, first=2, before=regions)
    fresh = forward(factor, feasible, RES, start, changed, linked)
    for a, b in zip(again, fresh):
        np.testing.assert_array_equal(a.labels, b.labels)


@pytest.mark.parametrize("seed", range(4))
def test_a_grouped_places_searches_side_by_side_equal_one_after_the_other(seed):
    """A place that keeps its pick's group runs one Dijkstra per group, in threads
    (``StepLabels.search_all``): the same labels, roots and Dijkstra indices as :meth:`search` called
    group by group in the main thread."""
    from placement.planning.program.forward import StepLabels, seeds_of

    rng = np.random.default_rng(900 + seed)
    linked = [False, True]
    factor, feasible, start, regions = random_task(rng, 14, 15, 2, linked)
    first = forward(factor, feasible, RES, start, regions[:1], linked[:1])[0]
    width = feasible.shape[1]
    same = {g: k for k, g in enumerate(regions[0].groups)}
    seedings = [
        (seeds_of(first.cells, first.labels[same[g]], width), [k]) for k, g in enumerate(regions[1].groups) if g in same
    ]
    assert len(seedings) >= 2
    together, alone = StepLabels(regions[1], (factor, feasible, RES)), StepLabels(regions[1], (factor, feasible, RES))
    together.search_all(seedings)
    for seeds, members in seedings:
        alone.search(seeds, members)
    np.testing.assert_array_equal(together.labels, alone.labels)
    np.testing.assert_array_equal(together.dijkstra, alone.dijkstra)
    assert len(together.roots) == len(alone.roots) >= 2
    for a, b in zip(together.roots, alone.roots):
        np.testing.assert_array_equal(a, b)
    assert np.isfinite(together.labels).any()
