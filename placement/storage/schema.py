"""Types of the stored root and arm metadata, checked like a preset: one MapError naming the key.

The digests (digest.py) say whether metadata changed; these checks say whether it can be used at
all, and they are all a map written before the digests existed gets.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from pathlib import Path
from typing import Any

from placement.errors import MapError
from placement.storage.format import STATS_KEY

MAX_SEED = 2**64 - 1
WITNESS_DTYPES = ("uint32", "int64")


class _Bad(Exception):
    def __init__(self, key: str, expected: str, got: object) -> None:
        text = repr(got)
        super().__init__(f"{key}: expected {expected}, got {text if len(text) <= 60 else text[:57] + '...'}")


def _int(doc: dict[str, Any], key: str, lo: int, hi: int, prefix: str = "") -> int:
    v = doc.get(key)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise _Bad(prefix + key, f"a whole number from {lo} to {hi}", v)
    return v


def _str(doc: dict[str, Any], key: str, prefix: str = "") -> str:
    v = doc.get(key)
    if not isinstance(v, str) or not v:
        raise _Bad(prefix + key, "a non-empty string", v)
    return v


def _real(v: object, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v):
        raise _Bad(key, "a finite number", v)
    return float(v)


def _vector3(v: object, key: str) -> None:
    """3 finite numbers (a position [m] or a direction)."""
    if not isinstance(v, list) or len(v) != 3:
        raise _Bad(key, "3 numbers", v)
    for i, x in enumerate(v):
        _real(x, f"{key}[{i}]")


def _dict(doc: dict[str, Any], key: str, prefix: str = "") -> dict[str, Any]:
    v = doc.get(key)
    if not isinstance(v, dict):
        raise _Bad(prefix + key, "a mapping", v)
    return v


def _names(doc: dict[str, Any], key: str) -> list[str]:
    v = doc.get(key)
    if not isinstance(v, list) or not v or not all(isinstance(a, str) and a for a in v) or len(set(v)) != len(v):
        raise _Bad(key, "a non-empty list of distinct names", v)
    return v


def _quantiles(v: object) -> None:
    """A ``value_quantiles`` record (placement/maps/quantiles.py): ``levels`` a whole number, ``values``
    empty (no reached cell) or ``levels + 1`` finite positive non-decreasing numbers."""
    if not isinstance(v, dict):
        raise _Bad("value_quantiles", "a mapping", v)
    n = _int(v, "levels", 1, 1_000_000, "value_quantiles.")
    vals = v.get("values")
    if not isinstance(vals, list) or (vals and len(vals) != n + 1):
        raise _Bad("value_quantiles.values", f"an empty list or {n + 1} numbers", vals)
    for i, x in enumerate(vals):
        if _real(x, f"value_quantiles.values[{i}]") <= 0 or (i and x < vals[i - 1]):
            raise _Bad(f"value_quantiles.values[{i}]", "a positive number, not below the one before", x)


def _stats(v: object) -> None:
    """A statistics record (placement/storage/stats.py): ``cells`` a positive whole number, ``filled_cells``
    a whole number up to it, ``fill_ratio`` a number from 0 to 1, ``value.max`` and ``value.mean`` finite
    numbers, ``value.histogram`` ascending ``edges`` and one whole ``counts`` entry per bin between them."""
    p = STATS_KEY + "."
    if not isinstance(v, dict):
        raise _Bad(STATS_KEY, "a mapping", v)
    cells = _int(v, "cells", 1, 2**63 - 1, p)
    _int(v, "filled_cells", 0, cells, p)
    if not 0 <= _real(v.get("fill_ratio"), p + "fill_ratio") <= 1:
        raise _Bad(p + "fill_ratio", "a number from 0 to 1", v.get("fill_ratio"))
    value = _dict(v, "value", p)
    for key in ("max", "mean"):
        _real(value.get(key), f"{p}value.{key}")
    hist = _dict(value, "histogram", p + "value.")
    edges = hist.get("edges")
    if not isinstance(edges, list) or len(edges) < 2:
        raise _Bad(p + "value.histogram.edges", "2 or more numbers", edges)
    for i, x in enumerate(edges):
        if _real(x, f"{p}value.histogram.edges[{i}]") <= (edges[i - 1] if i else -math.inf):
            raise _Bad(f"{p}value.histogram.edges[{i}]", "a number above the one before", x)
    counts = hist.get("counts")
    if not isinstance(counts, list) or len(counts) != len(edges) - 1:
        raise _Bad(p + "value.histogram.counts", f"{len(edges) - 1} counts (one per bin)", counts)
    for i, c in enumerate(counts):
        if isinstance(c, bool) or not isinstance(c, int) or not 0 <= c <= cells:
            raise _Bad(f"{p}value.histogram.counts[{i}]", f"a whole number from 0 to {cells}", c)


#: how a torso record's maps stand for its settings (placement/maps/torso.py): one map moved with the lift
#: (a rigid prismatic lift; the record of maps without ``kind``), or one build per setting
TORSO_KINDS = ("shifted", "per_setting", "posture")
#: the units of a torso record's settings: a prismatic joint's [m], a revolute joint's [rad], a posture's index
TORSO_UNITS = ("m", "rad", "index")
#: between an arm's name and its setting in the name of the array of one setting of a per-setting build
SETTING_SEPARATOR = "@"


def setting_array(arm: str, joint: str, value: float) -> str:
    """The stored name of the map of ``arm`` built with ``joint`` at ``value`` [m or rad] (a per-setting
    torso build): ``right@torso_2_joint=0.2``, the value as Python's shortest round-trip repr."""
    return f"{arm}{SETTING_SEPARATOR}{joint}={float(value)!r}"


