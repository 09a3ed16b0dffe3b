"""What the hostile-input tests (test_hostile_scenes.py, test_hostile_robots.py) share."""

from __future__ import annotations

HUGE_DEC = "7" * 5000
HUGE_HEX = "0x" + "f" * 5000


def one_line(exc: BaseException, *words: str) -> str:
    """The message of `exc`, checked to be one short line holding every one of `words`."""
    msg = str(exc)
    assert "\n" not in msg and len(msg) < 1000, msg
    for w in words:
        assert w in msg, msg
    return msg
