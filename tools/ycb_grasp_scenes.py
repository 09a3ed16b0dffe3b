"""The building tidy-up scenes with a published grasp set: each YCB object grasped as DexYCB's grasps say.

The grasps: ``examples/buildings/ycb_grasps/ycb_farthest_100_grasps.json``, the objects of our
building scenes from ``assets/ycb_farthest_100_grasps.json`` of NVlabs/dex-ycb-toolkit (commit
a981fb3e, GPL-3.0; the poses as published, the file written compactly): per YCB object, 100 grasps
of a Franka Panda hand as (4, 4) poses of the hand frame in the object model's frame [m]. The conversion to a scene's ``grasps`` (version 2, TCP
trajectories in the object frame, see docs/scenes.md):

* the Panda hand frame has z along the approach and x along the fingers' motion; our canonical TCP
  has z along the approach and y across the fingers, at the fingertips' centre: TCP = hand pose x
  (turn of +90 deg about z, then PANDA_TCP_DEPTH m along z);
* the model frame is the object's centre with its axes along the object's edges (checked: every
  grasp's TCP lies within the box of the object's size plus TCP_SLACK m); where the model's axes
  are not the scene's ``size`` axes, MODEL_TO_OBJECT turns them (the cracker box: the model's y is
  its 0.16 m edge, the scene's x);
* each grasp is a trajectory of two poses: the pre-pose PRE_POSE m back along the approach, then
  the grasp; named ``dexycb-NN`` by its index in the set;
* the first PER_OBJECT grasps of each object's 100 (``--per-object``): a place step has a candidate
  per grasp and place yaw, each with a manipulation map per arm and torso setting, so planning time
  grows with the grasps (docs/bench/buildings.md gives both).

    python tools/ycb_grasp_scenes.py [--per-object N] [--check]

writes ``examples/buildings/<building>/tidy_up_ycb.yaml`` from each ``tidy_up.yaml`` beside it
(``--check``: exit 1 if one would change). Those files hold the GPL-3.0 grasps: see
examples/buildings/README.md.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
BUILDINGS = ROOT / "examples" / "buildings"
GRASP_FILE = BUILDINGS / "ycb_grasps" / "ycb_farthest_100_grasps.json"

#: Our scenes' object names -> the YCB model names of the grasp set.
YCB_NAMES = {
    "cracker_box": "003_cracker_box",
    "soup_can": "005_tomato_soup_can",
    "mustard": "006_mustard_bottle",
    "pudding_box": "008_pudding_box",
    "mug": "025_mug",
}
#: Turn [rad] about z from the model's axes to the scene object's (the axes of its ``size``).
MODEL_TO_OBJECT = {"cracker_box": -math.pi / 2}
#: The Panda hand's fingertip centre along its approach axis [m] (franka_description: the finger
#: joints 0.0584 m from the hand frame, the pads' centre 0.045 m beyond).
PANDA_TCP_DEPTH = 0.1034
#: Pre-pose distance back along the approach [m], as the generated grasps (docs/scenes.md).
PRE_POSE = 0.10
#: How far [m] a grasp's TCP may lie outside the object's box (grasps near an edge close there).
TCP_SLACK = 0.03
#: Grasps per object written into the scenes (of the set's 100).
PER_OBJECT = 20


def turn_z(angle: float) -> np.ndarray:
    """(4, 4) turn by ``angle`` [rad] about z."""
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def along_z(d: float) -> np.ndarray:
    """(4, 4) move by ``d`` [m] along z."""
    T = np.eye(4)
    T[2, 3] = d
    return T


#: Panda hand frame -> canonical TCP frame.
HAND_TO_TCP = turn_z(math.pi / 2) @ along_z(PANDA_TCP_DEPTH)


def tcp_poses(hand: np.ndarray, model_to_object: float) -> tuple[np.ndarray, np.ndarray]:
    """(pre-pose, grasp) (4, 4) TCP poses in the scene object's frame of a Panda hand pose ``hand``
    (4, 4) in the model frame; ``model_to_object``: the turn [rad] about z from model to object axes."""
    grasp = turn_z(model_to_object) @ hand @ HAND_TO_TCP
    return grasp @ along_z(-PRE_POSE), grasp


def pose7(T: np.ndarray) -> list[float]:
    """(4, 4) -> [x, y, z, qx, qy, qz, qw] (unit quaternion, w >= 0), rounded to 1e-9."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(T[:3, :3]).as_quat()
    q = q / np.linalg.norm(q) * (1.0 if q[3] >= 0 else -1.0)
    return [round(float(v), 9) for v in (*T[:3, 3], *q)]


