"""Why no arm and grasp carries an object from its pick to its place, in one shared explanation.

A transfer keeps the arm and the grasp from the pick to the place. When no (arm, grasp) pair that
picks the object also sets it down, every method names the place step and says, per pair, what
stops it there: the gripper alone colliding at every place pose, the maps keeping the threshold at
none, or IK and the collision check rejecting what the maps allow.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence

from placement.planning.context import PlanningContext
from placement.planning.problems import Option, Step

#: An (arm, grasp) pair.
Pair = tuple[str, str | None]


def excluded_words(failed: Mapping[Pair, str]) -> str:
    """ "arm left: top, top-flipped; arm right: top" for the (arm, grasp) pairs of ``failed``."""
    arms: dict[str, list[str]] = {}
    for arm, grasp in sorted(failed, key=lambda p: (p[0], str(p[1]))):
        arms.setdefault(arm, []).append(str(grasp))
    return "; ".join(f"arm {a}: {', '.join(g)}" for a, g in arms.items())


def unreached_words(place_options: Sequence[Option], pairs: set[Pair]) -> dict[Pair, str]:
    """Per pair of ``pairs`` whose every option among ``place_options`` (a place step's) the gripper
    alone rules out: that collision in words (the commonest culprit); the other pairs are left out
    (the maps keep the threshold at none of their place poses)."""
    out: dict[Pair, str] = {}
    for pair in pairs:
        mine = [o for o in place_options if (o.arm, o.candidate.grasp) == pair]
        if mine and all(o.blocked is not None for o in mine):
            culprit = Counter(o.blocked for o in mine).most_common(1)[0][0]
            out[pair] = f"the gripper collides at every place pose ({len(mine)}), mostly {culprit}"
    return out


def transfer_reason(
    ctx: PlanningContext, pick: Step, place: Step, failed: Mapping[Pair, str], place_options: Sequence[Option] = ()
) -> str:
    """Why no (arm, grasp) of ``pick`` sets its object down at ``place``, in one line. ``failed``: per
    pair that picks, what failed at the place ("": the maps reach no place pose of it; then
    ``place_options`` say whether its gripper collides at every one)."""
    blocked = unreached_words(place_options, {p for p, r in failed.items() if not r})
    unreached = {p: r for p, r in failed.items() if not r and p not in blocked}
    tried = {p: r for p, r in failed.items() if r}
    parts = []
    if unreached:
        arms = sorted({a for a, _ in unreached})
        parts.append(
            f"{excluded_words(unreached)}: no base placement reaches a place pose with the map threshold "
            + ", ".join(ctx.threshold_words(a) + (f" (arm {a})" if len(arms) > 1 else "") for a in arms)
        )
    for p in sorted(blocked, key=lambda p: (p[0], str(p[1]))):
        parts.append(f"arm {p[0]}, grasp {p[1]}: {blocked[p]}")
    for p, r in tried.items():
        parts.append(f"arm {p[0]}, grasp {p[1]}: picked, but the place failed: {r}")
    return (
        f"no grasp of '{pick.target}' lets the arm that picks it set it down at '{place.target}' "
        f"(a transfer keeps the arm and the grasp): {'; '.join(parts)}"
    )


def transfer_diagnosis(failed: Mapping[Pair, str], place_options: Sequence[Option] = ()) -> list[dict[str, str | None]]:
    """Per (arm, grasp) pair: why its place failed (JSON)."""
    blocked = unreached_words(place_options, {p for p, r in failed.items() if not r})
    return [
        {"arm": a, "grasp": g, "failed": r or blocked.get((a, g), "no place pose keeps the map threshold")}
        for (a, g), r in sorted(failed.items(), key=lambda kv: (kv[0][0], str(kv[0][1])))
    ]


__all__ = ["Pair", "excluded_words", "transfer_diagnosis", "transfer_reason", "unreached_words"]