def posture_array(arm: str, index: int) -> str:
    """The stored name of the map of ``arm`` built at posture ``index`` of a torso of several joints:
    ``right@posture=1`` (the joints' values are in its metadata's ``setting``)."""
    return f"{arm}{SETTING_SEPARATOR}posture={int(index)}"


def arm_arrays(names: list[str]) -> list[str]:
    """The arms among a root's ``arms`` list: every name but the per-setting arrays (``arm@joint=value``
    of an arm the list holds), which the arm's torso record names."""
    listed = set(names)
    return [n for n in names if not (SETTING_SEPARATOR in n and n.split(SETTING_SEPARATOR, 1)[0] in listed)]


def _torso(v: object) -> None:
    """A ``torso`` record (placement/maps/torso.py): ``joint`` a name, ``values`` 1 .. 16 ascending distinct
    finite numbers [m or rad], ``reference`` [m or rad], ``velocity`` a positive number [m/s or rad/s];
    ``kind`` (absent: shifted) one of TORSO_KINDS, ``unit`` (absent: m) one of TORSO_UNITS; a shifted
    record has ``shift`` 3 numbers [m/m], a per-setting one ``shift`` null and ``arrays``: the stored
    array of each value; a posture record (values the indices 0 .. k-1) also ``joints``, ``units``,
    ``velocities`` and ``postures`` (one value per joint for every index, the arm's own
    ``reference_setting`` included)."""
    if not isinstance(v, dict):
        raise _Bad("torso", "a mapping", v)
    _str(v, "joint", "torso.")
    vals = v.get("values")
    if not isinstance(vals, list) or not 1 <= len(vals) <= 16:
        raise _Bad("torso.values", "1 to 16 numbers", vals)
    for i, x in enumerate(vals):
        _real(x, f"torso.values[{i}]")
        if i and x <= vals[i - 1]:
            raise _Bad(f"torso.values[{i}]", "a number above the one before", x)
    _real(v.get("reference"), "torso.reference")
    kind = v.get("kind", "shifted")
    if kind not in TORSO_KINDS:
        raise _Bad("torso.kind", " or ".join(TORSO_KINDS), kind)
    if v.get("unit", "m") not in TORSO_UNITS:
        raise _Bad("torso.unit", " or ".join(TORSO_UNITS), v.get("unit"))
    if kind == "shifted":
        _vector3(v.get("shift"), "torso.shift")
    else:
        if v.get("shift") is not None:
            raise _Bad("torso.shift", "null (one build per setting)", v.get("shift"))
        arrays = v.get("arrays")
        if (
            not isinstance(arrays, list)
            or len(arrays) != len(vals)
            or not all(isinstance(a, str) and a for a in arrays)
            or len(set(arrays)) != len(arrays)
        ):
            raise _Bad("torso.arrays", f"{len(vals)} distinct array names (one per value)", arrays)
    if _real(v.get("velocity"), "torso.velocity") <= 0:
        raise _Bad("torso.velocity", "a positive speed", v.get("velocity"))
    if kind == "posture":
        _postures(v, len(vals))


def _postures(v: dict[str, Any], k: int) -> None:
    """The posture fields of a torso record with ``k`` values (see :func:`_torso`)."""
    joints = v.get("joints")
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) and j for j in joints):
        raise _Bad("torso.joints", "a list of joint names", joints)
    n = len(joints)
    ok: Callable[[Any], bool]
    for key, ok in (("units", lambda u: u in ("m", "rad")), ("velocities", lambda x: _real(x, "torso.velocities") > 0)):
        items = v.get(key)
        if not isinstance(items, list) or len(items) != n or not all(ok(x) for x in items):
            raise _Bad(f"torso.{key}", f"{n} entries (one per joint)", items)
    ref = v.get("reference_setting")
    if not isinstance(ref, int) or isinstance(ref, bool) or not 0 <= ref <= k:
        raise _Bad("torso.reference_setting", f"a posture index from 0 to {k}", ref)
    postures = v.get("postures")
    if not isinstance(postures, list) or len(postures) != max(k, ref + 1):
        raise _Bad("torso.postures", f"{max(k, ref + 1)} postures", postures)
    for i, p in enumerate(postures):
        if not isinstance(p, list) or len(p) != n:
            raise _Bad(f"torso.postures[{i}]", f"{n} numbers (one per joint)", p)
        for x in p:
            _real(x, f"torso.postures[{i}]")


