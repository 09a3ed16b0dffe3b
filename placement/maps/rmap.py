"""Opening, validating, saving and querying reachability maps."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from placement.errors import GridError, MapError, PlacementError
from placement.kernels.grid import cell_indices
from placement.kernels.irm import POLAR_ANGLES, column_maxima, farthest_reached, polar_bound, yaw_bits
from placement.maps.array_checks import check_arrays
from placement.maps.grid import Grid
from placement.maps.quantiles import estimate_quantiles, quantile_value
from placement.maps.torso import TorsoSettings, allowed_value, settings_from_meta
from placement.maps.witness import plain_samples, witness_configs
from placement.robots import Robot
from placement.storage import StoredMap
from placement.storage.chunks import each_of
from placement.storage.output import MapOutput, check_target, save_maps
from placement.storage.validate import TCP_TOLERANCE, check_root, validate_arm, validate_robot

__all__ = [
    "TCP_TOLERANCE",
    "MapOutput",
    "ReachabilityMap",
    "check_root",
    "check_target",
    "open_setting",
    "save_maps",
    "validate_arm",
    "validate_robot",
]


#: Rows of a polar bound per map cell width (see ReachabilityMap.polar_bound): finer rows blur a
#: value over less distance, at a larger table
POLAR_ROWS_PER_CELL = 4


class _Shared:
    """What an opened map and its views share: the arrays and chunks read so far and the value
    distribution (a shifted torso view shares them; a per-setting view has its own), and the views made
    (setting [m or rad] -> map, shared by every view of the opened map)."""

    def __init__(self, quantiles: dict[str, Any] | None, views: dict[float, ReachabilityMap] | None = None) -> None:
        self.full: np.ndarray | None = None
        self.full_witness: np.ndarray | None = None
        self.slices: dict[tuple[int, int, int], np.ndarray] = {}
        self.witness_slices: dict[tuple[int, int, int], np.ndarray] = {}
        #: (z bins, pitch bin, roll bin) -> the elementwise minimum of those slices (see ``lowest``)
        self.lowest: dict[tuple[tuple[int, ...], int, int], np.ndarray] = {}
        #: the same keys -> that slice's maximum over the yaw bins (see ``column_max``)
        self.column_max: dict[tuple[tuple[int, ...], int, int], np.ndarray] = {}
        #: (the same keys, a threshold) -> which yaw bins of each (x, y) cell lie above it (see ``yaw_bits``)
        self.yaw_bits: dict[tuple[tuple[tuple[int, ...], int, int], float], np.ndarray] = {}
        #: the slab of :meth:`ReachabilityMap.stacked` (rows of lowest slices, grown to the slices read
        #: or by doubling) and each key's row in it
        self.slab: np.ndarray | None = None
        self.slab_rows: dict[tuple[tuple[int, ...], int, int], int] = {}
        #: ((grid corner x, y [m]), the same keys) -> that slice's polar bound (see ``polar_bound``)
        self.polar: dict[tuple[tuple[float, float], tuple[tuple[int, ...], int, int]], np.ndarray] = {}
        self.quantiles = quantiles
        self.views: dict[float, ReachabilityMap] = {} if views is None else views


class ReachabilityMap:
    """One arm's map, opened lazily: slices are read on first use and cached.

    Attributes:
        path: where the map lives.
        arm: arm name.
        array: the stored array it reads: the arm's own, or for a per-setting torso view that setting's
            (``arm@joint=value``, see :mod:`placement.maps.torso_builds`).
        meta: the array's metadata (as stored).
        grid: the 6D :class:`Grid` this object answers on (a shifted torso view's: the stored grid moved
            with the lift).
        stored_grid: the grid as stored.
        robot: the :class:`Robot` it was validated against (None if opened without :func:`open_map`); a
            per-setting view's: that robot with the torso joint at the view's setting.
    """

    def __init__(
        self,
        store: StoredMap,
        arm: str,
        robot: Robot | None = None,
        *,
        torso_value: float | None = None,
        shared: _Shared | None = None,
        array: str | None = None,
        record: TorsoSettings | None = None,
        views: dict[float, ReachabilityMap] | None = None,
    ) -> None:
        """``torso_value``, ``shared`` (or ``views`` alone), ``array`` and ``record``: a view of
        :meth:`at_torso` (its setting [m or rad], what it shares, the array it reads, the opened map's
        torso record)."""
        self.store = store
        self.path = store.path
        self.arm = arm
        self.array = arm if array is None else array
        self.robot = robot
        self.meta = store.arm_meta(self.array)
        self.stored_grid = Grid.from_dict(self.meta["grid"])
        self.grid = self.stored_grid
        self._torso = settings_from_meta(self.meta) if record is None else record
        self._torso_value = None if self._torso is None else self._torso.reference
        if self._torso is not None and torso_value is not None:
            g = self.stored_grid
            ox, oy, oz = (float(x) for x in g.origin_array + self._torso.offset(torso_value))
            self.grid = Grid((ox, oy, oz), g.resolution, g.shape)
            self._torso_value = torso_value
        self._shared = _Shared(self.meta.get("value_quantiles"), views) if shared is None else shared
        if self._torso_value is not None:
            self._shared.views.setdefault(self._torso_value, self)
        self._slices = self._shared.slices
        self._witness_slices = self._shared.witness_slices
        self._reach: dict[tuple[int, int, int], float] = {}  # depends on the grid: one per view
        self._plain = plain_samples(self.meta)
        self._empty = int(self.meta["witness"]["empty"])
        self._seed = int(self.meta["seed"])

    def __repr__(self) -> str:
        lift = "" if self._torso is None else f", {self._torso.joint}={self._torso_value:g}"
        return f"ReachabilityMap({str(self.path)!r}, arm={self.arm!r}, shape={self.grid.shape}{lift})"

    @property
    def _full(self) -> np.ndarray | None:
        return self._shared.full

    @_full.setter
    def _full(self, values: np.ndarray | None) -> None:
        self._shared.full = values

    @property
    def _full_witness(self) -> np.ndarray | None:
        return self._shared.full_witness

    @_full_witness.setter
    def _full_witness(self, witness: np.ndarray | None) -> None:
        self._shared.full_witness = witness

    @property
    def torso(self) -> TorsoSettings | None:
        """The torso settings the map stands for (the opened map's ``torso`` record, shared by its views),
        or None: a map built without the build spec's ``torso`` key, for the preset's held value only."""
        return self._torso

    @property
    def torso_value(self) -> float | None:
        """The torso setting [m or rad] this object stands for: the reference (the preset's held value) for
        the opened map, the view's setting for a view of :meth:`at_torso`; None for a map without a record."""
        return self._torso_value

    def at_torso(self, value: float) -> ReachabilityMap:
        """This map with the torso at ``value`` [m or rad] (one of ``torso.values`` or the reference, else
        MapError naming them); ``self`` for its own setting. Views are kept: the same value gives the same
        object.

        A shifted map's view (a prismatic lift) reads the same store, arrays and chunk caches (nothing is
        read again), its grid origin moved by ``(value - reference) * torso.shift`` [m]; its ``robot``
        stays the reference robot, and its :meth:`witness_q` gives the arm joints [rad or m] whose TCP,
        with the lift at ``value`` (``robot.with_fixed({joint: value})``), lies in the pose's cell.

        A per-setting map's view (one build per setting) is that setting's own stored map, opened and
        checked now (its own grid, arrays, witnesses and value quantiles; MapError if it is missing or
        was not built for this arm at ``value``); its ``robot`` is ``robot.with_fixed({joint: value})``.
        A posture record's ``value`` is the posture's index and the view's ``robot`` is
        ``robot.with_fixed(torso.held(value))`` (every torso joint at the posture).
        """
        t = self._torso
        if t is None:
            raise MapError(
                f"{self.path}: the map of arm '{self.arm}' has no torso settings (stands for the preset's "
                "fixed joints only); build it with the build spec's torso key"
            )
        v = allowed_value(t, value, f"{self.path}: arm '{self.arm}'")
        if v == self._torso_value:
            return self
        if v not in self._shared.views:  # a new view registers itself there
            if t.shift is not None:
                ReachabilityMap(self.store, self.arm, self.robot, torso_value=v, shared=self._shared)
            else:
                opened = self._shared.views[t.reference]  # the map open_map gave: the preset's robot
                open_setting(opened.store, self.arm, opened.robot, t, v, self._shared.views)
        return self._shared.views[v]

    def join(self, views: dict[float, ReachabilityMap]) -> None:
        """Make ``views`` (a map's views by torso value) this view's, and register it there (a setting's
        map joins its arm's once it has been checked)."""
        self._shared.views = views
        if self._torso_value is not None:
            views[self._torso_value] = self

    @property
    def in_memory(self) -> bool:
        """Whether the whole values array has been read (:meth:`load`)."""
        return self._full is not None

    def load(self) -> ReachabilityMap:
        """Read the whole array into memory (faster for many scattered queries)."""
        if self._full is None:
            self._full = self.store.read_all(self.array)
        return self

    @property
    def values(self) -> npt.NDArray[np.float32]:
        """The whole 6D float32 array (x, y, z, yaw, pitch, roll), read on first use."""
        if self._full is None:
            self._full = self.store.read_all(self.array)
        return self._full

    @property
    def witness(self) -> np.ndarray:
        """The whole 6D witness array (uint32 or int64, see :mod:`placement.maps.witness`), read on first use."""
        if self._full_witness is None:
            self._full_witness = self.store.read_all(self.array, witness=True)
        return self._full_witness

    def witness_slice(self, iz: int, ip: int, ir: int) -> np.ndarray:
        """Witnesses (nx, ny, n_yaw) at z bin iz, pitch bin ip, roll bin ir (one stored chunk)."""
        return self._chunk(self._full_witness, self._witness_slices, (iz, ip, ir), True)

    def _chunk(
        self,
        full: np.ndarray | None,
        cache: dict[tuple[int, int, int], np.ndarray],
        key: tuple[int, int, int],
        witness: bool,
    ) -> np.ndarray:
        """Chunk ``key`` = (iz, ip, ir) of the values or witnesses: from the whole array if read, else
        read once and cached."""
        if full is not None:
            return full[:, :, key[0], :, key[1], key[2]]
        key = (int(key[0]), int(key[1]), int(key[2]))
        s = cache.get(key)
        if s is None:
            s = cache[key] = self.store.read_chunk(self.array, *key, witness=witness)
        return s

    def witness_q(self, pose_base: npt.ArrayLike) -> npt.NDArray[np.float64] | None:
        """The witness configuration of the cell holding a TCP pose, or None if that cell is empty or outside.

        Args:
            pose_base: (4, 4) TCP pose in the arm's base frame [m].

        Returns:
            (n,) joint values [rad or m] of the sample that set the cell's value (its FK lies in
            the same cell), regenerated from the stored sample number; a few microseconds once the
            cell's chunk is cached (the first use of a chunk reads it, ~1 ms).
        """
        T = np.ascontiguousarray(pose_base, dtype=float)
        if T.shape != (4, 4):
            raise PlacementError(f"pose must have shape (4, 4), got {T.shape}")
        if self.robot is None:
            raise PlacementError("witness_q needs the robot: open the map with placement.open_map")
        g = self.grid
        flat = int(cell_indices(T.reshape(1, 4, 4), g.origin_array, g.resolution, g.shape_array)[0])
        if flat < 0:
            return None
        sx, sy, sz, s_yaw, sp, sr = g.shape
        rest, ir = divmod(flat, sr)
        rest, ip = divmod(rest, sp)
        rest, iyaw = divmod(rest, s_yaw)
        rest, iz = divmod(rest, sz)
        ix, iy = divmod(rest, sy)
        w = int(self.witness_slice(iz, ip, ir)[ix, iy, iyaw])
        if w == self._empty:
            return None
        # the witness stands for joints sampled on the stored grid (a view only moves where they land)
        return cast(
            "npt.NDArray[np.float64]",
            witness_configs(self.robot.arm(self.arm), self.stored_grid, self._seed, self._plain, np.array([w]))[0],
        )

    def read_slices(self, keys: Iterable[tuple[int, int, int]], witness: bool = False) -> None:
        """Read the slices (or witness slices) at ``keys`` (iz, ip, ir) not read yet, on the chunk
        threads (the codecs release the GIL: a step's hundreds of slices in about half the time): what
        :meth:`slice` (:meth:`witness_slice`) of each reads and caches, any damaged chunk's MapError
        raised here."""
        if (self._full_witness if witness else self._full) is not None:
            return
        cache = self._witness_slices if witness else self._slices
        todo = sorted({(int(iz), int(ip), int(ir)) for iz, ip, ir in keys}.difference(cache))

        def read(key: tuple[int, int, int]) -> None:
            cache[key] = self.store.read_chunk(self.array, *key, witness=witness)

        if len(todo) > 1:
            each_of(read, todo)
        elif todo:
            read(todo[0])

    def slice(self, iz: int, ip: int, ir: int) -> np.ndarray:
        """Values (nx, ny, n_yaw) at z bin iz, pitch bin ip, roll bin ir (one stored chunk)."""
        return self._chunk(self._full, self._slices, (iz, ip, ir), False)

    def lowest(self, zs: Sequence[int], ip: int, ir: int) -> np.ndarray:
        """(nx, ny, n_yaw) the elementwise minimum of the slices at z bins ``zs`` (pitch bin ip, roll
        bin ir): what poses stacked above each other with the same yaw, pitch and roll read, in one
        slice (cached; read-only; one z bin: that slice)."""
        key = (tuple(sorted({int(z) for z in zs})), int(ip), int(ir))
        if len(key[0]) == 1:
            return self.slice(key[0][0], key[1], key[2])
        hit = self._shared.lowest.get(key)
        if hit is None:
            hit = self.slice(key[0][0], key[1], key[2]).copy()
            for z in key[0][1:]:
                np.minimum(hit, self.slice(z, key[1], key[2]), out=hit)
            hit.flags.writeable = False
            self._shared.lowest[key] = hit
        return hit

    def stacked(self, keys: Sequence[tuple[Sequence[int], int, int]]) -> tuple[np.ndarray, np.ndarray]:
        """(slab (R, nx, ny, n_yaw) float32, rows (len(keys),) int64): :meth:`lowest` of each key
        ``(zs, ip, ir)`` is ``slab[rows[k]]``. The slab keeps every slice stacked so far, each copied in
        once: a kernel pass reads its slices from it instead of a stack of its own (tens of MB per
        step, copied anew for every pass). Rows are only ever added: a slab given out stays valid
        while a larger one replaces it (a kernel running in the background keeps reading the old)."""
        shared = self._shared
        out = np.empty(len(keys), dtype=np.int64)
        new: dict[tuple[tuple[int, ...], int, int], int] = {}  # key -> its row, in order
        first = len(shared.slab_rows)
        for k, (zs, ip, ir) in enumerate(keys):
            key = (tuple(sorted({int(z) for z in zs})), int(ip), int(ir))
            row = shared.slab_rows.get(key)
            if row is None:
                row = new.setdefault(key, first + len(new))
            out[k] = row
        if new:
            rows = [self.lowest(*key) for key in new]
            slab = shared.slab
            if slab is None or slab.shape[0] < first + len(new):
                need = first + len(new)
                # as many rows as slices were read (a planner reads its task's slices when it is built)
                # and a quarter more for merged ones, at least twice the rows: growing copies every
                # row again (rows not written are pages never touched)
                rows_for = max(2 * need, len(shared.slices) + len(shared.slices) // 4)
                grown = np.empty((max(16, rows_for), *rows[0].shape), dtype=np.float32)
                if slab is not None:
                    grown[:first] = slab[:first]
                slab = shared.slab = grown
            for k, (key, values) in enumerate(zip(new, rows)):
                slab[first + k] = values
                shared.slab_rows[key] = first + k
        assert shared.slab is not None or not len(keys)
        return (shared.slab if shared.slab is not None else np.zeros((0, 0, 0, 0), np.float32)), out

    def column_max(self, zs: Sequence[int], ip: int, ir: int) -> np.ndarray:
        """(nx, ny) float32: the maximum over the yaw bins of :meth:`lowest` ``(zs, ip, ir)`` (cached;
        read-only): a bound the inverse-map kernel skips base yaws with."""
        key = (tuple(sorted({int(z) for z in zs})), int(ip), int(ir))
        hit = self._shared.column_max.get(key)
        if hit is None:
            hit = column_maxima(self.lowest(*key))
            hit.flags.writeable = False
            self._shared.column_max[key] = hit
        return hit

    def yaw_bits(self, zs: Sequence[int], ip: int, ir: int, above: float) -> np.ndarray:
        """(nx, ny) uint64: bit b of a cell set when yaw bin b of :meth:`lowest` ``(zs, ip, ir)`` holds a
        value above ``above`` (float32 comparison; a map of at most 64 yaw bins); cached, read-only: what
        a threshold pass of the inverse-map kernel reads."""
        key = ((tuple(sorted({int(z) for z in zs})), int(ip), int(ir)), float(above))
        hit = self._shared.yaw_bits.get(key)
        if hit is None:
            hit = yaw_bits(self.lowest(*key[0]), float(above))
            hit.flags.writeable = False
            self._shared.yaw_bits[key] = hit
        return hit

    @property
    def polar_rows_per_m(self) -> float:
        """Rows per metre of :meth:`polar_bound`'s tables: four per map cell."""
        return POLAR_ROWS_PER_CELL / float(self.grid.resolution)

    def polar_bound(self, zs: Sequence[int], ip: int, ir: int, lowest: np.ndarray | None = None) -> np.ndarray:
        """(R, :data:`~placement.kernels.irm.POLAR_ANGLES`) float32: the polar bound of :meth:`lowest`
        ``(zs, ip, ir)`` (:func:`~placement.kernels.irm.polar_bound`, :attr:`polar_rows_per_m` rows per
        metre: a pose's most by its distance from the base and its yaw less its bearing); cached,
        read-only. A view whose grid corner moved in x or y has its own. ``lowest``: that slice, when
        the caller has it (a kernel pass in the background thread reads it from the slab it was given,
        and reads no chunk)."""
        g = self.grid
        corner = (float(g.origin[0]), float(g.origin[1]))
        key = (corner, (tuple(sorted({int(z) for z in zs})), int(ip), int(ir)))
        hit = self._shared.polar.get(key)
        if hit is None:
            res = float(g.resolution)
            values = self.lowest(*key[1]) if lowest is None else lowest
            hit = polar_bound(values, corner[0], corner[1], res, self.polar_rows_per_m, POLAR_ANGLES)
            hit.flags.writeable = False
            self._shared.polar[key] = hit
        return hit

    def slice_reach(self, iz: int, ip: int, ir: int) -> float:
        """Largest horizontal distance [m] from the base origin to any point of a reached cell of
        slice (iz, ip, ir), over every yaw bin; -1 if the slice is empty. A TCP pose of this slice
        farther than that from the base is unreachable at every base yaw."""
        key = (int(iz), int(ip), int(ir))
        r = self._reach.get(key)
        if r is None:
            g = self.grid
            r = farthest_reached(self.slice(*key), float(g.origin[0]), float(g.origin[1]), float(g.resolution))
            self._reach[key] = r
        return r

    def value(self, T: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Map values of TCP poses T (4, 4) or (N, 4, 4) in the base frame -> (N,); 0 = unreachable."""
        T = np.ascontiguousarray(T, dtype=float)
        if T.shape[-2:] != (4, 4):
            raise PlacementError(f"poses must have shape (4, 4) or (N, 4, 4), got {T.shape}")
        T = T.reshape(-1, 4, 4)
        g = self.grid
        flat = g.index(T)
        out = np.zeros(len(flat), dtype=np.float64)
        ok = flat >= 0
        if not ok.any():
            return out
        idx = np.unravel_index(flat[ok], g.shape)
        if self._full is None and len(flat) > 2000:
            self.load()
        if self._full is not None:
            out[ok] = self._full[idx]
            return out
        pos = np.flatnonzero(ok)
        for k in range(len(pos)):
            ix, iy, iz, iyaw, ip, ir = (int(a[k]) for a in idx)
            out[pos[k]] = self.slice(iz, ip, ir)[ix, iy, iyaw]
        return out

    @property
    def value_quantiles(self) -> dict[str, Any]:
        """The distribution of the arm's non-zero values (see :mod:`placement.maps.quantiles`): the
        metadata's ``value_quantiles``, or for a map built without it an estimate from every 8th
        chunk, computed on first use (about 1.3 s for a 5 cm PR2 arm) and kept."""
        if self._shared.quantiles is None:
            self._shared.quantiles = estimate_quantiles(self.store, self.array, self.grid.shape)
        return self._shared.quantiles

    def quantile_value(self, q: float) -> float:
        """The map value at quantile ``q`` (0 .. 1) of the arm's non-zero values (dimensionless)."""
        return quantile_value(self.value_quantiles, q, f"{self.path}: arm '{self.arm}'")

    @property
    def rank(self) -> int:
        """The dimension r of the subspace the values measure (``measure.rank``; 6 for maps without it):
        each octant's r largest singular values count (see :mod:`placement.kernels.subspace`)."""
        return int(self.meta["measure"].get("rank", 6))

    def verify(self) -> None:
        """Read every chunk and compare it with its stored CRC32 (MapError if any is damaged)."""
        self.store.read_all(self.array)


def open_setting(
    store: StoredMap,
    arm: str,
    robot: Robot | None,
    record: TorsoSettings,
    value: float,
    views: dict[float, ReachabilityMap],
) -> ReachabilityMap:
    """The stored map of ``arm`` at setting ``value`` [m or rad; a posture's index] of a per-setting or
    posture torso ``record``, checked: the array is there, its metadata says it was built for this arm
    with the joint at ``value`` (every joint at the posture's values) and the preset's other fixed joints, and (given ``robot``) it matches the arm like :func:`open_map`'s checks.
    It registers itself in ``views``."""
    path, name, unit = store.path, record.array(arm, value), record.unit
    at = record.describe(value) if record.joints else f"{record.joint} = {value:g} {unit}"
    where = f"{path}: the map of arm '{arm}' at {at} (array '{name}')"
    if name not in (store.root.get("arms") or []):
        raise MapError(f"{where} is missing; rebuild the map")
    held = None if robot is None else robot.with_fixed(record.held(value))
    try:  # with views of its own until checked
        rmap = ReachabilityMap(store, arm, held, torso_value=value, array=name, record=record, views={})
    except GridError as exc:
        raise MapError(f"{where}: {exc} (corrupt); rebuild the map") from None
    setting = rmap.meta.get("setting") or {}
    posture = {k: float(x) for k, x in (setting.get("posture") or {}).items()}
    if (
        setting.get("joint") != record.joint
        or abs(float(setting.get("value", float("nan"))) - value) > 1e-9
        or (record.joints and posture != record.held(value))
    ):
        raise MapError(f"{where} was built for setting {setting} (corrupt); rebuild the map")
    if held is not None:
        built = {k: float(v) for k, v in (rmap.meta.get("fixed_joints") or {}).items()}
        if built != held.fixed_joints:
            raise MapError(
                f"{where} was built with fixed joints {rmap.meta.get('fixed_joints')}, not {held.fixed_joints}; "
                "rebuild the map"
            )
        validate_arm(path, rmap.meta, held, arm)
        check_arrays(rmap, held)
    rmap.join(views)
    return rmap
