"""Evaluation on a Dask cluster: the same per-scene function as the local run, the same document."""

from __future__ import annotations

import json

import pytest
import yaml
from click.testing import CliRunner

from placement.cli.main import cli
from placement.errors import PlacementError
from placement.evaluation.evaluate import evaluate
from placement.evaluation.generate import generate_scene

distributed = pytest.importorskip("dask.distributed")

METHODS = ["sequential", "irm", "fixed"]


@pytest.fixture(scope="module")
def client():
    """Two worker processes with one thread each, on loopback only (bounded start-up)."""
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            worker_dashboard_address=None,
        ) as cluster,
        distributed.Client(cluster, timeout="60s") as c,
    ):
        yield c


@pytest.fixture(scope="module")
def scenes(maps_dir, tmp_path_factory):
    """Three small generated scenes (two with obstacles) on the test maps."""
    d = tmp_path_factory.mktemp("dask-scenes")
    paths = []
    for k in range(3):
        doc = generate_scene(7, k, objects=2, obstacles=k > 0, maps=str(maps_dir))
        # no effective IK time budget: a budget that runs out depends on the machine's load, and the
        # local and Dask documents must agree whatever else runs
        doc["planner"] = {"threshold": 0.01, "yaw_steps": 40, "ik_budget_ms": 60000, "time_budget_s": 3600}
        p = d / f"s{k}.yaml"
        p.write_text(yaml.safe_dump(doc))
        paths.append(p)
    return paths


def without_timings(doc: dict) -> dict:
    """The document with the planning times (the only part that may differ between runs) removed."""
    doc = json.loads(json.dumps(doc))
    for r in doc["methods"].values():
        del r["planning_ms_per_placement"]
    return doc


@pytest.mark.slow
def test_dask_document_equals_local(client, scenes):
    local = evaluate(scenes, METHODS, workers=1)
    seen = []
    with distributed.get_task_stream(client) as stream:
        remote = evaluate(scenes, METHODS, client=client, progress=lambda done, total: seen.append((done, total)))
    assert without_timings(remote) == without_timings(local)
    assert seen == [(k, 3) for k in range(4)]
    assert any(local["methods"]["sequential"]["success"])  # the comparison is about real plans
    # one task per scene, run on the cluster's workers
    tasks = [t for t in stream.data if "scene_task" in str(t["key"])]
    assert len(tasks) == 3 and {t["worker"] for t in tasks} <= set(client.scheduler_info()["workers"])


def test_dask_error_in_a_scene_is_raised_here(client, scenes, tmp_path):
    # the maps are first opened on a worker: its PlacementError comes back as such
    with pytest.raises(PlacementError, match="no-maps-here"):
        evaluate(scenes[:2], ["sequential"], maps=tmp_path / "no-maps-here", client=client)


@pytest.mark.slow
def test_cli_dask_equals_local(client, scenes):
    args = ["evaluate", *map(str, scenes), "--methods", ",".join(METHODS), "--json", "-q"]
    local = CliRunner().invoke(cli, [*args, "--workers", "1"])
    remote = CliRunner().invoke(cli, [*args, "--dask", client.scheduler.address])
    assert local.exit_code == 0 and remote.exit_code == 0, (local.output, remote.output)
    assert without_timings(json.loads(remote.stdout)) == without_timings(json.loads(local.stdout))


@pytest.mark.parametrize(
    ("address", "words"),
    [
        # a refused port takes the connect timeout (10 s): the same dask_client() is tested so for
        # `maps build --dask` in test_cli.py
        ("nonsense", ["cannot reach Dask scheduler at nonsense", "missing port"]),
        ("foo://host:1", ["unknown address scheme 'foo'"]),
    ],
)
def test_cli_bad_address_is_one_line(scenes, tmp_path, address, words):
    out = tmp_path / "report"
    r = CliRunner().invoke(cli, ["evaluate", str(scenes[0]), "--dask", address, "--out", str(out)])
    assert r.exit_code == 2, (r.output, r.exception)
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    for w in words:
        assert w in lines[0]
    assert r.stdout == "" and not out.exists()  # nothing planned, nothing left behind


def test_cli_workers_and_dask_exclude_each_other(scenes):
    r = CliRunner().invoke(cli, ["evaluate", str(scenes[0]), "--dask", "tcp://127.0.0.1:1", "--workers", "2"])
    assert r.exit_code == 2
    assert r.stderr.strip() == ("error: --workers and --dask exclude each other: the cluster's workers run the scenes")
