"""Opening, validating, saving and querying reachability maps."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .errors import MapError, PlacementError
from .grid import Grid
from .kernels.grid import cell_indices
from .robots import Robot, load_robot
from .storage import atomic_replace, backend, detect, open_store
from .storage.format import CRC_KEY, FORMAT_VERSION, ROOT_KEY, WITNESS_CRC_KEY, BuiltMap, chunk_crcs, witness_name
from .witness import empty_value, plain_samples, witness_configs

# stored and preset TCP offsets (4, 4) [m, dimensionless rotation] agree to this
TCP_TOLERANCE = 1e-9


class ReachabilityMap:
    """One arm's map, opened lazily: slices are read on first use and cached.

    Attributes:
        path: where the map lives; arm: arm name; meta: the arm's metadata;
        grid: the 6D :class:`Grid`; robot: the :class:`Robot` it was validated
        against (None if opened without :func:`open_map`).
    """

    def __init__(self, store, arm: str, robot: Robot | None = None):
        self.store = store
        self.path = store.path
        self.arm = arm
        self.robot = robot
        self.meta = store.arm_meta(arm)
        self.grid = Grid.from_dict(self.meta["grid"])
        self._slices: dict[tuple[int, int, int], np.ndarray] = {}
        self._witness_slices: dict[tuple[int, int, int], np.ndarray] = {}
        self._reach: dict[tuple[int, int, int], float] = {}
        self._full: np.ndarray | None = None
        self._full_witness: np.ndarray | None = None
        self._plain = plain_samples(self.meta)
        self._empty = int(self.meta["witness"]["empty"])
        self._seed = int(self.meta["seed"])

    def __repr__(self) -> str:
        return f"ReachabilityMap({str(self.path)!r}, arm={self.arm!r}, shape={self.grid.shape})"

    @property
    def in_memory(self) -> bool:
        """Whether the whole values array has been read (:meth:`load`)."""
        return self._full is not None

    def load(self) -> ReachabilityMap:
        """Read the whole array into memory (faster for many scattered queries)."""
        if self._full is None:
            self._full = self.store.read_all(self.arm)
        return self

    @property
    def values(self) -> np.ndarray:
        """The whole 6D float32 array (x, y, z, yaw, pitch, roll), read on first use."""
        self.load()
        return self._full

    @property
    def witness(self) -> np.ndarray:
        """The whole 6D witness array (uint32 or int64, see :mod:`placement.witness`), read on first use."""
        if self._full_witness is None:
            self._full_witness = self.store.read_all(self.arm, witness=True)
        return self._full_witness

    def witness_slice(self, iz: int, ip: int, ir: int) -> np.ndarray:
        """Witnesses (nx, ny, n_yaw) at z bin iz, pitch bin ip, roll bin ir (one stored chunk)."""
        return self._chunk(self._full_witness, self._witness_slices, (iz, ip, ir), True)

    def _chunk(self, full: np.ndarray | None, cache: dict, key: tuple, witness: bool) -> np.ndarray:
        """Chunk ``key`` = (iz, ip, ir) of the values or witnesses: from the whole array if read, else
        read once and cached."""
        if full is not None:
            return full[:, :, key[0], :, key[1], key[2]]
        key = (int(key[0]), int(key[1]), int(key[2]))
        s = cache.get(key)
        if s is None:
            s = cache[key] = self.store.read_chunk(self.arm, *key, witness=witness)
        return s

    def witness_q(self, pose_base) -> np.ndarray | None:
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
        return witness_configs(self.robot.arm(self.arm), g, self._seed, self._plain, np.array([w]))[0]

    def slice(self, iz: int, ip: int, ir: int) -> np.ndarray:
        """Values (nx, ny, n_yaw) at z bin iz, pitch bin ip, roll bin ir (one stored chunk)."""
        return self._chunk(self._full, self._slices, (iz, ip, ir), False)

    def slice_reach(self, iz: int, ip: int, ir: int) -> float:
        """Largest horizontal distance [m] from the base origin to any point of a reached cell of
        slice (iz, ip, ir), over every yaw bin; -1 if the slice is empty. A TCP pose of this slice
        farther than that from the base is unreachable at every base yaw."""
        key = (int(iz), int(ip), int(ir))
        r = self._reach.get(key)
        if r is None:
            hit = np.nonzero(self.slice(*key).any(axis=2))
            if hit[0].size == 0:
                r = -1.0
            else:
                g = self.grid
                # the farthest corner of each reached cell
                xs = g.origin[0] + g.resolution * np.stack([hit[0], hit[0] + 1])
                ys = g.origin[1] + g.resolution * np.stack([hit[1], hit[1] + 1])
                r = float(np.sqrt(np.max(np.abs(xs), axis=0) ** 2 + np.max(np.abs(ys), axis=0) ** 2).max())
            self._reach[key] = r
        return r

    def value(self, T) -> np.ndarray:
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

    def verify(self) -> None:
        """Read every chunk and compare it with its stored CRC32 (MapError if any is damaged)."""
        self.store.read_all(self.arm)


def check_root(path: Path, root: dict) -> None:
    """MapError unless ``root`` is the metadata of a complete map of this format version."""
    if not root:
        raise MapError(f"{path}: not a reachability map (no '{ROOT_KEY}' metadata)")
    if not root.get("complete"):
        raise MapError(f"{path}: map is half-written (an interrupted build); rebuild it")
    if root.get("format_version") != FORMAT_VERSION:
        raise MapError(f"{path}: map format version {root.get('format_version')} is not supported "
                       f"(this software reads version {FORMAT_VERSION}); rebuild it")


def validate_robot(path: Path, root: dict, robot: Robot) -> None:
    """MapError if the map at ``path`` was not built for ``robot`` as it is now."""
    if root.get("robot") != robot.name:
        raise MapError(f"{path}: map was built for robot '{root.get('robot')}', not '{robot.name}'")
    if root.get("urdf_sha256") != robot.urdf_sha256:
        raise MapError(f"{path}: map was built from another URDF of '{robot.name}' (hash differs); rebuild it")
    if root.get("base_frame") != robot.base_frame:
        raise MapError(f"{path}: map base frame '{root.get('base_frame')}' differs from the robot's "
                       f"'{robot.base_frame}'")
    if {k: float(v) for k, v in (root.get("fixed_joints") or {}).items()} != robot.fixed_joints:
        raise MapError(f"{path}: map was built with fixed joints {root.get('fixed_joints')}, the robot "
                       f"holds {robot.fixed_joints}")


def validate_arm(path: Path, meta: dict, robot: Robot, arm: str) -> None:
    """MapError if the map of ``arm`` was built for other arm joints, tip frame or TCP offset than ``robot``'s."""
    a = robot.arm(arm)
    if meta.get("joints") != list(a.joints):
        _differs(path, arm, "joints", meta.get("joints"), list(a.joints))
    if meta.get("tip_frame") != a.tip_frame:
        _differs(path, arm, "tip frame", meta.get("tip_frame"), a.tip_frame)
    try:
        tcp = np.asarray(meta.get("tcp_offset"), dtype=float)
        same = tcp.shape == (4, 4) and bool(np.all(np.abs(tcp - a.tcp_offset) <= TCP_TOLERANCE))
    except (TypeError, ValueError):
        same = False
    if not same:
        _differs(path, arm, "TCP offset (4x4)", meta.get("tcp_offset"), a.tcp_offset)


