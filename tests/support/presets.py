"""Robot preset documents and their one-line errors: the round PR2 as a mapping, edits, loading."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

import placement
from placement.errors import PresetError

DELETE = object()


def pr2_mapping() -> dict:
    """The PR2 preset with a round base (tests/data/pr2_round.yaml: the built-in one before it got its
    real footprint) as a mapping (its URDF path is package://, valid from any folder)."""
    return yaml.safe_load((Path(__file__).parents[1] / "data" / "pr2_round.yaml").read_text())


def changed(spec: dict, **changes) -> dict:
    """A deep copy of ``spec`` with ``a__b__c=value`` set at spec[a][b][c] (DELETE removes the key)."""
    out = copy.deepcopy(spec)
    for dotted, value in changes.items():
        *parents, last = dotted.split("__")
        node = out
        for k in parents:
            node = node[k]
        if value is DELETE:
            del node[last]
        else:
            node[last] = value
    return out


def write(tmp_path, spec) -> str:
    path = tmp_path / "my.yaml"
    path.write_text(spec if isinstance(spec, str) else yaml.safe_dump(spec, sort_keys=False))
    return str(path)


def message(tmp_path, spec, cls=PresetError, *words) -> str:
    """Load ``spec`` and return its error line: of class ``cls``, one line, naming the file and ``words``."""
    path = write(tmp_path, spec)
    with pytest.raises(cls) as info:
        placement.load_robot(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: "), msg
    for w in words:
        assert w in msg, msg
    return msg


# -- the mapping alone -------------------------------------------------------------------------------
