"""Seeded table-clearing benchmark scenes (docs/evaluation.md), written in the scene format.

Layout (metres): a 10 x 8 room with walls; three pick tables in a row centred at
(5, 4), each ``table_size`` = (length along the row, depth); two square place
tables (edge from the robot's footprint, :func:`place_table_edge`) at (1.6, 1.6) and (8.4, 1.6) with the place location 0.1 m above their top (all five
tables are ``table: true``: surfaces objects stand on, where the ``fixed`` baseline parks);
``objects`` boxes at random on the pick area, picked in order and placed
alternately on the two place tables; a random start pose in the free band along
the north wall. The obstacle variant adds boxes beside the pick tables that block
some placements, but never the table edge in front of an object on the side it is
nearest to (so every scene can be solved). Scene k of seed s depends only on (s, k).

Gripper clearance: the footprints (yawed rectangles) of any two objects are at least
:data:`GRIPPER_CLEARANCE` (0.10 m) apart edge to edge, so a gripper fits between them. The PR2's
fingers and palm (as the collision check holds them, finger joints at 0) at a top grasp reach at
most 0.041 m beyond the grasped object's footprint
(finger links +-0.056 m across, +-0.028 m along, plus the planner's 5 mm collision padding, on the
narrowest object); the rest is room for the wrist and for grasps at other base yaws. Before the
rule the generator put objects 5 cm apart centre to centre, where no top grasp was collision-free.

Invariants (tested over many seeds): every object's centre lies on the pick area at least
``MARGIN`` from its edge (a yawed footprint corner may overhang by up to 5 mm: the largest
half-diagonal, 0.065 m, minus the margin), outside every crate, and outside every crate's
``SHADOW`` on the object's own side; every two objects' footprints are at least ``GRIPPER_CLEARANCE``
apart (so a top grasp of every object is collision-free, checked with the PR2's gripper shapes in
tests/test_generate.py); place locations are above their place tables. When 1000
positions for an object are all shadowed or too close to an earlier object (more objects than the
tables hold: up to 12 always fit the PR2's default tables), the scene is drawn again from its seed
on pick tables 1.25 times as long, up to 2 m (scenes that fit are as they were; a table length the
caller gives is kept); when the tables cannot hold them, the generator raises :class:`~placement.errors.PlacementError` naming the scene and
the object instead of keeping a blocked position.

Paths: :func:`write_scenes` takes a preset path and ``maps`` as seen from the current directory
and records them relative to the scene file (an absolute path stays absolute), so a scene loads
from any working directory.
"""

from __future__ import annotations

import math
import os
from functools import cache
from pathlib import Path
from typing import Any, cast

import numpy as np
import numpy.typing as npt
import yaml

from placement.errors import PlacementError
from placement.evaluation.outdir import output_dir
from placement.planning.settings import PlannerConfig
from placement.robots import load_robot
from placement.robots.preset import builtin_presets
from placement.scene import parse_scene

ROOM = (10.0, 8.0)
TABLE_HEIGHT = 0.75
#: pick table (length, depth) per robot preset [m]; the PR2 reaches ~0.37 m into a table
TABLE_SIZES = {"pr2": (0.8, 0.6), "armar6": (0.8, 0.8)}
#: horizontal distance [m] from the base origin to a place location the arm reaches comfortably,
#: per robot: the place table's centre is put there when the base parks facing its side (the
#: ``fixed`` standoff), see :func:`place_table_edge`. PR2: parked 0.49 m from a 0.5 m table as a
#: 0.47 m circle, it had its place locations 0.725 m away (0.74 m before snapping to the 5 cm
#: grid); 0.70 m puts them 0.72 m away with its real footprint (0.76 m made IK fail)
PLACE_REACH = {"pr2": 0.70}
DEFAULT_PLACE_EDGE = 0.8  # [m] place table edge of other presets
SHADOW = 0.55  # [m] half-width of the pick-table edge a crate blocks (crate half-size + arm clearance)
MARGIN = 0.06  # [m] least distance of an object's centre from the pick area's edge
#: least edge-to-edge distance [m] of two objects' footprints: room for a gripper between them (module doc)
GRIPPER_CLEARANCE = 0.10
OBJECT_SIZES = [(0.06, 0.06, 0.10), (0.05, 0.12, 0.10), (0.07, 0.07, 0.12), (0.04, 0.09, 0.08)]
TRIES = 1000  # random positions tried per object before the scene is given up
#: upper bounds of ``objects`` per scene and scenes per call: a benchmark, not a stress test
MAX_OBJECTS = 50
MAX_SCENES = 1000
#: pick table length and depth bounds [m]: crates need 0.2 m of length, objects 2 * MARGIN of depth,
#: and up to 2 m the row stays clear of the walls, the place tables and the start band
TABLE_LENGTH = (0.2, 2.0)
#: The pick tables grow by this factor (up to the longest) while the objects do not fit on them.
GROW = 1.25
TABLE_DEPTH = (2 * MARGIN, 2.0)
MAX_SEED = 2**63 - 1  # seeds are 0 .. MAX_SEED (numpy's SeedSequence takes any; YAML/JSON keep int64 exact)


