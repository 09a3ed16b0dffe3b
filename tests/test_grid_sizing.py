"""Map grids sized from the TCP positions an arm reaches (placement/maps/reach.py), not link lengths."""

from __future__ import annotations

import numpy as np
import pytest
from support.telescoping import REACH_X, telescoping_robot

from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.sampling import sample_configs
from placement.maps import build as build_module
from placement.maps.build import build_map, default_grid, provable_grid
from placement.maps.reach import grid_margin, reach_box


@pytest.fixture(scope="module")
def telescoping(tmp_path_factory):
    return telescoping_robot(tmp_path_factory.mktemp("telescoping"))


def sampled_positions(robot, arm: str, seed: int, count: int, block: int = 100_000):
    """TCP positions (count, 3) [m] of the build's counter-based samples ``0 .. count-1`` of ``seed``."""
    a = robot.arm(arm)
    ch = a.chain
    for start in range(0, count, block):
        Q = sample_configs(np.uint64(seed), start, min(block, count - start), a.lower, a.upper)
        T, _ = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
        yield T[:, :3, 3]


@pytest.mark.parametrize("which", ["pr2", "telescoping"])
def test_a_million_samples_stay_in_the_box_without_its_margin(which, pr2, telescoping):
    """The box itself (before the grid's margin of a cell and 5 %) holds the TCP of each of 1 M build
    samples (seeds 0 and 1): the margin is slack, not a guess."""
    robot, arm = (pr2, "right") if which == "pr2" else (telescoping, "arm")
    lo, hi = reach_box(robot, arm)
    over = 0.0
    for seed, count in ((0, 600_000), (1, 400_000)):
        for p in sampled_positions(robot, arm, seed, count):
            over = max(over, float(np.max(p - hi)), float(np.max(lo - p)))
    assert over <= 1e-9, over
    # and the box is the reach's own: the samples come within 5 cm of every face
    assert np.all(grid_margin(lo, hi, 0.05) > 0.05)


def test_pr2_grid_close_to_the_link_length_cube(pr2):
    """The PR2's arm reaches about as far in every direction as its link lengths: the grid stays
    within 20 % of the old cube's cell count (see docs/maps.md for the numbers)."""
    for res in (0.05, 0.1):
        new, old = default_grid(pr2, "right", res), provable_grid(pr2, "right", res)
        assert 0.8 * old.size <= new.size <= 1.2 * old.size, (res, new.shape, old.shape)


def test_telescoping_grid_is_its_reach(telescoping):
    """The telescoping arm's grid spans its forward reach, not a 5 m cube of link lengths and strokes."""
    lo, hi = reach_box(telescoping, "arm")
    assert hi[0] == pytest.approx(REACH_X, abs=0.01)  # all extended, wrist straight: the exact extreme
    g = default_grid(telescoping, "arm", 0.1)
    old = provable_grid(telescoping, "arm", 0.1)
    assert old.shape[0] * 0.1 > 5.0  # what the link-length bound gave
    assert np.prod(g.shape[:3]) * 30 < np.prod(old.shape[:3])
    extent = np.array(g.shape[:3]) * 0.1
    assert np.all(extent <= (hi - lo) + 2 * grid_margin(lo, hi, 0.1) + 0.2 + 1e-9)  # + rounding to cells


def test_a_sample_outside_the_box_rebuilds_on_the_link_length_cube(pr2, monkeypatch, capsys):
    """Fault injection: a box far too small. The build says so on stderr and builds on the provable
    cube, which every sample lies in; the metadata names the bound."""

    def tiny(robot, arm):
        return np.zeros(3), np.full(3, 0.01)

    monkeypatch.setattr(build_module, "reach_box", tiny)
    built = build_map(pr2, "right", samples=3000, resolution=0.25, bins=(4, 3, 4), progress=False)
    assert built.meta["grid_bound"] == "link lengths"
    assert built.grid == provable_grid(pr2, "right", 0.25, (4, 3, 4))
    assert "fell outside the grid of the arm's sampled reach" in capsys.readouterr().err
