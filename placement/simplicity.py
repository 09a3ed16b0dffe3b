"""Is a polygon simple? An O(n log n) sweep line (Shamos and Hoey) with exact predicates.

Used for robot footprints and scene obstacle polygons. A polygon (k, 2), k >= 3, closed from its
last vertex back to its first, is simple when no two edges meet except adjacent edges at their
shared vertex; a vertex visited twice, an edge touching another, collinear edges that overlap and a
spike (an edge running straight back over the one before it) all make it not simple. Consecutive
repeated points are the caller's to refuse (a zero-length edge has no direction).

The orientation test is exact: a floating-point determinant with Shewchuk's error bound, and when
the bound cannot tell the sign, the same determinant in exact rationals. So nearly collinear
neighbours (a 100,000-vertex circle, whose consecutive edges turn by 6e-5 rad) are never taken for
touching, and touching edges are never missed. The sweep visits the vertices in (x, y) order and
keeps the edges that cross the sweep line in a list sorted from below to above; when two edges
meet, two of them are neighbours in that list at some event before the sweep passes the leftmost
meeting point (the classic argument, which holds for closed segments when, at one point, edges
that start there are inserted before the edges that end there are removed).
"""

from __future__ import annotations

import bisect
from fractions import Fraction

import numpy as np
import numpy.typing as npt

#: Shewchuk's ccwerrboundA: |det| above this times (|detleft| + |detright|) has the right sign.
_ERRBOUND = (3.0 + 16.0 * 2.0**-53) * 2.0**-53
#: Below this magnitude products may be subnormal and the bound does not hold: decide exactly.
_TINY = 1e-280

#: A vertex (x, y).
Point = tuple[float, float]


def orient(a: Point, b: Point, c: Point) -> int:
    """Sign of the turn a -> b -> c: 1 left (counter-clockwise), -1 right, 0 collinear; exact."""
    if c == a or c == b or a == b:
        return 0
    ax, ay = a
    detl = (b[0] - ax) * (c[1] - ay)
    detr = (b[1] - ay) * (c[0] - ax)
    det = detl - detr
    detsum = abs(detl) + abs(detr)
    if detsum > _TINY:
        bound = _ERRBOUND * detsum
        if det > bound:
            return 1
        if -det > bound:
            return -1
    fa = (Fraction(ax), Fraction(ay))
    e = (Fraction(b[0]) - fa[0]) * (Fraction(c[1]) - fa[1]) - (Fraction(b[1]) - fa[1]) * (Fraction(c[0]) - fa[0])
    return (e > 0) - (e < 0)


def segments_meet(p1: Point, p2: Point, q1: Point, q2: Point) -> bool:
    """Whether the closed segments p1p2 and q1q2 share a point (exact; points as (x, y) tuples)."""
    o1, o2 = orient(p1, p2, q1), orient(p1, p2, q2)
    if o1 == o2 != 0:
        return False
    o3, o4 = orient(q1, q2, p1), orient(q1, q2, p2)
    if o3 == o4 != 0:
        return False
    if o1 == o2 == 0:  # on one line: do the intervals along it overlap? (x, y) order is the line's order
        return max(min(p1, p2), min(q1, q2)) <= min(max(p1, p2), max(q1, q2))
    return True


def spike(prev: Point, v: Point, nxt: Point) -> bool:
    """Whether the edges prev-v and v-nxt (adjacent at v) overlap beyond v: collinear, nxt back towards prev."""
    return orient(prev, v, nxt) == 0 and (prev > v) == (nxt > v)


def edges_meet(pts: list[Point], i: int, j: int) -> bool:
    """Whether edges i and j (edge i runs from vertex i to vertex i + 1) of the closed polygon ``pts``
    meet other than adjacent edges at their shared vertex."""
    k = len(pts)
    if i == j:
        return False
    if (i + 1) % k == j:
        return spike(pts[i], pts[j], pts[(j + 1) % k])
    if (j + 1) % k == i:
        return spike(pts[j], pts[i], pts[(i + 1) % k])
    return segments_meet(pts[i], pts[(i + 1) % k], pts[j], pts[(j + 1) % k])


class _Edge:
    """An edge in the sweep's list: ordered from below to above where the sweep line crosses it."""

    __slots__ = ("i", "left", "right", "ylo", "yhi")

    def __init__(self, i: int, a: Point, b: Point) -> None:
        self.i = i
        self.left, self.right = (a, b) if a <= b else (b, a)
        self.ylo, self.yhi = (a[1], b[1]) if a[1] <= b[1] else (b[1], a[1])

    def __lt__(self, other: _Edge) -> bool:
        """Whether this edge lies below ``other`` (both cross the sweep line, and have not crossed yet)."""
        if self is other:
            return False
        if self.left >= other.left:  # compare at this edge's left end, which lies within other's span
            o = orient(other.left, other.right, self.left) or orient(other.left, other.right, self.right)
            return self.i < other.i if o == 0 else o < 0
        o = orient(self.left, self.right, other.left) or orient(self.left, self.right, other.right)
        return self.i < other.i if o == 0 else o > 0


def self_crossing(points: npt.ArrayLike) -> tuple[int, int] | None:
    """A pair of edges (i, j), i < j, of the closed polygon ``points`` (k, 2) that meet (edge i runs
    from vertex i to vertex i + 1), or None when the polygon is simple. O(k log k) for a simple
    polygon. Points must be finite; consecutive points must differ (not checked)."""
    pts = [(float(x), float(y)) for x, y in np.asarray(points, dtype=float).reshape(-1, 2)]
    k = len(pts)
    if k < 3:
        return None
    edges = [_Edge(i, pts[i], pts[(i + 1) % k]) for i in range(k)]
    events: list[tuple[Point, int, int]] = []  # (point, 0 = insert before 1 = remove, edge index)
    for e in edges:
        events.append((e.left, 0, e.i))
        events.append((e.right, 1, e.i))
    events.sort()
    active: list[_Edge] = []

    def check(a: _Edge | None, b: _Edge | None) -> tuple[int, int] | None:
        # both cross the sweep line, so their x ranges overlap: edges whose y ranges do not cannot meet
        if a is None or b is None or a.yhi < b.ylo or b.yhi < a.ylo:
            return None
        if edges_meet(pts, a.i, b.i):
            return (min(a.i, b.i), max(a.i, b.i))
        return None

    for _, kind, i in events:
        e = edges[i]
        if kind == 0:
            at = bisect.bisect_left(active, e)
            active.insert(at, e)
            found = check(active[at - 1] if at else None, e) or check(
                e, active[at + 1] if at + 1 < len(active) else None
            )
        else:
            at = bisect.bisect_left(active, e)
            if at >= len(active) or active[at] is not e:  # the order broke: only edges that meet do that
                at = active.index(e)
            del active[at]
            found = check(active[at - 1] if at else None, active[at] if at < len(active) else None)
        if found:
            return found
    return None
