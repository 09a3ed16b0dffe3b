"""Stream mode answers: every update line is either refused (nothing changed) or applied (said so),
with a planning failure as its own field; echoed user values are bounded; an update that moves
obstacles and the start together lists both (the `change` name was reused for a tuple)."""

from __future__ import annotations

import io
import json

import pytest
from support.planning import write_scene

from placement.cli.options import MESSAGE_CHARS, bounded, cut
from placement.cli.query import stream_lines, stream_plans
from placement.planning import Planner, SceneError

START = [1.0, 4.0, 0.0]
CRATE = {"name": "crate", "box": {"center": [1.0, 4.0, 0.3], "size": [0.4, 0.4, 0.6]}}  # on the start pose


@pytest.fixture(scope="module")
def scene_path(tmp_path_factory, maps_dir):
    return write_scene(tmp_path_factory.mktemp("stream"), maps_dir)


def run_stream(planner, lines: list, capsys) -> tuple[list[dict], str]:
    """stream_plans over ``lines`` (dicts are sent as JSON, bytes and str as they are): the answers
    (the first plan first) and stderr."""
    raw = b"".join(
        (x if isinstance(x, bytes) else (x if isinstance(x, str) else json.dumps(x)).encode()) + b"\n" for x in lines
    )
    stream_plans(planner, stream=io.BytesIO(raw))
    out, err = capsys.readouterr()
    return [json.loads(x) for x in out.splitlines()], err


def test_each_answer_says_refused_or_applied(scene_path, capsys):
    planner = Planner(scene_path)
    answers, err = run_stream(
        planner,
        [
            {"start": [1.5, 4.0, 0.0]},  # 1 applied, planned
            {"start": [1.2, 4.0, 0.0], "objects": [{"name": "mug"}]},  # 2 refused: nothing of it taken
            "not json",  # 3 refused
            {"start": START, "obstacles": {"add": [CRATE]}},  # 4 applied, planning fails
            {"obstacles": {"add": [dict(CRATE, box={"center": [5.5, 0.5, 0.3], "size": [0.2, 0.2, 0.6]})]}},  # 5
            {"start": [1.5, 3.0, 0.0]},  # 6 applied, plans again
        ],
        capsys,
    )
    assert len(answers) == 7 and answers[0]["status"] == "ok" and "update" not in answers[0]
    first, refused, not_json, blocked, duplicate, again = answers[1:]
    assert first["update"]["status"] == "applied" and first["update"]["line"] == 1
    assert first["update"]["updated"] == ["start"] and first["plan_error"] is None and first["status"] == "ok"
    for a, line in ((refused, 2), (not_json, 3)):
        assert a["update"] == {"status": "refused", "line": line} and a["error"] and "steps" not in a
    assert "unknown object 'mug'" in refused["error"]
    # applied: the crate is in the scene and the start moved, though no plan came of it
    assert blocked["update"]["status"] == "applied" and blocked["update"]["line"] == 4
    assert blocked["update"]["updated"] == ["obstacles", "start"]
    assert "start pose" in blocked["plan_error"] and "steps" not in blocked and "error" not in blocked
    assert "crate" in {o.name for o in planner.scene.obstacles}
    # proof that it stayed: the same name again is refused as a duplicate
    assert duplicate["update"]["status"] == "refused" and "crate" in duplicate["error"]
    assert again["update"]["status"] == "applied" and again["plan_error"] is None and again["status"] == "ok"
    lines = err.splitlines()
    assert sum("update refused, nothing changed" in x for x in lines) == 3
    assert sum("update applied, but planning failed" in x for x in lines) == 1


def test_a_refused_update_changes_nothing(scene_path, capsys):
    planner = Planner(scene_path)
    scene, world, problems = planner.scene, planner.world, planner.problems
    answers, _ = run_stream(planner, [{"start": [1.5, 4.0, 0.0], "obstacles": {"remove": ["nothing"]}}], capsys)
    assert answers[1]["update"]["status"] == "refused"
    assert planner.scene is scene and planner.world is world and planner.problems is problems
    assert answers[1]["error"].startswith("update: obstacles.remove[0]: unknown obstacle 'nothing'")


