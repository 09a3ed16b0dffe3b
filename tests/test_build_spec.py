"""Build specs: every bad value is one PlacementError line naming the key; hypothesis throws junk at the parser."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from placement import PlacementError
from placement.maps.buildspec import (
    DEFAULT_BINS,
    DEFAULT_RESOLUTION,
    FORMATS,
    INDEXES,
    MAX_BINS,
    MAX_RESOLUTION,
    MAX_SAMPLES,
    MAX_SEED,
    MIN_RESOLUTION,
    SPEC_KEYS,
    BuildSpec,
    TorsoSpec,
    load_build_spec,
    parse_build_spec,
    parse_build_spec_text,
)

ROOT = Path(__file__).resolve().parents[1]
PR2_SPEC = (ROOT / "maps" / "pr2.yaml").read_text()


def test_the_default_spec_file():
    spec = load_build_spec(ROOT / "maps" / "pr2.yaml")
    assert spec == BuildSpec(
        robot="pr2",
        arms=("right", "left"),
        samples=30_000_000,
        seed=0,
        resolution=0.05,
        bins=(20, 9, 20),
        index="isotropy",
        format="zarr",
        completion=True,
        torso=TorsoSpec("torso_lift_joint", (0.0, 0.15, 0.31)),
    )
    coarse = load_build_spec(ROOT / "maps" / "pr2-10cm.yaml")
    assert coarse.resolution == 0.1 and coarse.samples == 150_000_000 and not coarse.completion
    assert BuildSpec().resolution == DEFAULT_RESOLUTION == 0.05 and BuildSpec().bins == DEFAULT_BINS


@pytest.mark.parametrize(
    "data,expected",
    [
        ({"arms": "right"}, {"arms": ("right",)}),
        ({"arms": ["left"]}, {"arms": ("left",)}),
        ({"samples": 1e6}, {"samples": 1_000_000}),
        ({"samples": "1e6"}, {"samples": 1_000_000}),
        ({"samples": MAX_SAMPLES}, {"samples": MAX_SAMPLES}),
        ({"seed": 0}, {"seed": 0}),
        ({"seed": MAX_SEED}, {"seed": MAX_SEED}),
        ({"resolution": 0.1}, {"resolution": 0.1}),
        ({"resolution": "1e-1"}, {"resolution": 0.1}),
        ({"resolution": 1}, {"resolution": 1.0}),
        ({"bins": [10, 5, 10]}, {"bins": (10, 5, 10)}),
        ({"bins": "4,3,4"}, {"bins": (4, 3, 4)}),
        ({"index": "volume", "format": "hdf5"}, {"index": "volume", "format": "hdf5"}),
        ({"self_collision": True, "self_distance": False}, {"self_collision": True}),
    ],
)
def test_valid_values(data, expected):
    spec = parse_build_spec(data, "spec.yaml")
    for key, value in expected.items():
        assert getattr(spec, key) == value


@pytest.mark.parametrize(
    "data,words",
    [
        ({"samples": "many"}, ["spec.yaml: samples", "1 to 100,000,000,000", "'many'"]),
        ({"samples": 0}, ["samples", "from 1"]),
        ({"samples": 1e30}, ["samples", "100,000,000,000"]),
        ({"samples": MAX_SAMPLES + 1}, ["samples"]),
        ({"samples": 2.5}, ["samples"]),
        ({"samples": True}, ["samples"]),
        ({"seed": 1.5}, ["spec.yaml: seed", "1.5"]),
        ({"seed": -1}, ["seed", "from 0"]),
        ({"seed": MAX_SEED + 1}, ["seed"]),
        ({"bins": 5}, ["bins", "three"]),
        ({"bins": ["a", "b", "c"]}, ["bins", "three"]),
        ({"bins": [20, 9]}, ["bins", "three"]),
        ({"bins": [20, 9, 20, 4]}, ["bins", "three"]),
        ({"bins": [0, 9, 20]}, ["bins"]),
        ({"bins": [-2, 9, 20]}, ["bins"]),
        ({"bins": [20, 9, MAX_BINS + 2]}, ["bins", str(MAX_BINS)]),
        ({"bins": [3, 9, 20]}, ["bins", "even"]),
        ({"bins": [20, 8, 20]}, ["bins", "odd"]),
        ({"resolution": -1}, ["resolution", f"{MIN_RESOLUTION:g} to {MAX_RESOLUTION:g} m"]),
        ({"resolution": 0}, ["resolution"]),
        ({"resolution": "fine"}, ["resolution"]),
        ({"resolution": math.nan}, ["resolution"]),
        ({"resolution": math.inf}, ["resolution"]),
        ({"resolution": [0.1]}, ["resolution"]),
        ({"arms": []}, ["arms"]),
        ({"arms": [1]}, ["arms"]),
        ({"arms": ["right", "right"]}, ["arms", "twice"]),
        ({"arms": {"right": 1}}, ["arms"]),
        ({"index": "speed"}, ["index", ", ".join(INDEXES)]),
        ({"format": "parquet"}, ["format", ", ".join(FORMATS)]),
        ({"format": ["zarr"]}, ["format"]),
        ({"self_collision": "yes please"}, ["self_collision", "true or false"]),
        ({"self_distance": 1}, ["self_distance", "true or false"]),
        ({"robot": ""}, ["robot"]),
        ({"robot": 7}, ["robot"]),
        ({"wheels": 4}, ["unknown key 'wheels'", "samples"]),
        ({1: 2}, ["unknown key 1"]),
        ({}, ["non-empty mapping"]),
        (None, ["non-empty mapping"]),
        ([1, 2], ["non-empty mapping"]),
        ("samples: 3", ["non-empty mapping"]),
    ],
)
def test_bad_values_name_the_key(data, words):
    with pytest.raises(PlacementError) as exc:
        parse_build_spec(data, "spec.yaml")
    message = str(exc.value)
    assert "\n" not in message and message.startswith("spec.yaml")
    for w in words:
        assert w in message, message


@pytest.mark.parametrize(
    "text,words",
    [
        ("", ["non-empty mapping"]),
        ("samples: [", ["not valid YAML"]),
        ("- 1\n- 2\n", ["non-empty mapping"]),
        ("created: 2020-02-30\n", ["not valid YAML"]),
        ("samples: 1e30\n", ["samples"]),
    ],
)
def test_bad_text(text, words):
    with pytest.raises(PlacementError) as exc:
        parse_build_spec_text(text, "s.yaml")
    assert all(w in str(exc.value) for w in words) and "\n" not in str(exc.value)


def test_bad_files(tmp_path):
    with pytest.raises(PlacementError, match="not found"):
        load_build_spec(tmp_path / "nope.yaml")
    with pytest.raises(PlacementError, match="is a directory"):
        load_build_spec(tmp_path)
    binary = tmp_path / "b.yaml"
    binary.write_bytes(b"\xff\xfe\x00samples")
    with pytest.raises(PlacementError, match="cannot be read"):
        load_build_spec(binary)


def test_arms_of_robot(pr2):
    assert BuildSpec().arms_of(pr2) == pr2.arms
    assert parse_build_spec({"arms": "left"}).arms_of(pr2) == ["left"]
    with pytest.raises(PlacementError, match="no arm 'middle'.*right"):
        parse_build_spec({"arms": ["right", "middle"]}).arms_of(pr2)


# --------------------------------------------------------------------------------------------
# Property tests: random and mutated specs give a BuildSpec or one PlacementError line
# --------------------------------------------------------------------------------------------

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True),
    st.text(max_size=12),
    st.sampled_from(["right", "left", "1e6", "20,9,20", "nan", "zarr"]),
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
    max_leaves=8,
)
keys = st.one_of(st.sampled_from(SPEC_KEYS), st.text(max_size=8), st.integers(), st.none())
PR2_DATA = yaml.safe_load(PR2_SPEC)


def check(parse, arg):
    try:
        spec = parse(arg)
    except PlacementError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    assert isinstance(spec, BuildSpec)
    assert 1 <= spec.samples <= MAX_SAMPLES and 0 <= spec.seed <= MAX_SEED
    assert MIN_RESOLUTION <= spec.resolution <= MAX_RESOLUTION
    assert len(spec.bins) == 3 and spec.bins[0] % 2 == 0 and spec.bins[1] % 2 == 1
    assert spec.index in INDEXES and spec.format in FORMATS
    assert spec.arms is None or all(isinstance(a, str) and a for a in spec.arms)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(st.dictionaries(keys, values, max_size=6), values))
def test_random_specs(data):
    check(parse_build_spec, data)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(sorted(PR2_DATA)), values, st.booleans())
def test_mutated_pr2_spec(key, value, drop):
    data = dict(PR2_DATA)
    if drop:
        data.pop(key)
    else:
        data[key] = value
    check(parse_build_spec, data)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, len(PR2_SPEC)), st.integers(0, 20), st.text(max_size=8))
def test_mutated_pr2_spec_text(at, cut, insert):
    check(parse_build_spec_text, PR2_SPEC[:at] + insert + PR2_SPEC[at + cut :])


@pytest.mark.parametrize(
    "torso, words",
    [
        ({"joint": "torso_lift_joint", "values": ["0.1", 0.2]}, "torso.values[0] must be a setting"),
        ({"joint": "torso_lift_joint", "values": [int("f" * 5000, 16), 0.2]}, "an integer of about 6021 digits"),
        ({"joints": ["torso_lift_joint"], "postures": [["0.1"], [0.2]]}, "torso.postures[0][0] must be a setting"),
    ],
    ids=["string", "hex_5000_digits", "posture_string"],
)
def test_torso_settings_are_numbers_in_the_file(torso, words):
    """A setting written as a string is refused (a spec's numbers are YAML numbers); a 5,000-digit
    hexadecimal integer is named by its size, never converted (Python refuses to write it)."""
    with pytest.raises(PlacementError, match=".*") as err:
        parse_build_spec({"robot": "pr2", "torso": torso}, "spec.yaml")
    assert words in str(err.value) and "\n" not in str(err.value)
