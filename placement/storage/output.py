"""Saving maps: the output proven writable and reserved before any work, merged and swapped in under a lock.

A build opens a :class:`MapOutput` before it samples: the target is checked (a map of the same
robot and format, or nothing), the partial path the map will be written to is created and removed
(so a folder that cannot take the map fails now, not after the sampling), and every arm the build
writes is reserved with a lock file beside the map, so a second build of one of those arms into the
same map fails at once, naming the first. Saving then takes the map's save lock, reads the map as it
is now (arms another build saved meanwhile included), merges and swaps the result in atomically:
concurrent builds of different arms both end complete, and no arm is ever lost.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from placement.errors import MapError
from placement.storage import backend, detect, open_store
from placement.storage.base import ArmArrays, atomic_replace, clear_leftovers, partial_path
from placement.storage.format import CRC_KEY, FORMAT_VERSION, READABLE_VERSIONS, WITNESS_CRC_KEY, BuiltMap, chunk_crcs
from placement.storage.lock import FileLock, lock_path
from placement.storage.stats import STATS_KEY, array_stats
from placement.storage.validate import base_frame_definition, validate_robot

if TYPE_CHECKING:
    import numpy as np

    from placement.robots.preset import Robot

log = logging.getLogger("placement")

#: how long a save waits for another build's save into the same map to finish [s]
SAVE_WAIT_S = 1800.0


def followed(path: str | Path) -> Path:
    """Where a map at ``path`` is written: ``path``, or where it points when it is a symbolic link
    (followed to the end, also when that does not exist yet), so that a save replaces the real map
    and leaves the link as it was."""
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def shown(path: str | Path, what: str = "") -> str:
    """``path`` as a message names it: the user's path (with ``what``, the option), and where it leads
    when it is a symbolic link."""
    p = Path(path)
    name = f"{what} {p}" if what else str(p)
    return f"{name} (a link to {followed(p)})" if p.is_symlink() else name


def check_target(path: str | Path, robot: Robot, fmt: str, what: str = "", name: str | None = None) -> None:
    """Fail now, before a build, if the map could not be saved to ``path`` (``what`` names the option;
    ``name``, when given, is how messages name the path).

    The nearest existing ancestor must be a writable directory; an existing
    ``path`` must be a map of the same format whose root metadata matches ``robot``.
    """
    path = followed(path)
    name = name or (f"{what} {path}" if what else str(path))
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


def _arm_lock(path: Path, arm: str) -> Path:
    tag = arm if re.fullmatch(r"[A-Za-z0-9_-]{1,64}", arm) else hashlib.sha256(arm.encode()).hexdigest()[:16]
    return lock_path(path, f"arm-{tag}")


class MapOutput:
    """The output of a build of ``arms`` into ``path`` (see the module); a context manager.

    Entering checks the target, proves the folder writable and reserves the arms; :meth:`save`
    writes; leaving releases the reservations (and removes nothing but what it created).
    """

    def __init__(self, path: str | Path, robot: Robot, fmt: str, arms: Iterable[str], what: str = "") -> None:
        self.path = followed(path)  # a link is followed: the real map is replaced, the link kept
        self.robot = robot
        self.fmt = fmt
        self.arms = list(arms)
        self.what = what
        self.name = shown(path, what)
        self.locks: list[FileLock] = []

    def __enter__(self) -> MapOutput:
        if not self.arms:
            raise MapError(f"{self.name}: no arm to save")
        check_target(self.path, self.robot, self.fmt, self.what, self.name)
        self._check_kept()
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            for arm in self.arms:
                lock = FileLock(
                    _arm_lock(self.path, arm), f"a build of arm '{arm}' into {self.path} (pid {os.getpid()})"
                )
                try:
                    self.locks.append(lock.acquire())
                except MapError as exc:
                    raise MapError(
                        f"{self.name}: arm '{arm}' is being written by another build ({exc}); wait for "
                        f"it to finish or choose another output"
                    ) from None
            self._probe()
        except OSError as exc:
            self.__exit__()
            raise MapError(f"{self.name}: cannot write there ({exc.strerror or exc})") from None
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        for lock in reversed(self.locks):
            lock.release()
        self.locks = []

    def _probe(self) -> None:
        """Create (and remove) the partial path the map will be written to: its folder, name and permissions."""
        probe = partial_path(self.path)
        if probe.is_dir() and not probe.is_symlink():
            shutil.rmtree(probe)  # left by a dead process of our pid; atomic_replace would remove it too
        elif probe.exists() or probe.is_symlink():
            probe.unlink()
        if backend(self.fmt).suffix:
            probe.touch(exist_ok=False)
            probe.unlink()
        else:
            probe.mkdir()
            (probe / "zarr.json").touch()
            shutil.rmtree(probe)

    def _check_kept(self) -> None:
        """MapError now if the map at the path holds arms this build keeps but this software cannot read."""
        if not self.path.exists():
            return
        old = open_store(self.path)
        try:
            root = old.root
            kept = [a for a in root.get("arms") or [] if a not in self.arms]
            if root.get("complete") is True and kept and root.get("format_version") not in READABLE_VERSIONS:
                raise MapError(
                    f"{self.name} is a map of format version {root.get('format_version')!r}, which this "
                    f"software cannot read, holding arm(s) {', '.join(kept)} that this build does not "
                    f"rebuild; rebuild them too or choose another output"
                )
        finally:
            old.close()

    def save(self, maps: dict[str, BuiltMap]) -> Path:
        """Write ``maps`` (arm -> BuiltMap, the reserved arms) with the arms the map holds now, atomically."""
        unreserved = sorted(set(maps) - set(self.arms))
        if unreserved or not self.locks:
            raise MapError(f"{self.name}: arm(s) {', '.join(unreserved) or 'all'} not reserved for this save")
        witnesses: dict[str, np.ndarray] = {}
        for arm, m in maps.items():
            if m.witness is None or m.witness.shape != m.values.shape:
                raise MapError(
                    f"{self.path}: the map of arm '{arm}' has no witnesses of its shape; only a map from "
                    f"placement.build_map can be saved"
                )
            witnesses[arm] = m.witness
        arms: dict[str, ArmArrays] = {
            arm: (
                m.values,
                {
                    **m.meta,
                    CRC_KEY: chunk_crcs(m.values).tolist(),
                    WITNESS_CRC_KEY: chunk_crcs(witnesses[arm]).tolist(),
                    STATS_KEY: array_stats(m.values),  # what `maps info` prints, without reading the map
                },
                witnesses[arm],
            )
            for arm, m in maps.items()
        }
        holder = f"a save into {self.path} (pid {os.getpid()})"
        with FileLock(lock_path(self.path, "save"), holder).acquire(wait_s=SAVE_WAIT_S):
            for line in clear_leftovers(self.path):
                log.warning("%s", line)
            check_target(self.path, self.robot, self.fmt, name=self.name)
            self._check_kept()
            if self.path.exists():
                old = open_store(self.path)
                try:
                    if old.root.get("complete") is True and old.root.get("format_version") in READABLE_VERSIONS:
                        for arm in old.root.get("arms") or []:
                            if arm not in arms:
                                values = old.read_all(arm)
                                # an arm saved before the statistics were stored gets them now
                                meta = {**old.arm_meta(arm), STATS_KEY: array_stats(values)}
                                arms[arm] = (values, meta, old.read_all(arm, witness=True))
                finally:
                    old.close()
            root = {
                "format_version": FORMAT_VERSION,
                "preset": preset_name(self.robot),
                **self.robot.fingerprint,
                # a base frame the preset adds at load: the URDF hash does not cover it
                "base_frame_definition": base_frame_definition(self.robot),
                "arms": sorted(arms),
            }
            atomic_replace(backend(self.fmt), self.path, root, arms)
        return self.path


def preset_name(robot: Robot) -> str:
    """How the map names the robot's preset: the built-in preset's name, else the preset file's path."""
    from placement.robots.preset import PRESET_DIR

    return robot.name if Path(robot.source).parent == PRESET_DIR else robot.source


def save_maps(path: str | Path, robot: Robot, maps: dict[str, BuiltMap], fmt: str = "zarr") -> Path:
    """Write ``maps`` (arm -> BuiltMap) to ``path`` atomically, with the CRC32 of every chunk, every array's
    fill and value statistics (:mod:`placement.storage.stats`) and the metadata digests.

    Arms already in an existing complete map of the same robot at ``path`` are
    kept (and checked as they are read); a path that holds something else is
    never overwritten (MapError); an arm another build into ``path`` is writing
    is a MapError naming that build (see :class:`MapOutput`).
    """
    with MapOutput(path, robot, fmt, list(maps)) as out:
        return out.save(maps)
