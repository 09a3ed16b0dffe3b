"""Hypothesis strategies shared by the parser property tests: random documents and mutations of
valid ones (a value replaced, scaled or nudged, a key deleted or added, a list item duplicated or dropped)."""

from __future__ import annotations

import copy
import math

from hypothesis import strategies as st

#: leaves a YAML or JSON document can hold, including the awkward ones
LEAVES = (
    st.none()
    | st.booleans()
    | st.integers(-(10**9), 10**9)
    | st.sampled_from([0, 1, -1, 2**63, 10**400 // 10**399])
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.sampled_from([1e308, -0.0, 1e-320, math.pi])
    | st.text(max_size=6)
    | st.sampled_from(["", " ", "pr2", "right", "box", "x" * 300])
)


def documents(keys=("name", "box", "x")) -> st.SearchStrategy:
    """Random nested documents whose mapping keys are drawn from ``keys`` (plus random text)."""
    key = st.sampled_from(list(keys)) | st.text(max_size=4)
    return st.recursive(LEAVES, lambda c: st.lists(c, max_size=4) | st.dictionaries(key, c, max_size=5), max_leaves=25)


def _paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, prefix + (i,))


def _at(doc, path):
    for k in path:
        doc = doc[k]
    return doc


@st.composite
def mutated(draw, base: dict, keys=("name",), max_mutations: int = 3) -> dict:
    """``base`` (a valid document) with 1 .. ``max_mutations`` random mutations."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, max_mutations))):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, last = _at(doc, path[:-1]), path[-1]
        kind = draw(st.sampled_from(["replace", "delete", "add_key", "duplicate", "scale", "nudge", "nested"]))
        if kind == "replace":
            parent[last] = draw(LEAVES)
        elif kind == "nested":
            parent[last] = draw(documents(keys))
        elif kind == "delete":
            del parent[last]
        elif kind == "add_key" and isinstance(parent, dict):
            parent[draw(st.sampled_from(list(keys)) | st.text(max_size=5))] = draw(LEAVES)
        elif kind == "duplicate" and isinstance(parent, list):
            parent.append(copy.deepcopy(parent[last]))
        elif kind == "scale" and isinstance(parent[last], (int, float)) and not isinstance(parent[last], bool):
            parent[last] = parent[last] * draw(st.sampled_from([-1, 0, 1e6, 1e-6, 1e300, float("nan")]))
        elif kind == "nudge" and isinstance(parent[last], (int, float)) and not isinstance(parent[last], bool):
            # just inside and just outside tolerances such as a quaternion's unit norm (1e-6)
            parent[last] = parent[last] * (1 + draw(st.sampled_from([5e-7, -5e-7, 3e-6, -3e-6, 1e-3])))
    return doc