def _base_frame_definition(v: object) -> None:
    """The root's ``base_frame_definition``: null (a URDF frame) or {parent: name, xyz: [x, y, z] [m]}."""
    if v is None:
        return
    if not isinstance(v, dict):
        raise _Bad("base_frame_definition", "null or a mapping", v)
    _str(v, "parent", "base_frame_definition.")
    _vector3(v.get("xyz"), "base_frame_definition.xyz")


def check_arms(path: Path | str, root: dict[str, Any]) -> None:
    """MapError unless the root's arm list (if any) is a list of names (read by everything that opens a map)."""
    if "arms" in root:
        try:
            v = root["arms"]
            if not isinstance(v, list) or not all(isinstance(a, str) for a in v):
                raise _Bad("arms", "a list of names", v)
        except _Bad as exc:
            raise MapError(f"{path}: root metadata: {exc}; rebuild the map") from None


def check_root_types(path: Path | str, root: dict[str, Any]) -> None:
    """MapError naming the key unless the root metadata of a complete map has the stored types."""
    try:
        for key in ("robot", "urdf_sha256", "base_frame", "preset"):
            _str(root, key)
        for name, value in _dict(root, "fixed_joints").items():
            _real(value, f"fixed_joints.{name}")
        _names(root, "arms")
        if "base_frame_definition" in root:
            _base_frame_definition(root["base_frame_definition"])
    except _Bad as exc:
        raise MapError(f"{path}: root metadata: {exc}; rebuild the map") from None


def check_arm_types(path: Path | str, arm: str, meta: dict[str, Any]) -> None:
    """MapError naming the key unless an arm's metadata has what reading and verifying it needs."""
    try:
        if "setting" in meta:  # one setting of a per-setting torso build: its name says which
            setting = _dict(meta, "setting")
            joint = _str(setting, "joint", "setting.")
            value = _real(setting.get("value"), "setting.value")
            owner = meta.get("arm")
            if "posture" in setting:  # a posture of a torso of several joints: ``value`` is its index
                named = isinstance(owner, str) and value == int(value) and posture_array(owner, int(value)) == arm
            else:
                named = isinstance(owner, str) and setting_array(owner, joint, value) == arm
            if not named:
                raise _Bad("arm", f"the arm of array '{arm}'", meta.get("arm"))
        elif meta.get("arm") != arm:
            raise _Bad("arm", repr(arm), meta.get("arm"))
        if not isinstance(meta.get("joints"), list) or not all(isinstance(j, str) for j in meta["joints"]):
            raise _Bad("joints", "a list of joint names", meta.get("joints"))
        _str(meta, "tip_frame")
        grid = _dict(meta, "grid")
        _vector3(grid.get("origin"), "grid.origin")
        if _real(grid.get("resolution"), "grid.resolution") <= 0:
            raise _Bad("grid.resolution", "a positive length", grid.get("resolution"))
        shape = grid.get("shape")
        if (
            not isinstance(shape, list)
            or len(shape) != 6
            or not all(isinstance(s, int) and not isinstance(s, bool) and 1 <= s <= 1 << 31 for s in shape)
        ):
            raise _Bad("grid.shape", "6 positive counts", shape)
        samples = _int(meta, "samples", 1, 10**12)
        _int(meta, "seed", 0, MAX_SEED)
        measure = _dict(meta, "measure")
        _str(measure, "index", "measure.")
        if "rank" in measure:
            _int(measure, "rank", 1, 6, "measure.")
        witness = _dict(meta, "witness")
        if witness.get("dtype") not in WITNESS_DTYPES:
            raise _Bad("witness.dtype", " or ".join(WITNESS_DTYPES), witness.get("dtype"))
        _int(witness, "empty", 0, 2**64, "witness.")
        if _int(witness, "plain_samples", 1, 10**12, "witness.") != samples:
            raise _Bad("witness.plain_samples", f"the sample count {samples}", witness.get("plain_samples"))
        if "value_quantiles" in meta:  # maps built before it was recorded have none
            _quantiles(meta["value_quantiles"])
        if "torso" in meta:  # only maps built with the spec's torso key have one
            _torso(meta["torso"])
        if STATS_KEY in meta:  # maps saved before it was recorded have none
            _stats(meta[STATS_KEY])
    except _Bad as exc:
        raise MapError(f"{path}: metadata of arm '{arm}': {exc}; rebuild the map") from None
