"""The parallel kernels' threads wait passively unless the user says otherwise: the entry points set
it (placement/process_env.py); importing the package sets nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = (
    "import os, placement, placement.kernels; before = os.environ.get('OMP_WAIT_POLICY'); "
    "from placement.process_env import configure_process; configure_process(); "
    "print(before, os.environ.get('OMP_WAIT_POLICY'))"
)


@pytest.mark.parametrize(
    ("given", "expected"), [(None, "None PASSIVE"), ("ACTIVE", "ACTIVE ACTIVE"), ("passive", "passive passive")]
)
def test_omp_wait_policy_defaults_to_passive_and_keeps_the_users(given, expected):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if given is not None:
        env["OMP_WAIT_POLICY"] = given
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == expected


def test_the_command_sets_it_before_any_kernel_runs():
    code = (
        "import os, sys; from placement.cli.main import main; sys.argv = ['placement', '--version']\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\nprint(os.environ.get('OMP_WAIT_POLICY'))"
    )
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "PASSIVE"
