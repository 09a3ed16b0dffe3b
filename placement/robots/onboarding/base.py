"""The base of a robot read by ``placement robots init``: the frame on the floor and the footprint.

Base frame: a root-level frame named ``*footprint*``, else the root link when it is on the floor (its
origin within :data:`ON_FLOOR` of the lowest point of the robot's collision shapes), else (a root
above the floor, as a humanoid's or a wheeled robot's pelvis) the root link projected to the floor, a
frame the preset defines (``base_frame_parent``, ``base_frame_xyz``): never a link that a joint moves
(a wheel, a sole).

Footprint: the convex hull of the floor projection of the bounding boxes of every collision shape
the arms do not move (through pinocchio/coal geometry), in the base frame, rounded outwards to the
millimetre; without loadable collision shapes, a circle around the links' origins plus
:data:`RADIUS_MARGIN`.
"""

from __future__ import annotations

import itertools
import math
import os
import stat
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from placement.collision.robot import convex_hull
from placement.errors import RobotError
from placement.robots.description import package_dirs
from placement.robots.footprint import contains_origin
from placement.validation import one_line

#: A root link whose origin is this close to the floor [m] is on the floor.
ON_FLOOR = 0.05
#: Added to the links' origins when the footprint cannot come from collision shapes [m].
RADIUS_MARGIN = 0.1
#: Largest collision mesh file read [bytes] (a binary STL of 335,000 triangles; Romeo's largest is
#: 3.9 MB) and most triangles over all collision meshes once loaded: a random-soup mesh of 200,000
#: triangles takes 20 s in init; Romeo has 105,000.
MAX_MESH_BYTES = 16 * 2**20
MAX_COLLISION_TRIANGLES = 250_000


@dataclass
class Base:
    """What init found about the base.

    Attributes:
        frame: base frame name.
        footprint: (k, 2) [m] counter-clockwise polygon in the base frame, or None (use ``radius``).
        radius: [m] circumscribed radius (of the polygon, or the circle when footprint is None).
        notes: plain words on how each value was found; warnings: what was guessed.
        parent, xyz: for a base frame the preset defines (no URDF frame is on the floor under the root):
            the URDF frame it is fixed to and its origin (3,) [m] there; else None.
    """

    frame: str
    footprint: np.ndarray | None
    radius: float
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    parent: str | None = None
    xyz: tuple[float, float, float] | None = None


def _mesh_path(name: str, urdf: Path) -> Path | None:
    """The file a URDF mesh ``filename`` names, as pinocchio looks for it; None when none exists."""
    if name.startswith("file://"):
        name = name[len("file://") :]
    if name.startswith("package://"):
        rest = name[len("package://") :]
        options = [Path(d) / rest for d in package_dirs(urdf)]
    else:
        p = Path(name).expanduser()
        options = [p] if p.is_absolute() else [Path(urdf).parent / p, Path.cwd() / p]
    for p in options:
        try:
            if os.path.lexists(p):
                return p
        except (OSError, ValueError):
            pass
    return None


def _numbers(text: str | None, n: int) -> list[float] | None:
    """The floats of a URDF attribute (``n`` of them, or 1 for a uniform scale), None if unreadable."""
    try:
        v = [float(t) for t in (text or "").split()]
    except ValueError:
        return None
    return v if len(v) in (n, 1 if n == 3 else n) else None


