"""The kernel timings of `make bench` (tools/bench.py) and the machine line of its table.

Every timing is the median of several runs on this machine.
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from pathlib import Path

import numba
import numpy as np
from numba import njit

from placement.kernels.isotropy import W_ROWS, isotropy_batched
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.manipulability import extended_manipulability, joint_penalties
from placement.kernels.sampling import sample_configs


def median_time(fn, runs=5):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


@njit(cache=True)
def measure_all(Q, J, lower, upper, cont, mode, index):
    """Evaluate the measure on all rows; mode 0 = direct 64 octants, 1 = batched kernel (exact)."""
    n = Q.shape[1]
    plo = np.empty(n)
    phi = np.empty(n)
    P = np.empty((6, n, 2))
    G = np.empty((6, 6, 2, 2))
    A = np.empty((6, 6))
    B = np.empty((6, 6))
    Ag = np.empty((21, 64))
    W = np.empty((W_ROWS, 64))
    de = np.empty((2, 6))
    ones = np.ones((6, 2))
    out = np.empty(Q.shape[0])
    for i in range(Q.shape[0]):
        joint_penalties(Q[i], lower, upper, cont, plo, phi)
        if mode == 0:
            out[i] = extended_manipulability(J[i], plo, phi, ones, index, -1.0, P, G, A, de)
        else:
            out[i] = isotropy_batched(J[i], plo, phi, ones, -1.0, P, G, Ag, W, A, B, de)
    return out


def machine() -> str:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, numba threads {numba.get_num_threads()}, "
        f"Python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}"
    )


def kernel_rows(a) -> list[tuple[str, str, str]]:
    """Table rows (measurement, value, ratio / detail) of the FK and isotropy kernels on the arm `a`, one thread."""
    ch = a.chain
    rows = []
    N = 200_000
    Q = sample_configs(np.uint64(1), 0, N, a.lower, a.upper)
    fk_jacobian_batch(Q[:10], ch.link_T, ch.axis, ch.kind, ch.tip_T)
    t = median_time(lambda: fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T))
    rows.append(("FK + TCP Jacobian (1 thread)", f"{N / t / 1e6:.2f} M/s", ""))
    _, J = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
    J[:, 3:] *= 0.15
    cont = a.continuous.astype(np.bool_)
    M = 4000
    measure_all(Q[:10], J[:10], a.lower, a.upper, cont, 0, 0)
    measure_all(Q[:10], J[:10], a.lower, a.upper, cont, 1, 0)
    t_direct = median_time(lambda: measure_all(Q[:M], J[:M], a.lower, a.upper, cont, 0, 0), 3)
    t_pruned = median_time(lambda: measure_all(Q[:M], J[:M], a.lower, a.upper, cont, 1, 0), 3)
    t_volume = median_time(lambda: measure_all(Q[: M * 10], J[: M * 10], a.lower, a.upper, cont, 0, 1), 3)
    d = measure_all(Q[:M], J[:M], a.lower, a.upper, cont, 0, 0)
    p = measure_all(Q[:M], J[:M], a.lower, a.upper, cont, 1, 0)
    rows.append(("isotropy, direct 64 octants (baseline, 1 thread)", f"{M / t_direct / 1e3:.1f} k/s", "1.00x"))
    rows.append(
        (
            "isotropy, batched-proof kernel, exact value (1 thread)",
            f"{M / t_pruned / 1e3:.1f} k/s",
            f"{t_direct / t_pruned:.2f}x (max diff {abs(d - p).max():.1e})",
        )
    )
    rows.append(("volume index, 64 octants (1 thread)", f"{10 * M / t_volume / 1e3:.1f} k/s", ""))
    return rows
