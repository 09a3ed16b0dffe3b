"""Large YAML documents read their lines of numbers first: the same data as PyYAML's plain parse,
or PyYAML's own error, whatever the text around them."""

from __future__ import annotations

import math

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from placement.validation import FAST_FROM, UniqueKeyLoader, _numbers_first, parse_yaml


def plain(text: str) -> object:
    return yaml.load(text, Loader=UniqueKeyLoader)


def same(text: str) -> None:
    """``_numbers_first`` gives what the plain parse gives, exactly (types and signs of zero too), or
    both raise."""
    try:
        want = plain(text)
    except (yaml.YAMLError, ValueError):
        with pytest.raises((yaml.YAMLError, ValueError)):
            _numbers_first(text)
        return
    got = _numbers_first(text)
    assert got == want
    assert repr(got) == repr(want)  # 1 and 1.0, 0.0 and -0.0 told apart


# numbers in the forms the fast path takes and in forms it must leave to PyYAML
numbers = st.one_of(
    st.integers(-(10**6), 10**6).map(str),
    st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr).filter(lambda t: "." in t),
    st.sampled_from(["-0.0", "+1.5", "1.", "2.5e+3", "1e3", "0x1f", "007", "1_000", ".5", ".inf", "-.inf", "1:30"]),
)
sequence = st.lists(numbers, min_size=1, max_size=7).map(lambda ns: "[" + ", ".join(ns) + "]")
line = st.one_of(
    sequence.map(lambda s: f"- {s}"),
    sequence.map(lambda s: f"  - {s}  # pose"),
    sequence.map(lambda s: f"- - {s}"),
    st.sampled_from(["- name: g", "  poses:", "- x", "notes: |", "note: >-", 'quoted: "a', "'b", 'c"', "# [1, 2]"]),
    sequence.map(lambda s: f"  key: {s}"),
    sequence.map(lambda s: f"  text {s}"),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(line, min_size=1, max_size=12))
def test_random_documents_read_the_same(lines: list[str]) -> None:
    same("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    "text",
    [
        "notes: |\n  - [1, 2]\n  - [3.0, 4]\nposes:\n- [5, 6]\n",  # a block scalar keeps its text
        'name: "a\n  - [1, 2]"\nposes:\n- [1, 2]\n',  # so does a quoted string over two lines
        "name: abc\n  - [1, 2]\n",  # and a plain scalar's continuation
        "- [1, 2]\n- [1, 2]  # [3]\n- [-0.0, 0.5e+3, 1e3]\n",
        "a: [1, 2]\na: [1, 2]\n",  # a duplicate key is refused either way
        "- [1, 2]\n- [1, 2\n",  # a syntax error
        "x: !placement-numbers '7'\nnotes: |\n  - [1, 2]\n",  # the tag the fast path writes, in the text
    ],
)
def test_hard_cases_read_the_same(text: str) -> None:
    same(text)


def test_a_large_grasp_set_reads_the_same_and_errors_keep_their_line(monkeypatch: pytest.MonkeyPatch) -> None:
    pose = "    - [0, 0, 0.15000000000000002, 0.00881502, 0.70705183, -0.0, 0.70705183]\n"
    body = "".join(f"- name: g{i}\n  poses:\n{pose}{pose}" for i in range(FAST_FROM // 100))
    assert len(body) >= FAST_FROM
    want = plain(body)
    with monkeypatch.context() as m:  # served by the lines of numbers alone, not the plain parse
        m.setattr("placement.validation.yaml.load", None)
        data = parse_yaml(body, "big.yaml", ValueError)
    assert data == want and math.copysign(1.0, data[0]["poses"][0][5]) == -1.0
    broken = body + "- name: [1, 2\n"
    with pytest.raises(ValueError, match=r"big.yaml: invalid YAML at line \d+"):
        parse_yaml(broken, "big.yaml", ValueError)
    lines = body.count("\n")
    with pytest.raises(ValueError) as err:
        parse_yaml(broken, "big.yaml", ValueError)
    assert f"line {lines + 2}," in str(err.value) or f"line {lines + 1}," in str(err.value)


@pytest.mark.parametrize(
    "line",
    [
        "- " * 20_000 + "[1]x",  # dashes that two optional runs of dashes could share in n^2 ways
        "- [" + "1, " * 20_000 + "x]",
        "- [" + "1" * 100_000,
        "a" * 100_000 + ": [1.5e+3" + " " * 20_000 + "x]",
    ],
)
def test_hostile_lines_are_read_in_linear_time(line: str) -> None:
    """A line that almost holds numbers costs the line search a few passes over it, not one per
    way to split it: a document of such lines parses (or is refused) like any other."""
    import time

    from placement.validation import _NUMBERS_LINE

    short, long = line[: len(line) // 10], line
    t0 = time.perf_counter()
    _NUMBERS_LINE.search(short)
    t1 = time.perf_counter()
    assert _NUMBERS_LINE.search(long) is None
    t2 = time.perf_counter()
    # 10x the text: 10x the time for a linear search, 100x for a quadratic one (with slack for noise)
    assert t2 - t1 < 40 * (t1 - t0) + 0.05
    same(line + "\n")