def _shape_problem(geometry: ET.Element, urdf: Path) -> str:
    """Why a collision ``<geometry>`` cannot be used ("" when it can)."""
    for kind, attrs in (
        ("box", {"size": 3}),
        ("cylinder", {"radius": 1, "length": 1}),
        ("sphere", {"radius": 1}),
        ("mesh", {"scale": 3}),
    ):
        el = geometry.find(kind)
        if el is None:
            continue
        for attr, n in attrs.items():
            if kind == "mesh" and el.get(attr) is None:
                continue
            v = _numbers(el.get(attr), n)
            # a mesh may be mirrored (a negative scale); nothing may be flat, NaN or infinite
            if v is None or not all(math.isfinite(x) and (x != 0 if kind == "mesh" else x > 0) for x in v):
                return f"{kind} {attr} '{el.get(attr)}' (needs finite, non-zero numbers)"
        if kind == "mesh":
            path = _mesh_path(el.get("filename", ""), urdf)
            if path is None:  # one missing mesh (an accessory not installed) must not cost the others
                return f"mesh '{el.get('filename', '')}' not found"
            try:
                st = os.stat(path)
            except OSError as exc:
                return f"mesh {path}: {exc.strerror or exc}"
            if not stat.S_ISREG(st.st_mode):
                return f"mesh {path} is not a regular file"
            if st.st_size > MAX_MESH_BYTES:
                return (
                    f"mesh {path} is {st.st_size / 2**20:.3g} MiB, more than the {MAX_MESH_BYTES // 2**20} MiB allowed"
                )
        return ""
    return ""


def screen_collisions(xml: str, urdf: Path) -> tuple[str, list[str]]:
    """(the URDF text without the ``<collision>`` shapes that cannot be used, warnings naming them).

    Unusable: a mesh with a zero, negative or NaN scale (coal crashes on its hull), a mesh that is not
    a regular file or is larger than :data:`MAX_MESH_BYTES`, a primitive with a size that is not a
    positive finite number, an origin that is not finite."""
    try:
        root = ET.fromstring(xml)
    except ET.ParseError:
        return xml, []
    warnings = []
    for link in root.iter("link"):
        for col in list(link.findall("collision")):
            origin = col.find("origin")
            why = ""
            if origin is not None:
                for attr in ("xyz", "rpy"):
                    v = _numbers(origin.get(attr, "0 0 0"), 3)
                    if v is None or not all(math.isfinite(x) for x in v):
                        why = f"origin {attr} '{origin.get(attr)}'"
            geometry = col.find("geometry")
            why = why or ("" if geometry is None else _shape_problem(geometry, urdf))
            if why:
                link.remove(col)
                warnings.append(
                    f"link '{link.get('name')}': a collision shape is left out ({why}): it is not in "
                    "the footprint nor in the self-collision sampling; fix the URDF before planning with "
                    "collision checks"
                )
    if not warnings:
        return xml, []
    return ET.tostring(root, encoding="unicode"), warnings


def load_collision(
    model: pin.Model, xml: str, urdf: Path, notes: list[str] | None = None
) -> tuple[pin.GeometryModel | None, str]:
    """(pinocchio GeometryModel of the usable ``<collision>`` shapes (see :func:`screen_collisions`),
    "") or (None, reason). Meshes holding more than :data:`MAX_COLLISION_TRIANGLES` triangles in all
    are made lighter by :func:`simplify_meshes`; what it did is appended to ``notes`` (a warning)."""
    xml, _ = screen_collisions(xml, urdf)
    try:
        geom = pin.buildGeomFromUrdfString(model, xml, pin.GeometryType.COLLISION, package_dirs=package_dirs(urdf))
    except Exception as exc:  # a mesh that cannot be found or read
        return None, one_line(" ".join(str(exc).split()))[:160]
    try:
        said = simplify_meshes(geom, MAX_COLLISION_TRIANGLES)
    except RobotError as exc:
        raise RobotError(f"{urdf}: {exc}") from None
    if said and notes is not None:
        notes.append(said)
    return geom, ""


def triangles(geometry: object) -> int:
    """Triangles of a collision geometry (0 for primitives)."""
    return int(getattr(geometry, "num_tris", 0) or 0)


