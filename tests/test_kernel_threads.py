"""The parallel kernels' threads wait passively unless the user says otherwise (placement/kernels)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = "import os, placement.kernels; print(os.environ.get('OMP_WAIT_POLICY'))"


@pytest.mark.parametrize(("given", "expected"), [(None, "PASSIVE"), ("ACTIVE", "ACTIVE"), ("passive", "passive")])
def test_omp_wait_policy_defaults_to_passive_and_keeps_the_users(given, expected):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if given is not None:
        env["OMP_WAIT_POLICY"] = given
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == expected
