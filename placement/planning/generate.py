"""Seeded table-clearing benchmark scenes (SPEC section 8), written in the scene format.

Layout (metres): a 10 x 8 room with walls; three pick tables in a row centred at
(5, 4), each ``table_size`` = (length along the row, depth); two place
tables (0.5 m square for the PR2, 0.8 m otherwise) at (1.6, 1.6) and (8.4, 1.6) with the place location 0.1 m above their top (all five
tables are ``table: true``: surfaces objects stand on, where the ``fixed`` baseline parks);
``objects`` boxes at random on the pick area, picked in order and placed
alternately on the two place tables; a random start pose in the free band along
the north wall. The obstacle variant adds boxes beside the pick tables that block
some placements, but never the table edge in front of an object on the side it is
nearest to (so every scene can be solved). Scene k of seed s depends only on (s, k).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from ..errors import PlacementError
from .scene import parse_scene

ROOM = (10.0, 8.0)
TABLE_HEIGHT = 0.75
#: pick table (length, depth) per robot preset [m]; the PR2 reaches ~0.37 m into a table (SPEC section 8)
TABLE_SIZES = {"pr2": (0.8, 0.6), "armar6": (0.8, 0.8)}
#: place table edge per robot [m]: the PR2 parked at its footprint radius reaches ~0.26 m into a table
PLACE_TABLE_SIZES = {"pr2": 0.5, "armar6": 0.8}
SHADOW = 0.55  # [m] half-width of the pick-table edge a crate blocks (crate half-size + arm clearance)
OBJECT_SIZES = [(0.06, 0.06, 0.10), (0.05, 0.12, 0.10), (0.07, 0.07, 0.12), (0.04, 0.09, 0.08)]


def generate_scene(seed: int, index: int = 0, *, objects: int = 6, obstacles: bool = False,
                   preset: str = "pr2", table_size=None, maps: str | None = None) -> dict:
    """One scene as a scene-file mapping (validated)."""
    if objects < 1:
        raise PlacementError(f"object count must be positive, got {objects}")
    rng = np.random.default_rng([int(seed), int(index), int(obstacles)])
    length, depth = table_size or TABLE_SIZES.get(preset, (0.8, 0.8))
    place_edge = PLACE_TABLE_SIZES.get(preset, 0.8)
    w, h = ROOM
    cx, cy = 5.0, 4.0
    obs = [
        {"name": "wall_south", "box": {"center": [w / 2, 0.05, 1.0], "size": [w, 0.1, 2.0]}},
        {"name": "wall_north", "box": {"center": [w / 2, h - 0.05, 1.0], "size": [w, 0.1, 2.0]}},
        {"name": "wall_west", "box": {"center": [0.05, h / 2, 1.0], "size": [0.1, h, 2.0]}},
        {"name": "wall_east", "box": {"center": [w - 0.05, h / 2, 1.0], "size": [0.1, h, 2.0]}},
    ]
    for k in range(3):
        obs.append({"name": f"pick_table_{k + 1}", "table": True,
                    "box": {"center": [cx + (k - 1) * length, cy, TABLE_HEIGHT / 2],
                            "size": [length, depth, TABLE_HEIGHT]}})
    places = []
    for name, (x, y) in (("a", (1.6, 1.6)), ("b", (8.4, 1.6))):
        obs.append({"name": f"place_table_{name}", "table": True, "box": {"center": [x, y, TABLE_HEIGHT / 2],
                                                           "size": [place_edge, place_edge, TABLE_HEIGHT]}})
        places.append({"name": f"place_{name}", "position": [x, y, TABLE_HEIGHT + 0.10]})
    if obstacles:
        # two crates beside the long sides of the pick row, each hiding part of one side
        for k in range(2):
            side = 1.0 if rng.random() < 0.5 else -1.0
            x = cx + rng.uniform(-1.5 * length + 0.3, 1.5 * length - 0.3)
            y = cy + side * (depth / 2 + 0.35)
            obs.append({"name": f"crate_{k + 1}", "box": {"center": [round(x, 3), round(y, 3), 0.25],
                                                          "size": [0.5, 0.5, 0.5]}})
    objs = []
    margin = 0.06
    crates = [o["box"]["center"] for o in obs if o["name"].startswith("crate")]
    for k in range(objects):
        size = OBJECT_SIZES[int(rng.integers(len(OBJECT_SIZES)))]
        for _ in range(1000):
            x = cx + rng.uniform(-1.5 * length + margin, 1.5 * length - margin)
            y = cy + rng.uniform(-depth / 2 + margin, depth / 2 - margin)
            # a crate may block a side, but never the side an object is nearest to within
            # SHADOW of its x: every object stays reachable from its own side
            if not any((c[1] - cy) * (y - cy) > 0 and abs(c[0] - x) < SHADOW for c in crates):
                break
        objs.append({"name": f"object_{k + 1}", "position": [round(x, 3), round(y, 3), TABLE_HEIGHT + size[2] / 2],
                     "yaw": round(float(rng.uniform(-math.pi, math.pi)), 4), "size": list(size)})
    start = [round(float(rng.uniform(1.0, w - 1.0)), 3), round(float(rng.uniform(h - 1.8, h - 0.8)), 3),
             round(float(rng.uniform(-math.pi, math.pi)), 4)]
    doc = {"version": 1, "resolution": 0.05, "bounds": [0.0, 0.0, w, h],
           "robot": {"preset": preset, "start": start}}
    if maps:
        doc["maps"] = maps
    doc.update({"obstacles": obs, "objects": objs, "place_locations": places,
                "task": [{"pick": o["name"], "place": places[k % 2]["name"]} for k, o in enumerate(objs)]})
    parse_scene(doc, ".", "generated")  # the generator never writes a scene the planner would reject
    return doc


def write_scenes(out_dir, seed: int, count: int, **kwargs) -> list[Path]:
    """Write ``count`` scenes of ``seed`` to ``out_dir``; returns their paths."""
    if count < 1:
        raise PlacementError(f"scene count must be positive, got {count}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tag = "obstacles" if kwargs.get("obstacles") else "free"
    paths = []
    for k in range(count):
        path = out / f"scene_{tag}_s{seed}_{k:03d}.yaml"
        path.write_text(yaml.safe_dump(generate_scene(seed, k, **kwargs), sort_keys=False))
        paths.append(path)
    return paths
