"""Base feasibility per yaw for polygon footprints (configuration-space obstacles per base yaw).

The occupancy the round base uses marks cells by their centre, which can hide the part of an
obstacle that lies in a cell whose centre is outside it (a thin wall may mark no cell at all).
A polygon base is tested against the *touched* layer instead: every cell whose square an obstacle
reaches into (interiors overlap), so the touched squares cover every obstacle, and a footprint
that keeps ``padding`` [m] from every touched square keeps it from the obstacles themselves.

With d the distance from a cell centre to the nearest touched cell centre [m], h half a cell
diagonal, r_in and r_out the footprint's inscribed and circumscribed radii [m] and p the padding:
d > r_out + p + h means every yaw is clear, d < r_in + p that none is; only the band between
needs per-yaw tests (``kernels/footprint.band_masks``), stored as packed bits per band cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from placement.errors import PlacementError
from placement.kernels.footprint import band_masks, block_table, pose_blocked
from placement.planning.arrays import BoolArray, FloatArray, IntArray, MaskArray
from placement.robots import Robot
from placement.robots.footprint import inscribed_radius
from placement.scene.navgrid import NavGrid

EPS = 1e-9  # [m] float slack of the band limits, always on the safe side
PAD_SLACK = 1e-6  # [m] added to the padding: covers the squares' float shrink (world.SHRINK)


@dataclass(frozen=True)
class BaseShape:
    """The base as the planner tests it: ``radius`` [m] (round base, or the polygon's circumscribed
    radius), ``polygon`` (k, 2) [m] counter-clockwise in the base frame or None (round), ``padding``
    [m] kept from obstacles by a polygon, ``yaws`` (K,) the planner's base yaws [rad]."""

    radius: float
    polygon: FloatArray | None
    padding: float
    yaws: FloatArray

    @classmethod
    def of(cls, robot: Robot, padding: float, yaws: FloatArray) -> BaseShape:
        poly = None if robot.footprint is None else np.ascontiguousarray(robot.footprint, dtype=float)
        return cls(float(robot.footprint_radius), poly, float(padding), np.asarray(yaws, dtype=float))

    @property
    def clearance(self) -> float:
        """[m] the least distance from the base origin to an obstacle at which the base can fit at some
        yaw: the inscribed radius plus padding (a polygon), the radius (a round base)."""
        if self.polygon is None:
            return self.radius
        return inscribed_radius(self.outline()) + self.padding

    @property
    def words(self) -> int:
        """uint64 words per yaw mask."""
        return (len(self.yaws) + 63) // 64

    def full_mask(self) -> MaskArray:
        """(W,) uint64 with the bits of every yaw set (one array per shape: callers copy, never write)."""
        return self._full

    @cached_property
    def _full(self) -> MaskArray:
        out = np.zeros(self.words, np.uint64)
        for k in range(len(self.yaws)):
            out[k >> 6] |= np.uint64(1) << np.uint64(k & 63)
        return out

    def outline(self) -> FloatArray:
        """(k, 2) the polygon [m] (PlacementError for a round base, which has none)."""
        if self.polygon is None:
            raise PlacementError("a round base has no footprint polygon")
        return self.polygon

    def half_depth(self) -> float:
        """How far the footprint reaches ahead of the base origin along its forward axis [m] (the
        radius for a round base)."""
        return self.radius if self.polygon is None else float(self.polygon[:, 0].max())

    def placed(self, x: float, y: float, yaw: float) -> FloatArray:
        """(k, 2) polygon in world coordinates [m] for a base at (x, y) [m] with ``yaw`` [rad]
        (a polygon base only)."""
        c, s = math.cos(yaw), math.sin(yaw)
        p = self.outline()
        return np.ascontiguousarray(np.c_[x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1]])


@dataclass(frozen=True)
class YawMasks:
    """Allowed base yaws of the band cells: ``cells`` (M,) ascending flat indices, ``bits`` (M, W)
    uint64; cells outside the band allow every yaw when feasible, none otherwise."""

    cells: IntArray
    bits: MaskArray


#: (band limits lo, hi [m], offsets dy, dx (L,) [cells], blocked yaws (L, W)) of a footprint on a grid
Offsets = tuple[float, float, IntArray, IntArray, MaskArray]
_OFFSETS: dict[tuple[bytes, bytes, float, float], Offsets] = {}