def object_grasps(name: str, size: list[float], hands: list[list[list[float]]]) -> list[dict[str, object]]:
    """The ``grasps`` of object ``name`` (edge lengths ``size`` [m]) from its set's hand poses;
    ValueError when a TCP lies farther than TCP_SLACK outside the box (the axes would be wrong)."""
    half = np.asarray(size, dtype=float) / 2 + TCP_SLACK
    out: list[dict[str, object]] = []
    for k, hand in enumerate(hands):
        pre, grasp = tcp_poses(np.asarray(hand, dtype=float), MODEL_TO_OBJECT.get(name, 0.0))
        if np.any(np.abs(grasp[:3, 3]) > half):
            raise ValueError(f"{name}: grasp {k}'s TCP {grasp[:3, 3].round(3)} is outside its box {size}")
        out.append({"name": f"dexycb-{k:02d}", "poses": [pose7(pre), pose7(grasp)]})
    return out


class Flow(list):  # type: ignore[type-arg]
    """A list YAML writes on one line."""


def _flow(dumper: yaml.SafeDumper, data: Flow) -> yaml.Node:
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=True)


yaml.SafeDumper.add_representer(Flow, _flow)


def flowed(x: object) -> object:
    """``x`` with its lists of numbers written on one line."""
    if isinstance(x, dict):
        return {k: flowed(v) for k, v in x.items()}
    if isinstance(x, list):
        return Flow(x) if all(isinstance(v, (int, float)) for v in x) else [flowed(v) for v in x]
    return x


def scene_text(source: Path, grasp_set: dict[str, list[list[list[float]]]], per_object: int = PER_OBJECT) -> str:
    """The scene ``source`` as version 2 with every YCB object's first ``per_object`` grasps of ``grasp_set``."""
    doc = yaml.safe_load(source.read_text())
    doc["version"] = 2
    for obj in doc["objects"]:
        hands = grasp_set[YCB_NAMES[obj["name"]]][:per_object]
        obj["grasps"] = object_grasps(obj["name"], obj["size"], hands)
    doc = flowed(doc)
    head = (
        f"# {source.parent.name}/{source.name} with the first {per_object} grasps per object of the published\n"
        "# DexYCB grasp set (GPL-3.0, see examples/buildings/README.md), written by\n"
        "# tools/ycb_grasp_scenes.py: do not edit.\n"
    )
    return head + yaml.safe_dump(doc, sort_keys=False, width=200)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-object", type=int, default=PER_OBJECT, help="grasps per object (of 100)")
    parser.add_argument("--check", action="store_true", help="exit 1 if a scene would change")
    args = parser.parse_args()
    grasp_set = json.loads(GRASP_FILE.read_text())
    stale = []
    for source in sorted(BUILDINGS.glob("*/tidy_up.yaml")):
        target = source.with_name("tidy_up_ycb.yaml")
        text = scene_text(source, grasp_set, args.per_object)
        if target.exists() and target.read_text() == text:
            continue
        if args.check:
            stale.append(str(target.relative_to(ROOT)))
        else:
            target.write_text(text)
            print(f"wrote {target.relative_to(ROOT)}", file=sys.stderr)
    if stale:
        print(f"out of date: {', '.join(stale)} (run python tools/ycb_grasp_scenes.py)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
