"""First runs: the compile notice appears exactly when numba compiles, and the warm-up compiles every kernel."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

import pytest
import yaml

from placement.evaluation.generate import generate_scene

pytestmark = pytest.mark.slow

NOTICE = "compiling kernels (first run only, about"


def stderr_of(args, cache_dir, stop_at_notice=False, timeout=120) -> str:
    """stderr of a CLI run with NUMBA_CACHE_DIR=cache_dir; with ``stop_at_notice`` the run is
    killed as soon as the notice appears (the compilation it announces is not waited for)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    p = subprocess.Popen(
        [sys.executable, "-m", "placement.cli.main", *map(str, args)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    timer = threading.Timer(timeout, p.kill)
    timer.start()
    lines = []
    try:
        for line in p.stderr:
            lines.append(line)
            if stop_at_notice and NOTICE in line:
                break
    finally:
        timer.cancel()
        p.kill()
        p.wait()
    return "".join(lines)


@pytest.fixture(scope="module")
def scene(maps_dir, tmp_path_factory):
    doc = generate_scene(3, 0, objects=1, maps=str(maps_dir))
    doc["planner"] = {"threshold": 0.01, "yaw_steps": 40}
    path = tmp_path_factory.mktemp("warmup") / "scene.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def commands(tmp_path, scene):
    return {
        "build": [
            "maps",
            "build",
            "--robot",
            "pr2",
            "--arm",
            "right",
            "--samples",
            "2000",
            "--resolution",
            "0.2",
            "--bins",
            "4,3,4",
            "--out",
            tmp_path / "m",
        ],
        "query": ["query", scene],
    }


@pytest.mark.parametrize("command", ["build", "query"])
def test_notice_on_a_cold_cache_only(tmp_path, scene, command):
    args = commands(tmp_path, scene)[command]
    cold = stderr_of(args, tmp_path / "empty-cache", stop_at_notice=True)
    assert cold.count(NOTICE) == 1, cold
    assert not (tmp_path / "m").exists()  # the notice came before the map was built, not after
    warm_dir = os.environ["NUMBA_CACHE_DIR"]  # the test session's cache
    warm = stderr_of(args, warm_dir)
    if NOTICE in warm:  # this session's cache was cold: now it is not
        if command == "build":
            args[-1] = tmp_path / "m2"
        warm = stderr_of(args, warm_dir)
    assert NOTICE not in warm, warm
    assert "error" not in warm, warm


def test_notice_is_logged_once_per_process(caplog):
    import numba

    from placement.warmup import NOTICE as listener
    from placement.warmup import announce_compilation

    announce_compilation(7)
    announce_compilation(7)  # a second call must not register a second listener
    listener.told = False  # as in a new process
    with caplog.at_level("INFO", logger="placement"):
        numba.njit(lambda x: x + 1)(1)  # not cached: always compiles
        numba.njit(lambda x: x * 2)(1)
    notices = [r.getMessage() for r in caplog.records if NOTICE in r.getMessage()]
    assert notices == ["compiling kernels (first run only, about 7 s)"]


def test_warmup_compiles_every_kernel(tmp_path):
    # a fresh process on the session's (warm) cache: what it finds compiled, the warm-up loaded or compiled
    code = (
        "import tempfile, pathlib; from placement.warmup import warm, uncompiled_kernels, kernel_dispatchers\n"
        "warm(pathlib.Path(tempfile.mkdtemp()), say=lambda m: None)\n"
        "print(len(kernel_dispatchers())); print(','.join(uncompiled_kernels()))"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    count, missing = p.stdout.splitlines()
    assert int(count) >= 10 and missing == ""


def test_kernel_list_is_what_python_calls():
    from placement.warmup import kernel_dispatchers, uncompiled_kernels

    names = kernel_dispatchers()
    assert {
        "placement.kernels.sampling.sample_block",
        "placement.kernels.irm.trajectory_maps",
        "placement.kernels.navigation.padded_costs",
        "placement.kernels.ik.dls_attempt",
    } <= set(names)
    # called only from other kernels: compiled into them, never on their own
    assert not any(
        n.startswith(("placement.kernels.rng.", "placement.kernels.octants")) for n in names
    )  # and octants_refine
    assert set(uncompiled_kernels()) <= set(names)
