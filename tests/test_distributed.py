"""The Dask path runs the same kernel as the local one and gives the same map, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import placement

pytestmark = pytest.mark.slow

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def client():
    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as c:
        yield c


def test_dask_build_equals_local(client, pr2):
    kwargs = dict(samples=40_000, seed=9, resolution=0.1, bins=(8, 5, 8), progress=False)
    local = placement.build_map(pr2, "right", **kwargs)
    remote = placement.build_map(pr2, "right", client=client, tasks=5, **kwargs)
    assert remote.values.dtype == np.float32
    assert np.array_equal(local.values, remote.values)
    assert np.array_equal(local.witness, remote.witness)
    assert np.count_nonzero(local.values) > 1000
    # another split, same map
    again = placement.build_map(pr2, "right", client=client, tasks=3, **kwargs)
    assert np.array_equal(local.values, again.values)
    assert np.array_equal(local.witness, again.witness)
