"""Manipulation cost maps (paper section IV-B) from reachability maps, without 6D inversion."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from placement.errors import PlacementError
from placement.kernels.grid import pose_bins, zyx_angles
from placement.kernels.irm import trajectory_maps
from placement.maps.grid import Grid
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import YAW_INDEX, Float32Array, FloatArray, IntArray, MaskArray, YawIndexArray
from placement.planning.problems.background import behind
from placement.scene.navgrid import NavGrid, Window

#: (group, base cell) pairs per map slice from which a kernel pass reads the slices' polar bounds: each
#: table takes about as long to make as the kernel spends on this many pairs' unreachable share
POLAR_PAYS = 2400
#: A pose's map lookup: (x [m], y [m], z bin, pitch bin, roll bin).
PoseKey = tuple[float, float, int, int, int]
#: An inverse reachability map over a window: value (h, w) float32, best yaw's index (h, w) int64.
IRM = tuple[Float32Array, YawIndexArray]


def base_yaws(count: int) -> FloatArray:
    """``count`` base yaws [rad] evenly over [-pi, pi), starting at 0 (aligned with the yaw bins
    whenever ``count`` is a multiple of the map's yaw bin count)."""
    if count < 1:
        raise PlacementError(f"yaw count must be positive, got {count}")
    a = np.arange(count) * (2 * math.pi / count)
    out: FloatArray = np.where(a >= math.pi, a - 2 * math.pi, a)
    return out


def manipulation_map(
    rmap: ReachabilityMap,
    tcp_world: FloatArray,
    nav: NavGrid,
    yaws: FloatArray,
    cells: IntArray | None = None,
    window: Window | None = None,
    masks: MaskArray | None = None,
) -> IRM:
    """IRM of a TCP trajectory: per base cell, the best yaw's worst map value along the trajectory.

    Args:
        rmap: the arm's reachability map (base frame on the floor).
        tcp_world: (P, 4, 4) TCP poses in the world frame (z up, floor at z = 0).
        nav: the navigation grid of base positions.
        yaws: (K,) base yaws to try [rad] (see :func:`base_yaws`).
        cells: optional (N,) flat base-cell indices to evaluate (default: those within the map's
            horizontal reach of the first pose).
        window: optional part of the grid to return (it must hold every cell of ``cells``);
            default the whole grid.
        masks: optional (N, W) uint64 packed base yaws allowed per cell (see
            ``World.yaw_masks``); default every yaw (needs ``cells``).
    Returns:
        value (h, w) float32 (0 = unreachable), yaw_index (h, w) int16 into ``yaws`` (-1), over
        ``window`` ((ny, nx) by default).
    """
    T = np.asarray(tcp_world, dtype=float).reshape(-1, 4, 4)
    if cells is None:
        cells = cells_within(nav, T[0, 0, 3], T[0, 1, 3], reach_xy(rmap.grid))
    return manipulation_maps(rmap, [T], nav, yaws, cells, window, masks)[0]


def _bins(rmap: ReachabilityMap, T: FloatArray) -> tuple[IntArray, FloatArray]:
    """:func:`~placement.kernels.grid.pose_bins` of the poses T (n, 4, 4) in ``rmap``'s grid."""
    g: Grid = rmap.grid
    T = np.ascontiguousarray(T, dtype=np.float64).reshape(-1, 4, 4)
    return pose_bins(T, float(g.origin[2]), float(g.resolution), int(g.shape[2]), int(g.shape[4]), int(g.shape[5]))


def _keyed(T: FloatArray, bins: IntArray, yaws: FloatArray) -> tuple[tuple[PoseKey, ...], list[float]] | None:
    """Per pose of T (P, 4, 4), from its :func:`_bins` and yaws [rad]: (x [m], y [m], z bin, pitch bin,
    roll bin), and the yaws; None if a pose is outside the map's height range."""
    if bins.size and bins[:, 0].min() < 0:
        return None
    xy = T[:, :2, 3].tolist()
    keys = tuple((x, y, iz, ip, ir) for (x, y), (iz, ip, ir) in zip(xy, bins.tolist()))
    return keys, yaws.tolist()


def pose_slices(rmap: ReachabilityMap, T: FloatArray) -> list[tuple[int, int, int]]:
    """The (z, pitch, roll) bins of the map slices the poses T (P, 4, 4) read, in order, of those in
    the map's height range (fewer than P when some pose is not)."""
    bins, _ = _bins(rmap, np.asarray(T, dtype=float).reshape(-1, 4, 4))
    return [(iz, ip, ir) for iz, ip, ir in bins[bins[:, 0] >= 0].tolist()]


def distinct_slices(rmap: ReachabilityMap, T: FloatArray) -> list[tuple[int, int, int]]:
    """The distinct (z, pitch, roll) bins of the map slices the poses T (P, 4, 4) in the map's height
    range read, ascending (a step's hundreds of candidates share a few dozen)."""
    bins, _ = _bins(rmap, np.asarray(T, dtype=float).reshape(-1, 4, 4))
    n_pitch, n_roll = int(rmap.grid.shape[4]), int(rmap.grid.shape[5])
    code = np.unique((bins[:, 0] * n_pitch + bins[:, 1]) * n_roll + bins[:, 2] if bins.size else bins[:, 0])
    code = code[code >= 0]  # a pose below or above the map's heights has z bin -1
    iz, rest = np.divmod(code, n_pitch * n_roll)
    ip, ir = np.divmod(rest, n_roll)
    return list(zip(iz.tolist(), ip.tolist(), ir.tolist()))


def manipulation_maps(
    rmap: ReachabilityMap,
    trajectories: Sequence[FloatArray],
    nav: NavGrid,
    yaws: FloatArray,
    cells: IntArray,
    window: Window | None = None,
    masks: MaskArray | None = None,
) -> list[IRM]:
    """:func:`manipulation_map` of several trajectories over the same ``cells``, ``window`` and ``masks``.

    Trajectories whose poses share positions and map slices (they differ only in the gripper's
    yaw, like a step's grasp or place candidates) are evaluated in one pass, and poses stacked above
    each other read one merged slice (:func:`_stacked`); each result is the same as its own
    evaluation. Returns (value, yaw_index) per trajectory, in order.
    """
    window = window or Window(0, nav.shape[0], 0, nav.shape[1])
    cells, masks = _checked(nav, yaws, cells, window, masks)
    vals, args, _, call = _kernel_pass(rmap, trajectories, nav, yaws, cells, window, masks, within_reach=False)
    if call is not None:
        call()
    return [(vals[i], args[i]) for i in range(len(trajectories))]


def reach_maps(
    rmap: ReachabilityMap,
    trajectories: Sequence[FloatArray],
    nav: NavGrid,
    yaws: FloatArray,
    cells: IntArray,
    masks: MaskArray,
    at_least: float | None = None,
    background: bool = False,
) -> Callable[[], list[tuple[Window, Float32Array, YawIndexArray]]]:
    """:func:`manipulation_maps` of a step's trajectories over ``cells`` (those within the arm's reach
    of any of them) and their yaw ``masks``, each kept over its own window: the cells within the
    horizontal reach of its last pose's slice (:func:`pose_reach`) of that pose, plus one cell. Cells
    farther away read nothing from the map (0 everywhere) and are not evaluated. One kernel pass for
    all of them, started here (in the background thread when ``background``, see :mod:`.background`).
    Returns the function that waits for the pass and gives (window, value, yaw_index) per trajectory,
    in order.

    ``at_least`` (dimensionless): where the best value is at least that, some value at least that and
    its yaw (the first found, not the best), else 0 and -1: the cells a threshold keeps, without the
    best of each (a fraction of the work; ``value >= at_least`` is the same as with the best values)."""
    window = Window.around(cells, nav.shape)
    cells, masks = _checked(nav, yaws, cells, window, masks)
    above = 0.0 if at_least is None else float(below(at_least))
    vals, args, discs, call = _kernel_pass(
        rmap,
        trajectories,
        nav,
        yaws,
        cells,
        window,
        masks,
        within_reach=True,
        above=above,
        stop_early=at_least is not None,
    )
    wait = behind(call, background) if call is not None else None

    def maps() -> list[tuple[Window, Float32Array, YawIndexArray]]:
        if wait is not None:
            wait()
        out = []
        for i, (x, y, r) in enumerate(discs):
            own = _disc_window(nav, x, y, r, window)
            sub = (slice(own.y0 - window.y0, own.y1 - window.y0), slice(own.x0 - window.x0, own.x1 - window.x0))
            out.append((own, vals[i][sub].copy(), args[i][sub].copy()))
        return out

    return maps


def _disc_window(nav: NavGrid, x: float, y: float, r: float, within: Window) -> Window:
    """The cells of ``within`` whose centres may lie within ``r`` [m] of (x, y), plus one cell (empty
    for a negative ``r``)."""
    if r < 0:
        return Window(within.y0, within.y0, within.x0, within.x0)
    res, (ox, oy) = nav.resolution, nav.origin
    y0 = max(int(math.floor((y - r - oy) / res)) - 2, within.y0)
    y1 = min(int(math.ceil((y + r - oy) / res)) + 2, within.y1)
    x0 = max(int(math.floor((x - r - ox) / res)) - 2, within.x0)
    x1 = min(int(math.ceil((x + r - ox) / res)) + 2, within.x1)
    return Window(y0, max(y1, y0), x0, max(x1, x0))


def _checked(
    nav: NavGrid, yaws: FloatArray, cells: IntArray, window: Window, masks: MaskArray | None
) -> tuple[IntArray, MaskArray]:
    """``cells`` as int64 (all inside ``window``) and their ``masks`` (default: every yaw), checked."""
    cells = np.asarray(cells, dtype=np.int64)
    if cells.size and not window.holds(cells, nav.shape[1]):
        raise PlacementError("manipulation_map: a cell to evaluate lies outside the window")
    if masks is None:
        masks = np.full((len(cells), (len(yaws) + 63) // 64), np.iinfo(np.uint64).max, np.uint64)
    masks = np.ascontiguousarray(masks, dtype=np.uint64)
    if masks.shape != (len(cells), (len(yaws) + 63) // 64):
        raise PlacementError(
            f"manipulation_map: yaw masks {masks.shape} do not fit {len(cells)} cells and {len(yaws)} yaws"
        )
    return cells, masks


def _kernel_pass(
    rmap: ReachabilityMap,
    trajectories: Sequence[FloatArray],
    nav: NavGrid,
    yaws: FloatArray,
    cells: IntArray,
    window: Window,
    masks: MaskArray,
    within_reach: bool,
    above: float = 0.0,
    stop_early: bool = False,
) -> tuple[Float32Array, YawIndexArray, list[tuple[float, float, float]], Callable[[], None] | None]:
    """(values (T, h, w), yaw indices (T, h, w), per trajectory its disc (x, y, r [m]), the kernel call
    that fills the first two or None when there is nothing to evaluate) of the trajectories over
    ``window``, in one kernel pass; ``within_reach``: each evaluated only on the cells within its last
    pose's reach (its disc; r = -1 for a trajectory off the map's heights, inf without); ``above``,
    ``stop_early``: as :func:`~placement.kernels.irm.trajectory_maps` takes ``above`` and ``first``."""
    g: Grid = rmap.grid
    vals = np.zeros((len(trajectories), *window.shape), np.float32)
    args = np.full((len(trajectories), *window.shape), -1, YAW_INDEX)
    discs: list[tuple[float, float, float]] = []
    groups: dict[tuple[PoseKey, ...], list[tuple[int, list[float]]]] = {}
    Ts = [np.asarray(T, dtype=float).reshape(-1, 4, 4) for T in trajectories]
    ends = np.cumsum([len(T) for T in Ts])
    # every pose's bins in one call (a step has hundreds of candidates)
    bins, pose_yaws = _bins(rmap, np.concatenate(Ts)) if Ts else (np.zeros((0, 3), np.int64), np.zeros(0))
    reaches = _reaches(rmap, bins[ends - 1]) if within_reach else [math.inf] * len(Ts)
    for i, T in enumerate(Ts):
        at = slice(ends[i] - len(T), ends[i])
        keyed = _keyed(T, bins[at], pose_yaws[at])
        last, reach = T[-1], reaches[i]
        discs.append((float(last[0, 3]), float(last[1, 3]), reach if keyed is not None else -1.0))
        if keyed is not None and reach >= 0:
            groups.setdefault(keyed[0], []).append((i, keyed[1]))
    if not groups or not cells.size:
        return vals, args, discs, None
    slices: list[tuple[tuple[int, ...], int, int]] = []  # (z bins, pitch bin, roll bin) per slice
    # a threshold pass reads which yaw bins lie above the threshold, 1 bit each (at most 64 bins)
    by_bits = stop_early and g.shape[3] <= 64
    bits: list[np.ndarray] = []
    bounds: list[np.ndarray] = []
    index: dict[tuple[tuple[int, ...], int, int], int] = {}
    bound_index: dict[tuple[tuple[int, ...], int, int], int] = {}
    pose_slice: list[int] = []
    pose_x: list[float] = []
    pose_y: list[float] = []
    member_yaw: list[float] = []
    group_pose, group_member, group_column, rows = [0], [0], [], []
    group_disc: list[tuple[float, float, float]] = []
    for keys, members in groups.items():
        yaws_of = [m[1] for m in members]
        stacked = _stacked(keys, yaws_of)
        for x, y, zs, ip, ir, _ in stacked:
            key = (tuple(sorted(set(zs))), ip, ir)
            if key not in index:
                index[key] = len(slices)
                slices.append(key)
                if by_bits:
                    bits.append(rmap.yaw_bits(zs, ip, ir, above))
            pose_slice.append(index[key])
            pose_x.append(x)
            pose_y.append(y)
        first = (tuple(sorted(set(stacked[0][2]))), stacked[0][3], stacked[0][4])
        if first not in bound_index:
            bound_index[first] = len(bounds)
            bounds.append(rmap.column_max(*first))
        group_column.append(bound_index[first])
        for i, ys in members:
            member_yaw.extend(ys[k[5]] for k in stacked)
            rows.append(i)
        group_pose.append(len(pose_slice))
        group_member.append(len(rows))
        group_disc.append(discs[members[0][0]])
    slab, slice_row = rmap.stacked(slices)  # a step's candidates share a few dozen slices
    polar = len(groups) * cells.size >= POLAR_PAYS * len(slices)
    head = (slab, slice_row, np.ascontiguousarray(np.stack(bits)) if bits else np.zeros((0, 0, 0), np.uint64))
    kernel_args = (  # after the polar bounds, made where the kernel runs (below)
        rmap.polar_rows_per_m,
        np.ascontiguousarray(np.stack(bounds)),
        np.array(pose_slice, dtype=np.int64),
        np.array(pose_x, dtype=float),
        np.array(pose_y, dtype=float),
        np.array(group_pose, dtype=np.int64),
        np.array(group_member, dtype=np.int64),
        np.array(rows, dtype=np.int64),
        np.array(member_yaw, dtype=float),
        np.array(group_column, dtype=np.int64),
        np.array(group_disc, dtype=float).reshape(-1, 3),
        np.array(g.origin[:2]),
        g.resolution,
        np.asarray(yaws, dtype=float),
        np.array(nav.origin, dtype=float),
        nav.resolution,
        nav.shape[1],
        cells,
        masks,
        vals,
        args,
        window.y0,
        window.x0,
        above,
        stop_early,
    )

    def call() -> None:
        tables = np.zeros((0, 0, 0), np.float32)
        if polar:  # made where they are missing (the planner makes its steps' tables when it is built)
            tables = np.stack([rmap.polar_bound(*key, lowest=slab[row]) for key, row in zip(slices, slice_row)])
        trajectory_maps(*(*head, tables, *kernel_args))

    return vals, args, discs, call


def below(value: float) -> np.float32:
    """The largest float32 below ``value``: a float32 map value v is at least ``value`` (compared as
    numpy compares a float32 array with a float) exactly when v is above it."""
    f = np.float32(value)
    return np.nextafter(f, np.float32(-np.inf)) if float(f) >= value else f


#: Poses merged by :func:`_stacked`: (x [m], y [m], z bins, pitch bin, roll bin, index of the first pose).
Stacked = tuple[float, float, tuple[int, ...], int, int, int]


def _stacked(keys: tuple[PoseKey, ...], yaws: Sequence[list[float]]) -> list[Stacked]:
    """The trajectory's poses merged where they read the same map row: poses at the same (x, y) with
    the same pitch and roll bins and, in every trajectory of ``yaws`` (C lists of P yaws [rad]), the
    same yaw differ only in their z bin (a pre-grasp above its grasp), so at every base pose they read
    the same row of their slices. Their minimum is then read once from the slices' elementwise
    minimum (``ReachabilityMap.lowest``): the same value, half the lookups. In the order of each
    merged pose's first pose."""
    out: dict[tuple[float, float, int, int, tuple[float, ...]], tuple[list[int], int]] = {}
    for j, (x, y, iz, ip, ir) in enumerate(keys):
        out.setdefault((x, y, ip, ir, tuple(t[j] for t in yaws)), ([], j))[0].append(iz)
    return [(x, y, tuple(zs), ip, ir, j) for (x, y, ip, ir, _), (zs, j) in out.items()]


def pose_reach(rmap: ReachabilityMap, pose: FloatArray) -> float:
    """Largest distance [m] between a base position and the TCP ``pose`` (4, 4, world frame) at which
    the map holds any value for the pose's slice (see ``ReachabilityMap.slice_reach``); -1 if none
    (the slice is empty, or the pose is outside the map's height range)."""
    return pose_reaches(rmap, np.asarray(pose, dtype=float).reshape(1, 4, 4))[0]


def pose_reaches(rmap: ReachabilityMap, poses: FloatArray) -> list[float]:
    """:func:`pose_reach` of each of the poses (n, 4, 4)."""
    return _reaches(rmap, _bins(rmap, poses)[0])


def _reaches(rmap: ReachabilityMap, bins: IntArray) -> list[float]:
    """:func:`pose_reach` of poses from their :func:`_bins`."""
    out = []
    for iz, ip, ir in bins.tolist():
        r = -1.0 if iz < 0 else rmap.slice_reach(iz, ip, ir)
        out.append(r + 1e-6 if r >= 0 else r)  # a micrometre of slack against rounding in the distance test
    return out


def reach_xy(g: Grid) -> float:
    """Largest horizontal distance [m] from the base origin to any map cell."""
    x0, y0 = g.origin[0], g.origin[1]
    x1, y1 = x0 + g.shape[0] * g.resolution, y0 + g.shape[1] * g.resolution
    return max(math.hypot(x, y) for x in (x0, x1) for y in (y0, y1))


def cells_within(nav: NavGrid, x: float, y: float, radius: float) -> IntArray:
    """Flat indices (ascending) of navigation cells whose centre is within ``radius`` [m] of (x, y)
    (none for a negative radius)."""
    if radius < 0:
        return np.zeros(0, np.int64)
    xs, ys = nav.centres()
    # only the bounding box of the disc is tested (plus a cell: the comparison below decides)
    x0 = max(int(math.floor((x - radius - nav.origin[0]) / nav.resolution)) - 1, 0)
    x1 = min(int(math.ceil((x + radius - nav.origin[0]) / nav.resolution)) + 2, nav.shape[1])
    y0 = max(int(math.floor((y - radius - nav.origin[1]) / nav.resolution)) - 1, 0)
    y1 = min(int(math.ceil((y + radius - nav.origin[1]) / nav.resolution)) + 2, nav.shape[0])
    if x0 >= x1 or y0 >= y1:
        return np.zeros(0, np.int64)
    mask = (xs[None, x0:x1] - x) ** 2 + (ys[y0:y1, None] - y) ** 2 <= radius * radius
    iy, ix = np.nonzero(mask)
    return (iy + y0) * nav.shape[1] + ix + x0


def yaw_values(
    rmap: ReachabilityMap, poses: FloatArray, bx: FloatArray, by: FloatArray, yaws: FloatArray
) -> Float32Array:
    """(N, K) map value of the trajectory ``poses`` (P, 4, 4) (its minimum over the poses) for base
    positions (bx, by) (N,) [m] at each of the base ``yaws`` (K,) [rad]: the arithmetic of the IRM
    kernel, for every yaw instead of the best one (0 where a pose is off the map)."""
    g = rmap.grid
    keys = pose_slices(rmap, poses)
    out = np.full((bx.size, yaws.size), np.inf, np.float32)
    if len(keys) < len(poses):
        return np.zeros_like(out)
    cs, sn = np.cos(yaws)[None], np.sin(yaws)[None]
    n_yaw = g.shape[3]
    for pose, key in zip(poses, keys):
        sl = rmap.slice(*key)
        dx, dy = pose[0, 3] - bx[:, None], pose[1, 3] - by[:, None]
        jx = np.floor((cs * dx + sn * dy - g.origin[0]) / g.resolution).astype(np.int64)
        jy = np.floor((-sn * dx + cs * dy - g.origin[1]) / g.resolution).astype(np.int64)
        tcp_yaw = zyx_angles(pose)[0]
        jb = np.mod(np.floor((tcp_yaw - yaws) * (n_yaw / (2 * math.pi)) + 0.5).astype(np.int64), n_yaw)
        inside = (jx >= 0) & (jy >= 0) & (jx < sl.shape[0]) & (jy < sl.shape[1])
        v = np.zeros(out.shape, np.float32)
        v[inside] = sl[jx[inside], jy[inside], np.broadcast_to(jb[None], jx.shape)[inside]]
        np.minimum(out, v, out=out)
    return out
