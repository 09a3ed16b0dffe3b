"""Build specs: what `placement maps build` builds, from a YAML file (``--spec``) and options.

Every value is checked here, before any work, and a bad one raises
:class:`PlacementError` with one line naming the file and key (or the option)
and what is allowed. ``arms`` is a list of arm names, or a string for one arm.
The validators (``parse_*``) are also used for the command-line options and
by :func:`placement.build_map`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from placement.errors import PlacementError
from placement.kinematics.manipulability import INDEX_NAMES
from placement.storage import BACKENDS
from placement.storage.files import FileRefused, read_bounded
from placement.validation import show as plain_show

if TYPE_CHECKING:
    from placement.robots.preset import Robot

MAX_SAMPLES = 10**11  # ~1 day of sampling at 1.2 M samples/s [count per arm]
MAX_SEED = 2**64 - 1  # seeds are uint64
MIN_RESOLUTION = 0.005  # [m]
MAX_RESOLUTION = 1.0  # [m]
MAX_BINS = 360  # per orientation axis (1 deg bins)
DEFAULT_SAMPLES = 1_000_000
DEFAULT_RESOLUTION = 0.05  # [m]: the paper's 5 cm cells
DEFAULT_BINS = (20, 9, 20)  # yaw 18 deg, pitch 20 deg, roll 18 deg
INDEXES = INDEX_NAMES
FORMATS = tuple(BACKENDS)
SPEC_KEYS = (
    "robot",
    "arms",
    "samples",
    "seed",
    "resolution",
    "bins",
    "index",
    "format",
    "self_collision",
    "self_distance",
    "completion",
    "torso",
)
TORSO_KEYS = ("joint", "values")
#: the keys of a torso of several joints held at postures (one build per posture)
POSTURE_KEYS = ("joints", "postures")
MAX_TORSO_VALUES = 16
MAX_TORSO_JOINTS = 16
MAX_TORSO_ABS = 10.0  # [m or rad]: no lift moves further, no torso turns further; a larger value is a typo


@dataclass(frozen=True)
class TorsoSpec:
    """The ``torso`` key of a build spec, parsed (checked against a robot by :mod:`placement.maps.torso`).

    Attributes:
        joint: the torso joint, one of the preset's fixed joints: a prismatic lift (one map, shifted)
            or a revolute joint (one build per setting); for postures, the first of ``joints``.
        values: (k,) settings [m for a prismatic joint, rad for a revolute one], 1 .. MAX_TORSO_VALUES
            distinct values, ascending; for postures, the posture indices 0 .. k-1.
        joints: (n,) for a torso of several joints held at postures (``torso: {joints, postures}``), the
            joints, distinct; () for one joint.
        postures: (k, n) for postures, each posture's value of every joint [m or rad per joint], in the
            spec's order (posture i is setting i), distinct; () for one joint.
    """

    joint: str
    values: tuple[float, ...]
    joints: tuple[str, ...] = ()
    postures: tuple[tuple[float, ...], ...] = ()


@dataclass(frozen=True)
class BuildSpec:
    """A checked build spec (units in brackets); build one with :func:`parse_build_spec`.

    Attributes:
        robot: preset name or path.
        arms: arm names, or None for every arm of the robot.
        samples: joint samples per arm [count], 1 .. MAX_SAMPLES.
        seed: sampling seed, 0 .. 2^64 - 1.
        resolution: position cell edge [m], MIN_RESOLUTION .. MAX_RESOLUTION.
        bins: orientation bin counts (yaw even, pitch odd, roll even).
        index: manipulability index, one of INDEXES.
        format: storage backend, one of FORMATS.
        self_collision, self_distance, completion: see `placement maps build --help`.
        torso: the lift settings the maps also stand for (:class:`TorsoSpec`), or None.
    """

    robot: str = "pr2"
    arms: tuple[str, ...] | None = None
    samples: int = DEFAULT_SAMPLES
    seed: int = 0
    resolution: float = DEFAULT_RESOLUTION
    bins: tuple[int, int, int] = DEFAULT_BINS
    index: str = "isotropy"
    format: str = "zarr"
    self_collision: bool = False
    self_distance: bool = False
    completion: bool = False
    torso: TorsoSpec | None = None

    def arms_of(self, robot: Robot) -> list[str]:
        """The arms to build on ``robot`` (ArmNotFound, naming the robot's arms, for an unknown one)."""
        arms = list(self.arms) if self.arms else list(robot.arms)
        for arm in arms:
            robot.arm(arm)
        return arms


def show(value: object) -> str:
    """A short one-line rendering of a bad value for an error message (a huge integer by its size:
    Python refuses to write one of more than 4300 digits)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return plain_show(value)
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def whole_number(value: object) -> int | None:
    """``value`` as an int if it is a whole number (int, integral float, or such a string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        try:
            return int(value.strip())
        except ValueError:
            pass
        try:
            value = float(value)
        except ValueError:
            return None
    if isinstance(value, float) and math.isfinite(value) and value == int(value):
        return int(value)
    return None


def parse_count(value: object, where: str, lo: int, hi: int) -> int:
    """A whole number in [lo, hi] (``1e6`` is accepted as 1000000, 1.5 is not)."""
    n = whole_number(value)
    if n is None or not lo <= n <= hi:
        raise PlacementError(f"{where} must be a whole number from {lo:,} to {hi:,}, got {show(value)}")
    return n


def parse_length(value: object, where: str, lo: float, hi: float) -> float:
    """A finite length [m] in [lo, hi] (a number or a numeric string)."""
    x = None
    if not isinstance(value, bool) and isinstance(value, (int, float, str)):
        try:
            x = float(value)
        except (ValueError, OverflowError):
            x = None
    if x is None or not (math.isfinite(x) and lo <= x <= hi):
        raise PlacementError(f"{where} must be a length from {lo:g} to {hi:g} m, got {show(value)}")
    return x


def parse_bins(value: object, where: str) -> tuple[int, int, int]:
    """Three orientation bin counts YAW,PITCH,ROLL (a list, or a comma-separated string)."""
    items = value.split(",") if isinstance(value, str) else value
    counts = [whole_number(b) for b in items] if isinstance(items, (list, tuple)) else []
    valid = [c for c in counts if c is not None and 1 <= c <= MAX_BINS]
    if len(counts) != 3 or len(valid) != 3:
        raise PlacementError(f"{where} must be three bin counts YAW,PITCH,ROLL from 1 to {MAX_BINS}, got {show(value)}")
    yaw, pitch, roll = valid
    if yaw % 2 or roll % 2:
        raise PlacementError(
            f"{where}: yaw and roll bin counts must be even (roll +-pi is a bin centre), got {yaw} and {roll}"
        )
    if pitch % 2 == 0:
        raise PlacementError(f"{where}: the pitch bin count must be odd (pitch 0 is a bin centre), got {pitch}")
    return yaw, pitch, roll


def parse_choice(value: object, where: str, choices: Collection[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise PlacementError(f"{where} must be one of {', '.join(choices)}, got {show(value)}")
    return value


def parse_flag(value: object, where: str) -> bool:
    if not isinstance(value, bool):
        raise PlacementError(f"{where} must be true or false, got {show(value)}")
    return value


def parse_name(value: object, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise PlacementError(f"{where} must be a name (a non-empty string), got {show(value)}")
    return value


def parse_arms(value: object, where: str) -> tuple[str, ...]:
    """A list of distinct arm names, or one name as a string."""
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not names:
        raise PlacementError(f"{where} must be an arm name or a list of arm names, got {show(value)}")
    arms = tuple(parse_name(a, where) for a in names)
    if len(set(arms)) != len(arms):
        raise PlacementError(f"{where} names an arm twice: {show(value)}")
    return arms


def _setting(value: object, where: str) -> float:
    """A torso setting: a length [m] (prismatic joint) or an angle [rad] (revolute), within +-MAX_TORSO_ABS;
    a number in the file (a string such as "0.1" is refused: a spec's numbers are YAML numbers)."""
    try:
        if isinstance(value, str):
            raise PlacementError(where)
        return parse_length(value, where, -MAX_TORSO_ABS, MAX_TORSO_ABS)
    except PlacementError:
        raise PlacementError(
            f"{where} must be a setting (a length [m] or an angle [rad]) from {-MAX_TORSO_ABS:g} to "
            f"{MAX_TORSO_ABS:g}, got {show(value)}"
        ) from None


def _exact_keys(value: dict[Any, Any], where: str, keys: tuple[str, ...]) -> None:
    """PlacementError naming the first key of ``value`` not in ``keys``, or the first of ``keys`` missing."""
    unknown = [k for k in value if k not in keys]
    if unknown:
        raise PlacementError(f"{where}: unknown key {show(unknown[0])}; allowed: {', '.join(keys)}")
    for key in keys:
        if key not in value:
            raise PlacementError(f"{where}.{key} is missing")


#: Torso settings (or postures, joint by joint) closer than this [m or rad] are one setting: a map per
#: setting would be built twice (1 ulp apart) for the same robot
SAME_SETTING = 1e-9


def parse_torso(value: object, where: str) -> TorsoSpec:
    """``{joint: name, values: [v1, ...]}`` [m or rad]: 1 .. MAX_TORSO_VALUES distinct finite values,
    returned ascending; or ``{joints: [j1, ...], postures: [[v11, ...], ...]}`` (:func:`parse_postures`).
    Errors name the sub-key (``torso.values[2]``)."""
    if not isinstance(value, dict):
        raise PlacementError(
            f"{where} must be a mapping {{joint: name, values: [m or rad, ...]}} or "
            f"{{joints: [names], postures: [[m or rad per joint], ...]}}, got {show(value)}"
        )
    if any(k in value for k in POSTURE_KEYS):
        return parse_postures(value, where)
    _exact_keys(value, where, TORSO_KEYS)
    joint = parse_name(value["joint"], f"{where}.joint")
    items = value["values"]
    if not isinstance(items, (list, tuple)) or not 1 <= len(items) <= MAX_TORSO_VALUES:
        raise PlacementError(
            f"{where}.values must be a list of 1 to {MAX_TORSO_VALUES} settings [m or rad], got {show(items)}"
        )
    values = [_setting(v, f"{where}.values[{i}]") for i, v in enumerate(items)]
    for i, v in enumerate(values):
        same = next((k for k, u in enumerate(values[:i]) if abs(u - v) <= SAME_SETTING), None)
        if same is not None:
            raise PlacementError(
                f"{where}.values[{i}]: {v:.17g} is given twice (values[{same}]: {values[same]:.17g}; settings "
                f"within {SAME_SETTING:g} m or rad are one)"
            )
    return TorsoSpec(joint, tuple(sorted(values)))


def parse_postures(value: dict[Any, Any], where: str) -> TorsoSpec:
    """``{joints: [j1, ..., jn], postures: [[v1, ..., vn], ...]}``: 1 .. MAX_TORSO_JOINTS distinct joint
    names and 1 .. MAX_TORSO_VALUES distinct postures of n finite values each [m or rad per joint], kept
    in the spec's order (posture i is setting i); errors name the sub-key (``torso.postures[1][0]``)."""
    if "joint" in value or "values" in value:
        extra = "joint" if "joint" in value else "values"
        raise PlacementError(
            f"{where}.{extra}: give either joint and values (one joint) or joints and postures (several), not both"
        )
    _exact_keys(value, where, POSTURE_KEYS)
    names = value["joints"]
    if not isinstance(names, (list, tuple)) or not 1 <= len(names) <= MAX_TORSO_JOINTS:
        raise PlacementError(f"{where}.joints must be a list of 1 to {MAX_TORSO_JOINTS} joint names, got {show(names)}")
    joints = tuple(parse_name(j, f"{where}.joints[{i}]") for i, j in enumerate(names))
    for i, j in enumerate(joints):
        if j in joints[:i]:
            raise PlacementError(f"{where}.joints[{i}]: '{j}' is given twice (joints[{joints.index(j)}])")
    items = value["postures"]
    if not isinstance(items, (list, tuple)) or not 1 <= len(items) <= MAX_TORSO_VALUES:
        raise PlacementError(
            f"{where}.postures must be a list of 1 to {MAX_TORSO_VALUES} postures (one value [m or rad] per "
            f"joint each), got {show(items)}"
        )
    postures: list[tuple[float, ...]] = []
    for i, p in enumerate(items):
        if not isinstance(p, (list, tuple)) or len(p) != len(joints):
            raise PlacementError(
                f"{where}.postures[{i}] must be a list of {len(joints)} values [m or rad] (one per joint of "
                f"{where}.joints), got {show(p)}"
            )
        posture = tuple(_setting(v, f"{where}.postures[{i}][{k}]") for k, v in enumerate(p))
        same = next(
            (k for k, q in enumerate(postures) if max(abs(a - b) for a, b in zip(q, posture)) <= SAME_SETTING), None
        )
        if same is not None:
            raise PlacementError(
                f"{where}.postures[{i}] is given twice (postures[{same}]; postures within {SAME_SETTING:g} m or "
                "rad in every joint are one)"
            )
        postures.append(posture)
    return TorsoSpec(joints[0], tuple(float(i) for i in range(len(postures))), joints, tuple(postures))


def parse_build_spec(data: object, source: str = "build spec") -> BuildSpec:
    """Check a build spec mapping (from YAML) and return it as a :class:`BuildSpec`."""
    if not isinstance(data, dict) or not data:
        raise PlacementError(f"{source} must be a non-empty mapping of {', '.join(SPEC_KEYS)}, got {show(data)}")
    unknown = [k for k in data if k not in SPEC_KEYS]
    if unknown:
        raise PlacementError(f"{source}: unknown key {show(unknown[0])}; allowed: {', '.join(SPEC_KEYS)}")
    parsers: dict[str, Callable[[Any, str], Any]] = {
        "robot": lambda v, w: parse_name(v, w),
        "arms": parse_arms,
        "samples": lambda v, w: parse_count(v, w, 1, MAX_SAMPLES),
        "seed": lambda v, w: parse_count(v, w, 0, MAX_SEED),
        "resolution": lambda v, w: parse_length(v, w, MIN_RESOLUTION, MAX_RESOLUTION),
        "bins": parse_bins,
        "index": lambda v, w: parse_choice(v, w, INDEXES),
        "format": lambda v, w: parse_choice(v, w, FORMATS),
        "self_collision": parse_flag,
        "self_distance": parse_flag,
        "completion": parse_flag,
        "torso": parse_torso,
    }
    return BuildSpec(**{key: parsers[key](value, f"{source}: {key}") for key, value in data.items()})


#: a build spec file is read only up to this size [bytes] (the default one has under 1 kB)
MAX_SPEC_BYTES = 1 << 20


def load_build_spec(path: str | Path) -> BuildSpec:
    """Read and check the build spec YAML at ``path``."""
    source = f"build spec {path}"
    try:
        text = read_bounded(path, MAX_SPEC_BYTES).decode("utf-8")
    except FileNotFoundError:
        raise PlacementError(f"{source} not found") from None
    except FileRefused as exc:  # a directory, FIFO, device or a file too large for a spec
        raise PlacementError(f"build spec {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PlacementError(f"{source} cannot be read ({type(exc).__name__})") from None
    return parse_build_spec_text(text, source)


def parse_build_spec_text(text: str, source: str = "build spec") -> BuildSpec:
    """Parse and check build spec YAML text (``source`` names it in errors)."""
    try:
        data = yaml.safe_load(text)
    except (yaml.YAMLError, ValueError, OverflowError, RecursionError) as exc:  # ValueError: 2020-02-30
        lines = str(exc).strip().splitlines() or [type(exc).__name__]
        raise PlacementError(f"{source} is not valid YAML: {lines[0]}") from None
    return parse_build_spec(data, source)
