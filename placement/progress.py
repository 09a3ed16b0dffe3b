"""Progress bars whose ETA is not wildly off when the work speeds up as it goes.

A map build gets faster as its map fills: a sample that provably cannot raise its
cell is dropped before its manipulability is computed, and early on almost every
sample can. The average rate since the start (what a plain tqdm ETA extrapolates
from its first updates, a first-ever build's compile included) therefore overstates
the remaining time many times over, and so does the current rate, by up to 2x. :class:`Eta`
waits until enough work is done to estimate (5 %), then fits the time per sample of the
last two halvings of the work done as a power of the work done and extrapolates it:
within 0.6x to 1.6x of the truth at 5 % on the build models of tests/test_progress.py,
converging as the build goes on.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any, cast

from tqdm import tqdm

__all__ = ["Eta", "EtaBar", "Ticking"]


class Eta:
    """Remaining time [s] from (work done, time [s]) updates.

    Args:
        min_fraction: no estimate before this fraction of the total is done.
        min_updates: nor before this many updates (one block's rate is no rate).
        max_exponent: the largest speed-up extrapolated: time per unit ~ done^-max_exponent.
    """

    def __init__(self, min_fraction: float = 0.05, min_updates: int = 3, max_exponent: float = 0.5):
        self.min_fraction = min_fraction
        self.min_updates = min_updates
        self.max_exponent = max_exponent
        self.points: list[tuple[float, float]] = []  # (done, time [s]), done increasing

    def start(self, t: float) -> None:
        """Work starts at time ``t`` [s] (nothing done yet)."""
        self.points = [(0.0, float(t))]

    def add(self, done: float, t: float) -> None:
        """``done`` units of work are finished at time ``t`` [s]."""
        if not self.points:
            self.start(t)
        if done > self.points[-1][0]:
            self.points.append((float(done), float(t)))

    def remaining(self, total: float | None) -> float | None:
        """Seconds left until ``total`` is done, or None while there is too little to go on."""
        if not total or len(self.points) < self.min_updates + 1:
            return None
        done, t = self.points[-1]
        if done < self.min_fraction * total:
            return None
        if done >= total:
            return 0.0
        # time per unit over the last two "halvings" of the work done: [done/4, done/2], [done/2, done]
        quarter = self.latest_at(done / 4)
        half = self.latest_at(done / 2)
        if t <= half[1] or half[0] <= quarter[0]:
            return None
        tau = (t - half[1]) / (done - half[0])
        mid = (done + half[0]) / 2
        tau_before = (half[1] - quarter[1]) / (half[0] - quarter[0])
        # the time per unit falls like a power of the work done, done^-p; p is capped so that
        # noise cannot promise a speed-up the build will not have (no slowdown is extrapolated)
        p = math.log(tau_before / tau) / math.log(mid / ((half[0] + quarter[0]) / 2)) if tau > 0 else 0.0
        p = min(max(p, 0.0), self.max_exponent)
        return cast(float, tau * mid**p * (total ** (1 - p) - done ** (1 - p)) / (1 - p))  # (float ** float: Any)

    def latest_at(self, done: float) -> tuple[float, float]:
        """The latest (done, time) update with at most ``done`` units done."""
        return next(pt for pt in reversed(self.points) if pt[0] <= done)


class EtaBar(tqdm):  # type: ignore[misc]  # tqdm ships no type hints: it is Any to mypy
    """A tqdm bar whose ETA ("<?" until it can be estimated) comes from :class:`Eta`."""

    def __init__(self, *args: Any, eta: Eta | None = None, **kwargs: Any) -> None:
        kwargs.setdefault("bar_format", "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{eta}, {rate_fmt}{postfix}]")
        self.eta = eta or Eta()
        super().__init__(*args, **kwargs)
        self.eta.start(time.monotonic())

    def update(self, n: float = 1) -> bool | None:
        if not self.disable:  # recorded first: the update below redraws the bar
            self.eta.add(self.n + n, time.monotonic())
        return cast("bool | None", super().update(n))

    @property
    def format_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = super().format_dict
        left = self.eta.remaining(d.get("total"))
        d["eta"] = "?" if left is None else self.format_interval(left)
        return d


class Ticking:
    """Redraws ``bar`` (a tqdm bar) every ``interval`` seconds from a daemon thread while in the ``with``
    block, so that its elapsed time moves while one item takes long (a scene of ``placement evaluate``
    takes seconds to minutes; tqdm alone redraws only on an update, and a bar frozen at ``00:00`` reads
    as a hung command)."""

    def __init__(self, bar: tqdm, interval: float = 1.0) -> None:
        self.bar, self.interval = bar, interval
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="progress-ticker", daemon=True)

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            if not self.bar.disable:
                self.bar.refresh()

    def __enter__(self) -> tqdm:
        self._thread.start()
        return self.bar

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
