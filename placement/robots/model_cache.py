"""Parsed URDF models, cached by the bytes they were parsed from, and their mimic joints."""

from __future__ import annotations

import hashlib
import threading
import xml.etree.ElementTree as ET
from collections import OrderedDict
from pathlib import Path

import pinocchio as pin

from placement.errors import RobotError
from placement.robots.description import (
    MAX_URDF_BYTES,
    check_tree,
    expand_xacro,
    is_xacro,
    kinematic_xml,
    readable_urdf,
)
from placement.validation import one_line, read_regular

#: Parsed URDF models kept in memory, keyed by (path, sha256 of the bytes parsed).
MODEL_CACHE_SIZE = 8

_MODELS: OrderedDict[tuple[str, str], tuple[pin.Model, dict[str, str]]] = OrderedDict()
MODELS_LOCK = threading.Lock()


def mimic_joints(xml: bytes | str) -> dict[str, str]:
    """{mimic joint: the joint it follows} of a URDF document ({} if it is not parseable XML: pinocchio
    parsed it, so only an exotic encoding gets here)."""
    try:
        root = ET.fromstring(xml)
    except ET.ParseError:
        return {}
    out: dict[str, str] = {}
    for j in root.iter("joint"):
        mimic, name = j.find("mimic"), j.get("name")
        if mimic is not None and name is not None:
            out[name] = mimic.get("joint", "?")
    return out


def urdf_model(path: Path, where: str) -> tuple[pin.Model, dict[str, str], str]:
    """(model, {mimic joint: leader}, sha256) of the URDF file ``path`` as it is now.

    The bytes are read once, hashed, and the model is parsed from those very
    bytes, so the cache key always describes the cached model (an edited file
    has a new hash). Each call returns its own copy of the model.
    """
    if is_xacro(path):  # expanded on every load: its includes may have changed
        data = expand_xacro(path, f"{where}: urdf")
    else:
        data = read_regular(path, RobotError, f"{where}: urdf: {path}", MAX_URDF_BYTES, "URDF")
    sha = hashlib.sha256(data).hexdigest()
    key = (str(path), sha)
    with MODELS_LOCK:
        hit = _MODELS.get(key)
        if hit is not None:
            _MODELS.move_to_end(key)
    if hit is None:
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise RobotError(one_line(f"{where}: urdf: {path} is not UTF-8 text (byte {exc.start})")) from None
        text, _ = readable_urdf(text)
        try:
            root = ET.fromstring(text)
            check_tree(root, f"{where}: urdf: {path}")
        except ET.ParseError as exc:
            raise RobotError(one_line(f"{where}: urdf: URDF {path} does not load: not XML ({exc})")) from None
        try:
            model = pin.buildModelFromXML(kinematic_xml(root))
        except Exception as exc:  # pinocchio raises plain RuntimeError/ValueError
            msg = " ".join(str(exc).split()) or type(exc).__name__
            raise RobotError(one_line(f"{where}: urdf: URDF {path} does not load: {msg}")) from None
        hit = (model, mimic_joints(data))
        with MODELS_LOCK:
            _MODELS[key] = hit
            while len(_MODELS) > MODEL_CACHE_SIZE:
                _MODELS.popitem(last=False)
    return pin.Model(hit[0]), dict(hit[1]), sha


def frame_id(model: pin.Model, name: str) -> int:
    """The id of the frame ``name``: its link's (BODY) frame when other frames share the name (the
    Unitree Z1's URDF names a link and its joint ``gripperStator``, and pinocchio's own lookup then
    raises), else the first frame of that name (``model.nframes`` when there is none)."""
    if model.existFrame(name, pin.FrameType.BODY):
        return int(model.getFrameId(name, pin.FrameType.BODY))
    for i, f in enumerate(model.frames):
        if f.name == name:
            return i
    return int(model.nframes)


__all__ = ["MODELS_LOCK", "MODEL_CACHE_SIZE", "frame_id", "mimic_joints", "urdf_model"]


_FK_DATA = threading.local()


def fk_data(model: pin.Model) -> pin.Data:
    """A pinocchio ``Data`` of ``model`` for the calling thread, made once (``createData`` of a
    full robot costs far more than the forward kinematics it serves)."""
    cache: dict[int, tuple[pin.Model, pin.Data]] | None = getattr(_FK_DATA, "by_model", None)
    if cache is None:
        cache = _FK_DATA.by_model = {}
    hit = cache.get(id(model))
    if hit is None or hit[0] is not model:  # the model is kept with it: its id is not reused meanwhile
        if len(cache) >= 4 * MODEL_CACHE_SIZE:
            cache.clear()
        hit = cache[id(model)] = (model, model.createData())
    return hit[1]
