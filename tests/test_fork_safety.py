"""The thread pools of the map reader and the searches serve a process forked after they were used
(a user's own multiprocessing on Linux forks): the child makes its own threads instead of waiting
forever for the parent's, which do not exist in it."""

from __future__ import annotations

import multiprocessing as mp

import pytest

from placement.planning.world import side_by_side
from placement.storage import chunks


def _child(queue) -> None:
    queue.put((side_by_side(lambda x: x * 3, range(4)), chunks._pool().submit(lambda: 7).result()))


@pytest.mark.skipif("fork" not in mp.get_all_start_methods(), reason="no fork on this platform")
def test_a_forked_child_uses_the_pools():
    assert side_by_side(lambda x: x * 2, range(4)) == [0, 2, 4, 6]
    assert chunks._pool().submit(lambda: 5).result() == 5
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_child, args=(queue,))
    child.start()
    try:
        assert queue.get(timeout=30) == ([0, 3, 6, 9], 7)
    finally:
        child.join(timeout=5)
        if child.is_alive():
            child.kill()