def test_obstacles_and_start_together_list_both(scene_path):
    planner = Planner(scene_path)
    crate = dict(CRATE, box={"center": [5.5, 0.5, 0.3], "size": [0.2, 0.2, 0.6]})
    info = planner.update({"obstacles": {"add": [crate]}, "start": [1.5, 4.0, 0.0]})
    assert info["updated"] == ["obstacles", "start"]
    info = planner.update(
        {"obstacles": {"remove": ["crate"]}, "start": [1.5, 4.1, 0.0], "objects": [{"name": "cup", "yaw": 0.5}]}
    )
    assert info["updated"] == ["cup", "obstacles", "start"]


def test_long_keys_and_values_are_not_echoed(scene_path, capsys):
    """A 20 MB key (over the line limit), a 1 MB key, a 1 MB object name and a 1 MB obstacle name:
    each answer and each stderr line stays short and says how long the value was."""
    planner = Planner(scene_path)
    big = "k" * 1_000_000
    answers, err = run_stream(
        planner,
        [
            {"x" * 20_000_000: 1},
            {big: 1},
            {"objects": [{"name": big, "yaw": 1.0}]},
            {"obstacles": {"remove": [big]}},
            {"objects": [{"name": "cup", big: 1}]},
        ],
        capsys,
    )
    assert [a["update"]["status"] for a in answers[1:]] == ["refused"] * 5
    assert "more than the" in answers[1]["error"] and "bytes a stream line may hold" in answers[1]["error"]
    for a in answers[1:]:
        assert len(json.dumps(a)) < 3000, a["error"][:200]
    for a in answers[2:]:
        assert "k" * 100 not in a["error"], a["error"][:200]
    for a in answers[3:5]:  # names this package quotes itself: cut with their length
        assert "1,000,000 characters" in a["error"], a["error"]
    assert len(err) < 5 * 3000 and len(err.splitlines()) == 5
    assert planner.scene.start == tuple(START)


def test_lines_that_are_not_utf8_or_too_long_are_refused():
    data = b'{"start": [1, 2, 3]}\n\xff\xfe\n\n' + b"x" * 50 + b"\n" + b"y" * 10
    got = list(stream_lines(io.BytesIO(data), max_bytes=20))
    assert got[0] == (1, '{"start": [1, 2, 3]}\n', None)
    assert got[1][0] == 2 and got[1][1] is None and "not UTF-8" in got[1][2]
    assert got[2][0] == 4 and got[2][1] is None and "51 bytes" in got[2][2]
    assert got[3] == (5, "y" * 10, None)


def test_bounded_messages():
    v = "v" * 10_000
    msg = bounded(f"update: unknown key '{v}'; also '{v}'", {"a": [{v: 1}]})
    assert msg.count("10,000 characters") == 2 and len(msg) < 300
    assert bounded("short 'x'", {"x": 1}) == "short 'x'"
    long = "error: " + " ".join(["w" * 100] * 1000)
    out = bounded(long)
    assert len(out) <= MESSAGE_CHARS + 60 and "message cut" in out
    assert cut("p" * 80) == "p" * 80 and "(81 characters)" in cut("p" * 81)


def test_update_errors_quote_names_briefly(scene_path):
    planner = Planner(scene_path)
    for change in ({"objects": [{"name": "n" * 100_000}]}, {"obstacles": {"remove": ["n" * 100_000]}}):
        with pytest.raises(SceneError) as e:
            planner.update(change)
        assert len(str(e.value)) < 1000 and "100,000 characters" in str(e.value)


def test_a_key_given_twice_is_refused_not_the_last_kept(scene_path, capsys):
    planner = Planner(scene_path)
    answers, err = run_stream(planner, ['{"start": [1.0, 4.0, 0.0], "start": [9.0, 9.0, 0.0]}'], capsys)
    assert answers[1]["update"]["status"] == "refused"
    assert "duplicate key 'start'" in answers[1]["error"]
    assert planner.scene.start == (1.0, 4.0, 0.0)