def _offsets(base: BaseShape, res: float) -> Offsets:
    """The band limits lo, hi [m] and the offsets (L,), (L,) [cells] with the yaws (L, W) an occupied
    cell there blocks, of ``base`` on a grid of ``res`` [m]; computed once per shape and grid (the
    table takes tens of ms, an obstacle update must not pay for it again)."""
    polygon = base.outline()
    key = (polygon.tobytes(), base.yaws.tobytes(), base.padding, res)
    got = _OFFSETS.get(key)
    if got is None:
        lo = inscribed_radius(polygon) + base.padding - EPS
        hi = base.radius + base.padding + PAD_SLACK + res * math.sqrt(0.5) + EPS
        reach = int(math.ceil(hi / res))
        table = block_table(polygon, base.yaws, base.padding + PAD_SLACK, res, reach)
        dy, dx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
        # band cells have no touched cell closer than lo: those offsets are never read
        use = table.any(axis=2) & (np.hypot(dy, dx) * res >= lo)
        got = (lo, hi, dy[use].astype(np.int64), dx[use].astype(np.int64), np.ascontiguousarray(table[use]))
        if len(_OFFSETS) >= 16:
            _OFFSETS.clear()
        _OFFSETS[key] = got
    return got


def polygon_feasibility(
    base: BaseShape,
    touched: BoolArray,
    touched_distance: FloatArray,
    res: float,
    previous: tuple[BoolArray, YawMasks] | None = None,
) -> tuple[BoolArray, YawMasks]:
    """(ny, nx) bool feasible at some yaw, and the band's yaw masks, of a polygon base over the
    ``touched`` layer (ny, nx) with its ``touched_distance`` [m] (cell centres) on a grid of ``res`` [m].

    ``previous``: (touched layer, masks) of the same grid before an obstacle change: a band cell's
    mask depends only on the touched cells within the offsets' reach, so band cells farther than that
    from every changed cell keep their old masks and only the rest are tested again (the same
    result as testing every band cell: tests/test_footprints.py)."""
    lo, hi, off_y, off_x, off_bits = _offsets(base, float(res))
    band = np.flatnonzero((touched_distance >= lo) & (touched_distance <= hi))
    full = base.full_mask()
    todo = np.ones(band.size, dtype=bool)
    bits = np.empty((band.size, base.words), np.uint64)
    if previous is not None and previous[0].shape == touched.shape:
        old_touched, old = previous
        cy, cx = np.nonzero(old_touched != touched)
        if cy.size == 0:
            todo[:] = False
        else:
            reach = int(max(np.abs(off_y).max(initial=0), np.abs(off_x).max(initial=0)))
            iy, ix = np.divmod(band, touched.shape[1])
            todo = (
                (iy >= cy.min() - reach)
                & (iy <= cy.max() + reach)
                & (ix >= cx.min() - reach)
                & (ix <= cx.max() + reach)
            )
        keep = np.flatnonzero(~todo)
        if keep.size:
            pos = np.minimum(np.searchsorted(old.cells, band[keep]), max(len(old.cells) - 1, 0))
            hit = old.cells[pos] == band[keep] if len(old.cells) else np.zeros(keep.size, bool)
            bits[keep[hit]] = old.bits[pos[hit]]
            todo[keep[~hit]] = True  # (cannot happen: such a cell is a band cell before and after)
    bits[todo] = band_masks(np.ascontiguousarray(touched), band[todo], off_y, off_x, off_bits, full)
    feasible = touched_distance > hi
    feasible.flat[band] = bits.any(axis=1)
    return feasible, YawMasks(band, bits)


def masks_at(base: BaseShape, feasible: BoolArray, masks: YawMasks | None, cells: IntArray) -> MaskArray:
    """(N, W) uint64 allowed-yaw masks of flat ``cells`` (N,): every yaw on feasible cells, none on
    the others, the band's own masks on band cells."""
    cells = np.asarray(cells, dtype=np.int64)
    out = np.zeros((len(cells), base.words), np.uint64)
    out[feasible.flat[cells]] = base.full_mask()
    if masks is not None and len(masks.cells) and len(cells):
        pos = np.minimum(np.searchsorted(masks.cells, cells), len(masks.cells) - 1)
        hit = masks.cells[pos] == cells
        out[hit] = masks.bits[pos[hit]]
    return out


def pose_clear(base: BaseShape, touched: BoolArray, nav: NavGrid, x: float, y: float, yaw: float) -> bool:
    """Whether a polygon base at (x, y) [m] with ``yaw`` [rad] keeps its padding from every touched square."""
    return not pose_blocked(
        touched,
        float(nav.origin[0]),
        float(nav.origin[1]),
        float(nav.resolution),
        base.placed(x, y, yaw),
        base.padding + PAD_SLACK,
    )
