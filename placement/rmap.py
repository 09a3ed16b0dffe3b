"""Opening, validating, saving and querying reachability maps."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .build import FORMAT_VERSION, BuiltMap
from .errors import MapError, PlacementError
from .grid import Grid
from .robots import Robot, load_robot
from .storage import atomic_replace, backend, checksum, detect, open_store


class ReachabilityMap:
    """One arm's map, opened lazily: slices are read on first use and cached.

    Attributes:
        path: where the map lives; arm: arm name; meta: the arm's metadata;
        grid: the 6D :class:`Grid`.
    """

    def __init__(self, store, arm: str):
        self.store = store
        self.path = store.path
        self.arm = arm
        self.meta = store.arm_meta(arm)
        self.grid = Grid.from_dict(self.meta["grid"])
        self._slices: dict[tuple[int, int, int], np.ndarray] = {}
        self._full: np.ndarray | None = None

    def __repr__(self) -> str:
        return f"ReachabilityMap({str(self.path)!r}, arm={self.arm!r}, shape={self.grid.shape})"

    def load(self) -> ReachabilityMap:
        """Read the whole array into memory (faster for many scattered queries)."""
        if self._full is None:
            self._full = self.store.read_all(self.arm)
        return self

    @property
    def values(self) -> np.ndarray:
        """The whole 6D float32 array (x, y, z, yaw, pitch, roll), read on first use."""
        return self.load()._full

    def slice(self, iz: int, ip: int, ir: int) -> np.ndarray:
        """Values (nx, ny, n_yaw) at z bin iz, pitch bin ip, roll bin ir (one stored chunk)."""
        if self._full is not None:
            return self._full[:, :, iz, :, ip, ir]
        key = (int(iz), int(ip), int(ir))
        s = self._slices.get(key)
        if s is None:
            s = self._slices[key] = self.store.read_chunk(self.arm, *key)
        return s

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
        """Read everything and compare with the stored checksum (MapError if corrupt)."""
        data = self.store.read_all(self.arm)
        want = self.meta.get("checksum")
        if want and checksum(data) != want:
            raise MapError(f"{self.path}: data of arm '{self.arm}' does not match its checksum (corrupt)")


def _check_root(path: Path, root: dict) -> None:
    if not root:
        raise MapError(f"{path}: not a reachability map (no '{'placement_map'}' metadata)")
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


def open_map(path: str | Path, arm: str, robot: Robot | str | None = None) -> ReachabilityMap:
    """Open the map of ``arm`` at ``path`` (Zarr directory or HDF5 file), lazily.

    The map is validated against ``robot`` (a :class:`Robot` or preset name/path);
    by default against the preset recorded in the map. Raises :class:`MapError`
    for a missing, half-written, corrupt, foreign or outdated map.
    """
    path = Path(path)
    store = open_store(path)
    root = store.root
    _check_root(path, root)
    if robot is None:
        robot = root.get("preset") or root.get("robot")
    if not isinstance(robot, Robot):
        robot = load_robot(robot)
    validate_robot(path, root, robot)
    arms = list(root.get("arms") or [])
    if arm not in arms:
        raise MapError(f"{path}: no map for arm '{arm}'; it has: {', '.join(arms) or 'none'}")
    rmap = ReachabilityMap(store, arm)
    want = rmap.meta.get("stored_chunks")
    have = store.chunks_present(arm)
    if want is not None and have is not None and have != want:
        raise MapError(f"{path}: arm '{arm}' has {have} of {want} data chunks (half-written or corrupt)")
    if tuple(rmap.meta["grid"]["shape"]) != rmap.grid.shape or rmap.meta.get("arm") != arm:
        raise MapError(f"{path}: metadata of arm '{arm}' is inconsistent (corrupt)")
    return rmap


def save_maps(path: str | Path, robot: Robot, maps: dict[str, BuiltMap], fmt: str = "zarr") -> Path:
    """Write ``maps`` (arm -> BuiltMap) to ``path`` atomically.

    Arms already in an existing map of the same robot at ``path`` are kept; a
    path that holds something else is never overwritten (MapError).
    """
    path = Path(path)
    be = backend(fmt)
    arms = {arm: (m.values, {**m.meta, "checksum": checksum(m.values)}) for arm, m in maps.items()}
    if path.exists():
        try:
            existing = detect(path)
        except MapError:
            raise MapError(f"{path} exists and is not a map; refusing to overwrite it") from None
        if existing.name != be.name:
            raise MapError(f"{path} is a {existing.name} map; refusing to replace it with {fmt}")
        old = open_store(path)
        try:
            if old.root.get("complete"):
                validate_robot(path, old.root, robot)
                for arm in old.root.get("arms", []):
                    if arm not in arms:
                        arms[arm] = (old.read_all(arm), old.arm_meta(arm))
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
