"""Progress ETAs: none until there is enough to go on, then not wildly off for a build that speeds up."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

from placement.progress import Eta, EtaBar

BLOCK = 1 << 19


def speeding_up(total: int, pause: float = 0.0, a=1.5e-6, b=6.5e-6, cells=3e6):
    """(done, time [s]) after each block of a build whose time per sample [s] falls as its map
    fills, ``a + b * cells / (cells + done)`` (samples that cannot raise their cell are cheap;
    after n samples a cell is raised with probability ~1 / (1 + n / cells)); ``pause`` [s] before
    the first block (a compile). The defaults fit the PR2's right arm at 0.1 m on the 2-core
    development machine under load (125 k samples/s at first, 350 k after 15 M, 150 M in about
    5 min); ``a=0.5e-6, b=7.5e-6, cells=1.3e6`` fits it idle (150 M in 121 s, `make bench`)."""

    def elapsed(n):  # the integral of the time per sample from 0 to n
        return a * n + b * cells * np.log1p(n / cells)

    return [(min(done, total), pause + elapsed(min(done, total))) for done in range(BLOCK, total + BLOCK, BLOCK)]


def test_no_eta_from_the_first_updates():
    eta = Eta()
    eta.start(0.0)
    total = 150_000_000
    updates = speeding_up(total, pause=85.0)  # the first-ever build
    for done, t in updates[:3]:
        eta.add(done, t)
        assert eta.remaining(total) is None
    assert Eta().remaining(total) is None and eta.remaining(0) is None


@pytest.mark.parametrize(
    ("pause", "total", "model"),
    [
        (0.0, 150_000_000, {}),
        (85.0, 150_000_000, {}),
        (0.0, 150_000_000, {"cells": 1e6}),
        (0.0, 150_000_000, {"a": 0.5e-6, "b": 7.5e-6, "cells": 1.3e6}),
        (85.0, 150_000_000, {"a": 0.5e-6, "b": 7.5e-6, "cells": 0.5e6}),
        (0.0, 150_000_000, {"cells": 30e6}),
        (0.0, 40_000_000, {"a": 3e-6, "b": 20e-6, "cells": 5e6}),
        (0.0, 20_000_000, {"b": 0.0}),  # no speed-up at all
    ],
)
def test_eta_follows_the_speed_up(pause, total, model):
    updates = speeding_up(total, pause=pause, **model)
    eta = Eta()
    eta.start(0.0)
    first = None
    for done, t in updates:
        eta.add(done, t)
        left = eta.remaining(total)
        if left is not None and first is None:
            first = (left, updates[-1][1] - t, done)
        if left is not None:
            true_left = updates[-1][1] - t
            # the speed-up is extrapolated: neither far over nor far under the truth
            assert 0.6 * true_left - 5 <= left <= 1.7 * true_left + 5, (done, left, true_left)
    assert first is not None and first[2] <= max(0.06 * total, 3 * BLOCK)  # an ETA appears early
    if pause:  # what the plain average rate said at the first update (the 3 h 39 min)
        done, t = updates[0]
        assert (total - done) * t / done > 10 * (updates[-1][1] - t)


def test_constant_rate_is_extrapolated_exactly():
    eta = Eta(min_fraction=0.0, min_updates=2)
    eta.start(10.0)
    for k in range(1, 5):
        eta.add(100 * k, 10.0 + k)
    assert eta.remaining(1000) == pytest.approx(6.0)
    eta.add(1000, 20.0)
    assert eta.remaining(1000) == 0.0


def test_bar_shows_question_mark_then_a_time():
    with EtaBar(total=100, file=io.StringIO(), mininterval=0, miniters=1) as bar:
        bar.update(1)
        assert "<?," in str(bar)
        for _ in range(9):
            time.sleep(0.01)
            bar.update(1)
        text = str(bar)
    assert "<?," not in text and "10/100" in text and "<00:0" in text