def _differs(path: Path, arm: str, field: str, stored, preset) -> None:
    def show(v):
        return np.round(np.asarray(v, dtype=float), 6).tolist() if isinstance(v, np.ndarray) else v

    raise MapError(f"{path}: the map of arm '{arm}' was built for {field} {show(stored)}, the preset has "
                   f"{show(preset)}; rebuild the map")


def open_map(path: str | Path, arm: str, robot: Robot | str | None = None) -> ReachabilityMap:
    """Open the map of ``arm`` at ``path`` (Zarr directory or HDF5 file), lazily.

    The map is validated against ``robot`` (a :class:`Robot` or preset name/path);
    by default against the preset recorded in the map. Checked here: the
    metadata is complete, the format version, robot name, URDF hash, base frame
    and fixed joints, the arm's joints (names, order, count), tip frame and TCP
    offset (to 1e-9), the chunk checksum table and (Zarr) the stored chunk count.
    Every later read checks each chunk's CRC32. Raises :class:`MapError` for a
    missing, half-written, corrupt, foreign or outdated map.
    """
    path = Path(path)
    store = open_store(path)
    root = store.root
    check_root(path, root)
    if robot is None:
        robot = root.get("preset") or root.get("robot")
    if not isinstance(robot, Robot):
        robot = load_robot(robot)
    validate_robot(path, root, robot)
    arms = list(root.get("arms") or [])
    if arm not in arms:
        raise MapError(f"{path}: no map for arm '{arm}'; it has: {', '.join(arms) or 'none'}")
    try:
        rmap = ReachabilityMap(store, arm, robot)
        consistent = tuple(rmap.meta["grid"]["shape"]) == rmap.grid.shape and rmap.meta.get("arm") == arm
        consistent &= rmap.meta["witness"]["empty"] == empty_value(rmap.meta["witness"]["dtype"])
    except (KeyError, TypeError, ValueError, MapError):
        consistent = False
    if not consistent:
        raise MapError(f"{path}: metadata of arm '{arm}' is inconsistent (corrupt); rebuild the map")
    validate_arm(path, rmap.meta, robot, arm)
    store.expected_crcs(arm)
    store.expected_crcs(arm, witness=True)
    for name, key in ((arm, "stored_chunks"), (witness_name(arm), "stored_witness_chunks")):
        want = rmap.meta.get(key)
        have = store.chunks_present(name)
        if want is not None and have is not None and have != want:
            raise MapError(f"{path}: arm '{arm}' has {have} of {want} {'witness' if name != arm else 'data'} "
                           f"chunks (half-written or corrupt); rebuild the map")
    return rmap