def simplify_meshes(geom: pin.GeometryModel, limit: int) -> str:
    """Replace the heaviest meshes of ``geom`` by their convex hulls until they hold at most ``limit``
    triangles in all (a vendor's visual-grade collision meshes); returns what was done in one line, or
    "" when nothing was. Raises :class:`RobotError` when even every hull together holds more."""
    objs = geom.geometryObjects
    counts = [triangles(o.geometry) for o in objs]
    total = before = sum(counts)
    if total <= limit:
        return ""
    replaced: list[str] = []
    for k in sorted(range(len(objs)), key=lambda k: -counts[k]):
        if total <= limit or counts[k] == 0:
            break
        hull, same = convex_hull(objs[k].geometry)
        if same:
            continue
        after = max(2 * int(hull.num_points) - 4, 0)  # a triangulated convex polyhedron of V vertices
        objs[k].geometry = hull
        total += after - counts[k]
        replaced.append(objs[k].name)
    if total > limit:
        raise RobotError(
            f"the collision meshes hold {before} triangles, more than the {limit} allowed, and still {total} "
            "with the heaviest replaced by their convex hulls: use simplified collision meshes"
        )
    shown = ", ".join(replaced[:4]) + (f" and {len(replaced) - 4} more" if len(replaced) > 4 else "")
    return (
        f"the collision meshes hold {before} triangles, more than the {limit} that init works with: "
        f"{len(replaced)} are replaced by their convex hulls here ({shown}): {before} -> {total} triangles "
        "(the planner's check uses the URDF's meshes; give lighter ones to speed it up)"
    )


def shape_corners(
    model: pin.Model, geom: pin.GeometryModel, q: np.ndarray, skip: set[int]
) -> list[tuple[str, np.ndarray]]:
    """[(shape name, (8, 3) corners [m] of its local bounding box in the root frame at ``q``)] of the
    collision shapes of ``geom`` not on the joints ``skip``."""
    gdata, data = geom.createData(), model.createData()
    pin.updateGeometryPlacements(model, data, geom, gdata, q)
    out: list[tuple[str, np.ndarray]] = []
    for k, obj in enumerate(geom.geometryObjects):
        if obj.parentJoint in skip:
            continue
        obj.geometry.computeLocalAABB()
        lo, hi = np.array(obj.geometry.aabb_local.min_), np.array(obj.geometry.aabb_local.max_)
        M = gdata.oMg[k]
        out.append((obj.name, np.array(list(itertools.product(*zip(lo, hi)))) @ M.rotation.T + M.translation))
    return out


def collision_boxes(
    model: pin.Model, xml: str, urdf: Path, q: np.ndarray, skip: set[int]
) -> tuple[np.ndarray | None, str]:
    """((m, 8, 3) corners [m] of the bounding boxes of collision shapes not on joints ``skip``, in the
    root frame at ``q``) or (None, reason)."""
    geom, why = load_collision(model, xml, urdf)
    if geom is None:
        return None, why
    corners = shape_corners(model, geom, q, skip)
    dropped = [name for name, c in corners if not np.all(np.isfinite(c))]
    boxes = [c for _, c in corners if np.all(np.isfinite(c))]
    if dropped:
        why = f"collision shapes {', '.join(dropped[:5])} have a bounding box that is not finite"
    if not boxes:
        return None, why or "no collision shapes outside the arms"
    return np.array(boxes), why


