"""The kinematic tree of a URDF read for ``placement robots init``: arms, hands, torso and floor.

Rules (each guess is reported by the caller):

- *actuated* joints have one degree of freedom and are not mimic joints;
- *hand* joints are actuated joints named like fingers or grippers (:data:`HAND_WORDS`), and every
  joint below one; *leg* joints are named like legs or wheels (:data:`LEG_WORDS`);
- the remaining actuated joints form a tree; each of its leaves ends one chain, which runs up to
  (not including) the nearest joint with more than one branch. A chain of at least
  :data:`~placement.robots.spec.MIN_ARM_JOINTS` joints is an *arm* when its end rises at least
  :data:`ARM_HEIGHT` above the robot's lowest point somewhere over its joint ranges
  (:data:`REACH_SAMPLES` uniform configurations, the rest of the robot at the reference configuration):
  a lift at the bottom of its travel does not make an arm a leg; a leg's end stays near the floor;
- the actuated joints above the arms (lifts, torso joints) are *torso* joints, held fixed;
- arms are named left/right from the words in their joint and link names (``l_``, ``left``,
  ``LShoulder``, ``Hand L``), or from the side they are on.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from placement.robots.chain import ancestors
from placement.robots.spec import MIN_ARM_JOINTS

HAND_WORDS = (
    "finger",
    "gripper",
    "thumb",
    "hand",
    "knuckle",
    "palm",
    "claw",
    "jaw",
    "phalanx",
    "index",
    "middle",
    "ring",
    "little",
    "pinky",
    "tip",
)
LEG_WORDS = ("leg", "hip", "knee", "ankle", "foot", "wheel", "caster", "sole")
#: A chain whose end never rises this high above the lowest point of the robot [m] is a leg, not an arm.
ARM_HEIGHT = 0.5
#: Uniform configurations of each chain sampled to see what its end reaches.
REACH_SAMPLES = 300
LEFT, RIGHT = ("l", "left"), ("r", "right")


def words(name: str) -> list[str]:
    """Lower-case words of a name: split at non-letters and camel case (``LShoulderPitch`` -> l, shoulder,
    pitch)."""
    out = []
    for part in re.split(r"[^A-Za-z0-9]+", name):
        if re.fullmatch(r"[A-Za-z][0-9]+", part):  # an index (r0, t12), not the word "r"
            continue
        out += re.findall(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+", part)
    return [w.lower() for w in out]


def named_like(name: str, vocabulary: tuple[str, ...]) -> bool:
    """Whether a word of ``name`` starts with one of ``vocabulary`` (``fingertip`` is a finger)."""
    return any(w.startswith(v) for w in words(name) for v in vocabulary)


@dataclass
class Tree:
    """The analysed tree.

    Attributes:
        chains: {joint id of the chain's end: [joint ids base to tip]}, every candidate chain.
        arms: [joint ids base to tip] of the chains accepted as arms.
        rejected: [(joint names, reason)] chains that are not arms.
        torso: joint ids above the arms (held fixed), base first.
        hand: {last arm joint id: hand joint ids below it}.
        reach: {joint id of a chain's end: (highest [m] above the lowest point, farthest [m] from the
            root's vertical axis)} its end reaches over the sampled configurations.
    """

    chains: dict[int, list[int]]
    arms: list[list[int]]
    rejected: list[tuple[list[str], str]]
    torso: list[int]
    hand: dict[int, list[int]]
    reach: dict[int, tuple[float, float]] = field(default_factory=dict)


def children(model: pin.Model) -> dict[int, list[int]]:
    out: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        out[model.parents[j]].append(j)
    return out


def subtree(model: pin.Model, jid: int) -> list[int]:
    """``jid`` and every joint below it."""
    kids, out, todo = children(model), [], [jid]
    while todo:
        j = todo.pop()
        out.append(j)
        todo += kids[j]
    return out


def floor_height(model: pin.Model, data: pin.Data) -> float:
    """Lowest frame origin [m] in the root frame (after framesForwardKinematics)."""
    return float(min(data.oMf[i].translation[2] for i in range(len(model.frames))))


def end_reach(model: pin.Model, q: np.ndarray, chain: list[int], below: list[int]) -> tuple[float, float]:
    """(highest z [m] in the root frame, farthest [m] from the root's vertical axis) that the frames on
    the joints ``below`` (the chain's end and what it carries) reach over :data:`REACH_SAMPLES` seeded
    uniform configurations of ``chain`` (joint ids), the other joints at ``q``."""
    frames = [i for i, f in enumerate(model.frames) if f.parentJoint in set(below)]
    lim = []
    for j in chain:
        jm = model.joints[j]
        lo, hi = (
            (-np.pi, np.pi) if jm.nq == 2 else (model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q])
        )
        # a URDF's reversed or infinite limits are refused when the preset loads; sample something here
        lim.append((min(lo, hi), max(lo, hi)) if np.isfinite(lo) and np.isfinite(hi) else (-np.pi, np.pi))
    rng = np.random.default_rng(0)
    data = model.createData()
    high, far = -np.inf, 0.0
    root = data.oMi[0].translation[:2]
    for values in rng.uniform([lo for lo, _ in lim], [hi for _, hi in lim], size=(REACH_SAMPLES, len(chain))):
        qs = q.copy()
        for j, v in zip(chain, values):
            jm = model.joints[j]
            if jm.nq == 2:
                qs[jm.idx_q : jm.idx_q + 2] = np.cos(v), np.sin(v)
            else:
                qs[jm.idx_q] = v
        pin.forwardKinematics(model, data, qs)
        for i in frames:
            p = pin.updateFramePlacement(model, data, i).translation
            high = max(high, float(p[2]))
            far = max(far, float(np.hypot(*(p[:2] - root))))
    return high, far


def analyse(model: pin.Model, mimic: dict[str, str], q: np.ndarray) -> Tree:
    """Find the arms, torso and hands of ``model`` at configuration ``q``."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    floor = floor_height(model, data)
    actuated = {j for j in range(1, model.njoints) if model.joints[j].nv == 1 and model.names[j] not in mimic}
    hand = set()
    for j in range(1, model.njoints):
        if named_like(model.names[j], HAND_WORDS):
            hand.update(subtree(model, j))
    body = {j for j in actuated - hand if not named_like(model.names[j], LEG_WORDS)}

    def up(j: int) -> int:  # nearest body joint above j, 0 for none
        j = model.parents[j]
        while j > 0 and j not in body:
            j = model.parents[j]
        return j

    below = {j: [k for k in body if up(k) == j] for j in body | {0}}
    chains = {}
    for leaf in (j for j in body if not below[j]):
        chain, j = [leaf], up(leaf)
        while j > 0 and len(below[j]) == 1:
            chain.append(j)
            j = up(j)
        chains[leaf] = chain[::-1]
    arms, rejected, reach = [], [], {}
    for leaf, chain in sorted(chains.items()):
        names = [model.names[j] for j in chain]
        if len(chain) < MIN_ARM_JOINTS:
            rejected.append((names, f"{len(chain)} actuated joints (an arm needs {MIN_ARM_JOINTS})"))
            continue
        high, far = end_reach(model, q, chain, subtree(model, leaf))
        reach[leaf] = (high - floor, far)
        if high - floor < ARM_HEIGHT:
            rejected.append(
                (
                    names,
                    f"its end reaches at most {high - floor:.2f} m above the robot's lowest point over "
                    f"{REACH_SAMPLES} sampled configurations: a leg",
                )
            )
        else:
            arms.append(chain)
    torso = []
    for chain in arms:
        torso += [j for j in ancestors(model, chain[0])[1:] if j in actuated and j not in torso]
    hands = {chain[-1]: [j for j in subtree(model, chain[-1])[1:]] for chain in arms}
    return Tree(chains, arms, rejected, sorted(torso), hands, reach)


def side_of(model: pin.Model, chain: list[int], tip_y: float) -> tuple[str | None, str]:
    """("left" | "right" | None, how it was decided) for an arm from the words of its joint and link
    names, else from the side of the base its tip is on at the reference configuration (``tip_y`` [m])."""
    names = [model.names[j] for j in chain]
    names += [f.name for f in model.frames if f.parentJoint in chain]
    votes = {"left": 0, "right": 0}
    for n in names:
        w = words(n)
        votes["left"] += any(x in LEFT for x in w)
        votes["right"] += any(x in RIGHT for x in w)
    if votes["left"] != votes["right"]:
        return max(votes, key=lambda side: votes[side]), "from its joint and link names"
    if abs(tip_y) > 0.02:
        return ("left" if tip_y > 0 else "right"), "from the side of the base its hand is on (names do not say)"
    return None, "names and position do not say which side"


def arm_names(model: pin.Model, arms: list[list[int]], tip_ys: list[float]) -> tuple[list[str], list[str]]:
    """(names, notes): left/right for two arms on opposite sides, ``arm`` for a single arm, else
    ``arm_0``, ``arm_1``, ..."""
    sides = [side_of(model, c, y) for c, y in zip(arms, tip_ys)]
    if len(arms) == 2 and {s for s, _ in sides} == {"left", "right"}:
        return [s for s, _ in sides if s is not None], [f"{s} arm: {how}" for s, how in sides]
    if len(arms) == 1:
        return ["arm"], []
    return [f"arm_{i}" for i in range(len(arms))], ["arms named by order: their names do not say left/right"]