@cache
def place_table_edge(preset: str) -> float:
    """Edge of the square place tables [m]: twice what is left of the robot's :data:`PLACE_REACH`
    after the ``fixed`` standoff (the footprint's half-depth, a round base's radius, plus
    ``fixed_margin``), rounded to the centimetre; :data:`DEFAULT_PLACE_EDGE` for other robots."""
    if preset not in PLACE_REACH:
        return DEFAULT_PLACE_EDGE
    robot = load_robot(preset)
    half_depth = robot.footprint_radius if robot.footprint is None else float(robot.footprint[:, 0].max())
    return round(2 * (PLACE_REACH[preset] - half_depth - PlannerConfig().fixed_margin), 2)


def footprint(x: float, y: float, yaw: float, size: tuple[float, ...]) -> npt.NDArray[np.float64]:
    """(4, 2) corners [m], counter-clockwise, of a box's footprint: centre (x, y) [m], ``yaw`` [rad],
    ``size`` (length, width, ...) [m] along its own axes."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * (size[0] / 2, size[1] / 2)
    return cast("npt.NDArray[np.float64]", local @ np.array([[c, s], [-s, c]]) + (x, y))


def footprint_gap(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> float:
    """Edge-to-edge distance [m] of two convex polygons (k, 2) given counter-clockwise; 0 when they overlap."""

    def separated(
        p: npt.NDArray[np.float64], q: npt.NDArray[np.float64]
    ) -> bool:  # some edge of p has every corner of q strictly outside it
        edges = np.roll(p, -1, axis=0) - p
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
        return bool(np.any(np.min(np.einsum("ej,qej->qe", normals, q[:, None] - p[None]), axis=0) > 0))

    if not (separated(a, b) or separated(b, a)):
        return 0.0

    def corner_to_edges(
        p: npt.NDArray[np.float64], q: npt.NDArray[np.float64]
    ) -> float:  # least distance of q's corners to p's edges
        start, d = p, np.roll(p, -1, axis=0) - p
        t = np.clip(np.einsum("qej,ej->qe", q[:, None] - start[None], d) / np.einsum("ej,ej->e", d, d), 0, 1)
        return float(np.min(np.linalg.norm(q[:, None] - (start[None] + t[..., None] * d[None]), axis=2)))

    return min(corner_to_edges(a, b), corner_to_edges(b, a))


def check_counts(seed: int, objects: int, count: int = 1) -> None:
    """Raise :class:`PlacementError` unless seed, objects and count are within their bounds."""
    for name, value, lo, hi in (
        ("seed", seed, 0, MAX_SEED),
        ("objects", objects, 1, MAX_OBJECTS),
        ("count", count, 1, MAX_SCENES),
    ):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
            raise PlacementError(f"{name} must be a whole number from {lo} to {hi}, got {value!r}")


def generate_scene(
    seed: int,
    index: int = 0,
    *,
    objects: int = 6,
    obstacles: bool = False,
    preset: str = "pr2",
    table_size: tuple[float, float] | None = None,
    maps: str | None = None,
) -> dict[str, Any]:
    """Scene ``index`` of ``seed`` as a scene-file mapping (validated; paths as given, from the cwd).

    ``table_size``: pick table (length, depth) [m] (default per preset, ``TABLE_SIZES``); the
    preset's length grows (up to 2 m) while the objects do not fit, another length is kept.
    Raises :class:`PlacementError` for out-of-bounds counts or when an object finds no free position.
    """
    check_counts(seed, objects)
    length, depth = table_size or TABLE_SIZES.get(preset, (0.8, 0.8))
    for name, value, (lo, hi) in (("length", length, TABLE_LENGTH), ("depth", depth, TABLE_DEPTH)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
            raise PlacementError(f"table_size: {name} must be from {lo} to {hi} m, got {value!r}")
    # the preset's length grows when the objects do not fit; a length of the caller's is kept
    grow = length == TABLE_SIZES.get(preset, (0.8, 0.8))[0]
    while True:
        try:
            return _scene(seed, index, objects, obstacles, preset, float(length), float(depth), maps)
        except _Crowded as exc:
            if not grow:
                raise PlacementError(
                    f"{exc} (pick tables {length} x {depth} m too short for {objects} objects)"
                ) from None
            if length >= TABLE_LENGTH[1]:
                raise PlacementError(f"{exc} (pick tables {length} x {depth} m, the longest, too short)") from None
            # more objects than the tables hold: longer pick tables, the scene drawn again from its seed
            length = min(round(length * GROW, 3), TABLE_LENGTH[1])


class _Crowded(Exception):
    """An object found no free position on the pick tables."""


def _scene(
    seed: int, index: int, objects: int, obstacles: bool, preset: str, length: float, depth: float, maps: str | None
) -> dict[str, Any]:
    """The scene of :func:`generate_scene` on pick tables of ``length`` x ``depth`` [m]; _Crowded when
    an object finds no free position."""
    rng = np.random.default_rng([int(seed), int(index), int(obstacles)])
    place_edge = place_table_edge(preset)
    w, h = ROOM
    cx, cy = 5.0, 4.0
    obs: list[dict[str, Any]] = [
        {"name": "wall_south", "box": {"center": [w / 2, 0.05, 1.0], "size": [w, 0.1, 2.0]}},
        {"name": "wall_north", "box": {"center": [w / 2, h - 0.05, 1.0], "size": [w, 0.1, 2.0]}},
        {"name": "wall_west", "box": {"center": [0.05, h / 2, 1.0], "size": [0.1, h, 2.0]}},
        {"name": "wall_east", "box": {"center": [w - 0.05, h / 2, 1.0], "size": [0.1, h, 2.0]}},
    ]
    for k in range(3):
        obs.append(
            {
                "name": f"pick_table_{k + 1}",
                "table": True,
                "box": {"center": [cx + (k - 1) * length, cy, TABLE_HEIGHT / 2], "size": [length, depth, TABLE_HEIGHT]},
            }
        )
    places: list[dict[str, Any]] = []
    for name, (x, y) in (("a", (1.6, 1.6)), ("b", (8.4, 1.6))):
        obs.append(
            {
                "name": f"place_table_{name}",
                "table": True,
                "box": {"center": [x, y, TABLE_HEIGHT / 2], "size": [place_edge, place_edge, TABLE_HEIGHT]},
            }
        )
        places.append({"name": f"place_{name}", "position": [x, y, TABLE_HEIGHT + 0.10]})
    if obstacles:
        # two crates beside the long sides of the pick row, each hiding part of one side
        for k in range(2):
            side = 1.0 if rng.random() < 0.5 else -1.0
            x = cx + rng.uniform(-1.5 * length + 0.3, 1.5 * length - 0.3)
            y = cy + side * (depth / 2 + 0.35)
            obs.append(
                {"name": f"crate_{k + 1}", "box": {"center": [round(x, 3), round(y, 3), 0.25], "size": [0.5, 0.5, 0.5]}}
            )
    objs: list[dict[str, Any]] = []
    placed: list[
        tuple[tuple[float, float], float, npt.NDArray[np.float64]]
    ] = []  # (centre, bounding radius, footprint corners)
    crates = [o["box"]["center"] for o in obs if o["name"].startswith("crate")]
    for k in range(objects):
        size = OBJECT_SIZES[int(rng.integers(len(OBJECT_SIZES)))]
        for _ in range(TRIES):
            x = cx + rng.uniform(-1.5 * length + MARGIN, 1.5 * length - MARGIN)
            y = cy + rng.uniform(-depth / 2 + MARGIN, depth / 2 - MARGIN)
            # a crate may block a side, but never the side an object is nearest to within
            # SHADOW of its x: every object stays reachable from its own side
            if any((c[1] - cy) * (y - cy) > 0 and abs(c[0] - x) < SHADOW for c in crates):
                continue
            x, y = round(x, 3), round(y, 3)  # the clearance holds for the position as written
            # the yaw is drawn after the position as before the clearance rule, so scenes
            # whose objects were already apart keep their random numbers
            yaw = round(float(rng.uniform(-math.pi, math.pi)), 4)
            corners = footprint(x, y, yaw, size)
            # bounding circles first: the exact gap only for objects that could be too close
            near = [q for q in placed if math.dist((x, y), q[0]) < math.hypot(*size[:2]) / 2 + q[1] + GRIPPER_CLEARANCE]
            if all(footprint_gap(corners, q[2]) >= GRIPPER_CLEARANCE for q in near):
                break
        else:
            raise _Crowded(
                f"scene {index} of seed {seed}: object_{k + 1} found no position free of the "
                f"crates' shadows and {GRIPPER_CLEARANCE} m from the other objects in {TRIES} tries"
            )
        placed.append(((x, y), math.hypot(*size[:2]) / 2, corners))
        objs.append(
            {"name": f"object_{k + 1}", "position": [x, y, TABLE_HEIGHT + size[2] / 2], "yaw": yaw, "size": list(size)}
        )
    start = [
        round(float(rng.uniform(1.0, w - 1.0)), 3),
        round(float(rng.uniform(h - 1.8, h - 0.8)), 3),
        round(float(rng.uniform(-math.pi, math.pi)), 4),
    ]
    doc: dict[str, Any] = {
        "version": 1,
        "resolution": 0.05,
        "bounds": [0.0, 0.0, w, h],
        "robot": {"preset": preset, "start": start},
    }
    if maps:
        doc["maps"] = maps
    doc.update(
        {
            "obstacles": obs,
            "objects": objs,
            "place_locations": places,
            "task": [{"pick": o["name"], "place": places[k % 2]["name"]} for k, o in enumerate(objs)],
        }
    )
    parse_scene(doc, ".", "generated")  # the generator never writes a scene the planner would reject
    return doc


def scene_path(value: str, scene_dir: Path) -> str:
    """``value`` (a path from the current directory) as the scene file in ``scene_dir`` must record it.

    An absolute path stays as it is; a relative one becomes relative to ``scene_dir``, computed
    lexically as the scene loader resolves it, and keeps a ``/`` so that it reads as a path.
    """
    if os.path.isabs(os.path.expanduser(value)):
        return value
    rel = os.path.relpath(os.path.abspath(value), os.path.abspath(scene_dir))
    return rel if ("/" in rel or rel.endswith((".yaml", ".yml"))) else "./" + rel


def write_scenes(out_dir: Path | str, seed: int, count: int, **kwargs: Any) -> list[Path]:
    """Write ``count`` scenes of ``seed`` to ``out_dir``; returns their paths.

    ``kwargs`` go to :func:`generate_scene`; a preset path and ``maps`` are taken from the current
    directory and written relative to ``out_dir``. ``out_dir`` is created and probed first, and
    every scene is generated before the first file is written (a failure leaves no new directory).
    """
    check_counts(seed, kwargs.get("objects", 6), count)
    out = Path(out_dir)
    with output_dir(out, "scene directory"):
        docs = [generate_scene(seed, k, **kwargs) for k in range(count)]
        preset = kwargs.get("preset", "pr2")
        for doc in docs:
            if preset not in builtin_presets():
                doc["robot"]["preset"] = scene_path(preset, out)
            if doc.get("maps"):
                doc["maps"] = scene_path(doc["maps"], out)
        tag = "obstacles" if kwargs.get("obstacles") else "free"
        paths = [out / f"scene_{tag}_s{seed}_{k:03d}.yaml" for k in range(count)]
        for path, doc in zip(paths, docs):
            path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return paths