def _turn(a: Sequence[float], b: Sequence[float], c: Sequence[float]) -> float:
    """z of (b - a) x (c - a): positive for a left turn."""
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def hull(points: np.ndarray) -> np.ndarray:
    """(k, 2) counter-clockwise convex hull of (m, 2) points (monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 9))))
    if len(pts) < 3:
        return np.array(pts)

    def half(seq: list[tuple[float, ...]]) -> list[tuple[float, ...]]:
        out: list[tuple[float, ...]] = []
        for p in seq:
            while len(out) >= 2 and _turn(out[-2], out[-1], p) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


#: Name of the base frame a preset defines when no URDF frame is on the floor under the root.
FLOOR_FRAME = "base_floor"


def floor_frame_name(model: pin.Model) -> str:
    """:data:`FLOOR_FRAME`, or it with a number when the URDF already has a frame of that name."""
    name, k = FLOOR_FRAME, 1
    while model.existFrame(name):
        name, k = f"{FLOOR_FRAME}_{k}", k + 1
    return name


def find_base(model: pin.Model, xml: str, urdf: Path, q: np.ndarray, arm_joints: set[int]) -> Base:
    """Base frame and footprint of ``model`` at ``q``; ``arm_joints``: joints of the arms and hands.

    The base frame is a frame a navigation stack drives, never one a joint moves: a root-level
    ``*footprint*`` frame, else the root link when it is on the floor, else the root link projected to
    the floor (a frame the preset defines: :attr:`Base.parent`, :attr:`Base.xyz`)."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    boxes, why = collision_boxes(model, xml, urdf, q, arm_joints)
    frames_z = [data.oMf[i].translation[2] for i, f in enumerate(model.frames) if f.parentJoint not in arm_joints]
    floor = float(min(frames_z) if boxes is None else min(boxes[..., 2].min(), min(frames_z)))
    root = next(i for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY)
    notes, warnings = [], list(screen_collisions(xml, urdf)[1])
    if boxes is not None and why:  # shapes left out of the footprint
        warnings.append(f"{why}: they are left out of the footprint")
    prints = [i for i, f in enumerate(model.frames) if f.parentJoint == 0 and "footprint" in f.name.lower()]
    root_z = float(data.oMf[root].translation[2]) - floor
    parent, xyz = None, None
    base_M = data.oMf[root]
    if prints:
        name, base_M = model.frames[prints[0]].name, data.oMf[prints[0]]
        notes.append(f"base frame '{name}': named as a footprint, on the root")
    elif root_z <= ON_FLOOR:
        name = model.frames[root].name
        notes.append(f"base frame '{name}': the root link, {root_z:.3f} m above the robot's lowest point")
    else:
        name, parent = floor_frame_name(model), model.frames[root].name
        # the floor point under the root's origin, in the root's axes (the root is level)
        depth = round(root_z, 3)
        xyz = (0.0, 0.0, -depth)
        base_M = data.oMf[root] * pin.SE3(np.eye(3), np.array(xyz))
        notes.append(
            f"base frame '{name}': no URDF frame on the floor under the root, so the preset defines one: the "
            f"root link '{parent}' projected to the floor, {depth:.3f} m below it (the robot's lowest point "
            "with the held joints as below); a frame that no joint moves, as a navigation stack drives it"
        )
    base = name
    B = base_M.inverse()
    if boxes is None:
        pts = np.array(
            [
                (B * data.oMf[i]).translation[:2]
                for i in range(len(model.frames))
                if model.frames[i].parentJoint not in arm_joints
            ]
        )
        radius = float(np.max(np.hypot(pts[:, 0], pts[:, 1]))) + RADIUS_MARGIN
        warnings.append(
            f"no collision geometry for the footprint ({why}); footprint_radius is the farthest "
            f"link origin + {RADIUS_MARGIN} m: measure the base"
        )
        return Base(base, None, round(radius, 3), notes, warnings, parent, xyz)
    # a shape of 1e300 m (a URDF typo) overflows to inf here: the outline is then refused by the
    # preset's own check, which names the footprint; numpy need not warn on the way
    with np.errstate(over="ignore", invalid="ignore"):
        flat = boxes.reshape(-1, 3) @ B.rotation.T + B.translation
        poly = hull(flat[:, :2])
        # rounded outwards to the millimetre, then the hull again: two corners within a millimetre
        # become one point (iCub's did: a footprint that repeats a point does not load)
        poly = hull(np.sign(poly) * np.ceil(np.abs(poly) * 1000) / 1000)
        encloses = len(poly) >= 3 and contains_origin(poly)
    if not encloses:
        radius = float(np.max(np.hypot(flat[:, 0], flat[:, 1])))
        warnings.append(
            "the collision shapes' outline does not surround the base frame's origin; footprint_radius "
            "is their farthest point: check the base frame"
        )
        return Base(base, None, round(radius + 0.005, 3), notes, warnings, parent, xyz)
    notes.append(
        f"footprint: convex hull of the floor projection of the bounding boxes of {len(boxes)} collision "
        "shapes the arms do not move"
    )
    return Base(base, poly, float(np.max(np.hypot(poly[:, 0], poly[:, 1]))), notes, warnings, parent, xyz)