def check_target(path: str | Path, robot: Robot, fmt: str, what: str = "") -> None:
    """Fail now, before a build, if the map could not be saved to ``path`` (``what`` names the option).

    The nearest existing ancestor must be a writable directory; an existing
    ``path`` must be a map of the same format whose root metadata matches ``robot``.
    """
    path = Path(path)
    name = f"{what} {path}" if what else str(path)
    be = backend(fmt)
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise MapError(f"{name}: {parent} is a file, not a directory")
    if not _writable(parent):
        raise MapError(f"{name}: directory {parent} is not writable")
    if not path.exists():
        return
    try:
        existing = detect(path)
    except MapError:
        raise MapError(f"{name} exists and is not a map; refusing to overwrite it") from None
    if existing.name != be.name:
        raise MapError(f"{name} is a {existing.name} map; refusing to replace it with {fmt}")
    old = existing.open(path)
    try:
        if old.root.get("complete"):
            validate_robot(path, old.root, robot)
    finally:
        old.close()


def _writable(directory: Path) -> bool:
    """Whether a map can be created in ``directory``: tried with an empty probe directory, removed at once.

    access() alone says yes to root on read-only mounts and pseudo file systems (/proc).
    """
    if not os.access(directory, os.W_OK | os.X_OK):
        return False
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".placement-probe-", dir=directory))
    except OSError:
        return False
    return True


def save_maps(path: str | Path, robot: Robot, maps: dict[str, BuiltMap], fmt: str = "zarr") -> Path:
    """Write ``maps`` (arm -> BuiltMap) to ``path`` atomically, with the CRC32 of every chunk.

    Arms already in an existing complete map of the same robot and format
    version at ``path`` are kept (and checked as they are read); a path that
    holds something else is never overwritten (MapError).
    """
    path = Path(path)
    be = backend(fmt)
    check_target(path, robot, fmt)
    for arm, m in maps.items():
        if m.witness is None or m.witness.shape != m.values.shape:
            raise MapError(f"{path}: the map of arm '{arm}' has no witnesses of its shape; only a map from "
                           f"placement.build_map can be saved")
    arms = {arm: (m.values, {**m.meta, CRC_KEY: chunk_crcs(m.values).tolist(),
                             WITNESS_CRC_KEY: chunk_crcs(m.witness).tolist()}, m.witness) for arm, m in maps.items()}
    if path.exists():
        old = open_store(path)
        try:
            if old.root.get("complete") and old.root.get("format_version") == FORMAT_VERSION:
                for arm in old.root.get("arms", []):
                    if arm not in arms:
                        arms[arm] = (old.read_all(arm), old.arm_meta(arm), old.read_all(arm, witness=True))
        finally:
            old.close()
    root = {"format_version": FORMAT_VERSION, "preset": robot.source if not _builtin(robot) else robot.name,
            **robot.fingerprint, "arms": sorted(arms)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_replace(be, path, root, arms)
    return path


def _builtin(robot: Robot) -> bool:
    from .robots.preset import PRESET_DIR
    return Path(robot.source).parent == PRESET_DIR
