"""Writes placement/kernels/octants.py and octants_refine.py: the 64-octant bound kernels, unrolled.

Each kernel is one loop over the 64 octants whose body is a fully unrolled
6x6 computation on local variables, reading the packed Gram matrices from
one array and writing one or two output rows. That shape is what LLVM
vectorises (one store stream, no inner loops, no conditional sqrt); written by
hand it would be 300 lines of index soup, so it is generated. Run
``python tools/gen_octants.py`` after editing this file; a test checks the
modules are up to date. The tighter bounds (more iterations, used only for exact values) go to
their own module so that each stays readable at under 400 lines.
"""

from __future__ import annotations

import sys
from pathlib import Path

KERNELS = Path(__file__).resolve().parents[1] / "placement" / "kernels"
OUT = KERNELS / "octants.py"
OUT_REFINE = KERNELS / "octants_refine.py"
IND = " " * 8
POWER_STEPS = 3  # power steps for rho (lower bound of lambda_max)
REFINE_STEPS = 5  # further power steps when a sample needs its exact value
INVERSE_STEPS = 2  # inverse-iteration steps for mu (upper bound of lambda_min)


def p(r: int, c: int) -> int:
    if r < c:
        r, c = c, r
    return r * (r + 1) // 2 + c


def load(alpha: bool) -> list[str]:
    out = []
    for r in range(6):
        for c in range(r + 1):
            out.append(f"a{r}{c} = {'alpha * ' if alpha else ''}A[{p(r, c)}, s]")
    return out


def a(r: int, c: int) -> str:
    return f"a{max(r, c)}{min(r, c)}"


def factor(shift: str | None) -> list[str]:
    """Unrolled LDL^T of A (+ shift I) into locals l_ij (unit lower), pivots d_j and their inverses i_j.

    LDL^T instead of Cholesky: the same pivots' signs and the same backward
    stability, without six square roots (the slowest SIMD operations here).
    u_ij = l_ij d_j saves multiplications.
    """
    out = []
    for j in range(6):
        for i in range(j + 1, 6):
            u = a(i, j) + "".join(f" - u{i}{k} * l{j}{k}" for k in range(j))
            out.append(f"u{i}{j} = {u}")
        d = a(j, j) + (f" + {shift}" if shift else "") + "".join(f" - u{j}{k} * l{j}{k}" for k in range(j))
        out.append(f"d{j} = {d}")
        out.append(f"i{j} = 1.0 / d{j}")
        for i in range(j + 1, 6):
            out.append(f"l{i}{j} = u{i}{j} * i{j}")
    # NaN-safe: a NaN pivot compares False, so it never passes for positive
    out.append("pd = (d0 > 0.0) & (d1 > 0.0) & (d2 > 0.0) & (d3 > 0.0) & (d4 > 0.0) & (d5 > 0.0)")
    return out


def matvec(x: str, y: str) -> list[str]:
    return [f"{y}{r} = " + " + ".join(f"{a(r, c)} * {x}{c}" for c in range(6)) for r in range(6)]


def normalise(x: str) -> list[str]:
    return [
        f"nm = max(max(max(abs({x}0), abs({x}1)), max(abs({x}2), abs({x}3))), max(abs({x}4), abs({x}5)))",
        "nm = 1.0 / nm if nm > 0.0 else 1.0",
    ] + [f"{x}{r} *= nm" for r in range(6)]


def rayleigh(x: str, y: str, out: str) -> list[str]:
    return [
        "num = " + " + ".join(f"{x}{r} * {y}{r}" for r in range(6)),
        "den = " + " + ".join(f"{x}{r} * {x}{r}" for r in range(6)),
        f"{out} = num / den if den > 0.0 else 0.0",
    ]


def solve(x: str) -> list[str]:
    """x <- (L D L^T)^-1 x with the unrolled factor."""
    out = []
    for r in range(6):
        out.append(f"z{r} = {x}{r}" + "".join(f" - l{r}{c} * z{c}" for c in range(r)))
    for r in range(5, -1, -1):
        out.append(f"{x}{r} = z{r} * i{r}" + "".join(f" - l{c}{r} * {x}{c}" for c in range(r + 1, 6)))
    return out


def body(lines: list[str]) -> str:
    return "\n".join(IND + ln for ln in lines)


def _bodies() -> tuple[str, str, str, str]:
    """The unrolled loop bodies: positive-definiteness, rho, refined rho, mu."""
    pd = body(["b = beta[s]"] + load(True) + factor("b") + ["out[s] = 1.0 if pd else 0.0"])
    power = [f"x{r} = top[{r}]" for r in range(6)] + load(False)
    # the iteration counts are unrolled: an inner loop would stop LLVM vectorising across octants
    step = matvec("x", "y") + [f"x{r} = y{r}" for r in range(6)]

    def steps(k):
        # Rayleigh quotients are scale-free: rescale only every 4 steps, against overflow
        out = []
        for i in range(k):
            out += step + (normalise("x") if i % 4 == 3 else [])
        return out

    # (the iterates are not stored for a later continuation: a second output stream costs the vectorisation)
    rho_lines = power + steps(POWER_STEPS) + matvec("x", "y") + rayleigh("x", "y", "rho[s]")
    refine_lines = power + steps(POWER_STEPS + REFINE_STEPS) + matvec("x", "y") + rayleigh("x", "y", "rho[s]")
    mu_lines = (
        load(False)
        + factor(None)
        + [f"w{r} = bottom[{r}]" for r in range(6)]
        + (solve("w") + normalise("w"))
        + solve("w") * (INVERSE_STEPS - 1)
        + matvec("w", "y")
        + rayleigh("w", "y", "m")
        + ["mu[s] = m if pd else 0.0"]
    )
    return pd, body(rho_lines), body(refine_lines), body(mu_lines)


def generate() -> str:
    """The text of octants.py: Gram matrices, positive-definiteness flags, rho, traces."""
    pd, rho_body = _bodies()[:2]
    tr = body(["trace[s] = " + " + ".join(f"A[{p(r, r)}, s]" for r in range(6))])
    fill = '''

@njit(cache=True)
def fill_grams(G: npt.NDArray[np.float64], A: npt.NDArray[np.float64]) -> None:
    """A[p(r, c), s] <- G[r, c, s_r, s_c] for all 64 octants s (bit r set = sign -); A (21, 64)."""
    for r in range(6):
        for c in range(r + 1):
            k = r * (r + 1) // 2 + c
            g00 = G[r, c, 0, 0]
            g01 = G[r, c, 0, 1]
            g10 = G[r, c, 1, 0]
            g11 = G[r, c, 1, 1]
            for s in range(64):
                b = (s >> c) & 1
                lo = g01 if b else g00
                hi = g11 if b else g10
                A[k, s] = hi if (s >> r) & 1 else lo
'''
    return f'''"""All 64 octant Gram matrices at once: bounds and proofs, vectorised across octants.

GENERATED by tools/gen_octants.py; edit the generator, not this file.

A sample's 64 octants are independent 6x6 problems. Each kernel here is one
loop over the octants whose body is a fully unrolled 6x6 computation on
local variables: LLVM turns it into SIMD across octants (AVX2/AVX-512), about
20x faster than one octant at a time. Packed Gram matrices: ``A`` (21, 64),
entry (r, c), r >= c, in row ``r * (r + 1) // 2 + c``. Only bounds are
computed here, so contracted multiply-adds are harmless; exact values come
from ``manipulability.octant_value``. Factorisations are LDL^T (no square roots).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

# contracted multiply-adds only; error_model="numpy": a zero pivot gives inf, not an exception
_FM = {{"contract"}}
{fill}

@njit(cache=True, fastmath=_FM, error_model="numpy")
def pd_flags(
    A: npt.NDArray[np.float64], alpha: float, beta: npt.NDArray[np.float64], out: npt.NDArray[np.float64]
) -> None:
    """out[s] <- 1.0 if alpha * A_s + beta[s] * I is positive definite (Cholesky pivots > 0), else 0.0."""
    for s in range(64):
{pd}


@njit(cache=True, fastmath=_FM, error_model="numpy")
def lambda_max_lower(A: npt.NDArray[np.float64], top: npt.NDArray[np.float64], rho: npt.NDArray[np.float64]) -> None:
    """rho[s] <- a lower bound of lambda_max(A_s): Rayleigh quotient after {POWER_STEPS} power steps from top (6,).

    Any start vector gives a valid bound; an eigenvector of a neighbouring
    octant makes it tight.
    """
    for s in range(64):
{rho_body}


@njit(cache=True, fastmath=_FM, error_model="numpy")
def traces(A: npt.NDArray[np.float64], trace: npt.NDArray[np.float64]) -> None:
    """trace[s] <- trace(A_s) >= lambda_max(A_s) for positive semi-definite A_s."""
    for s in range(64):
{tr}
'''


REFINE_TEMPLATE = '''@njit(cache=True, fastmath=_FM, error_model="numpy")
def lambda_max_tight(A: npt.NDArray[np.float64], top: npt.NDArray[np.float64], rho: npt.NDArray[np.float64]) -> None:
    """rho[s] <- as :func:`lambda_max_lower` with {power_total} power steps: tighter, for exact values."""
    for s in range(64):
{refine_body}


@njit(cache=True, fastmath=_FM, error_model="numpy")
def lambda_min_upper(A: npt.NDArray[np.float64], bottom: npt.NDArray[np.float64], mu: npt.NDArray[np.float64]) -> None:
    """mu[s] <- an upper bound of lambda_min(A_s): Rayleigh quotient after {INVERSE_STEPS} inverse steps from bottom (6,).

    0 where A_s is not numerically positive definite (the caller then
    computes that octant exactly).
    """
    for s in range(64):
{mu_body}


'''


def generate_refine() -> str:
    """The text of octants_refine.py: the bounds that need more iterations (exact values only)."""
    refine_body, mu_body = _bodies()[2:]
    head = """\"\"\"Tighter 64-octant bounds for exact values: more power steps, inverse iteration.

GENERATED by tools/gen_octants.py; edit the generator, not this file. Same layout and conventions
as :mod:`placement.kernels.octants`.
\"\"\"

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

# contracted multiply-adds only; error_model="numpy": a zero pivot gives inf, not an exception
_FM = {"contract"}


"""
    return (
        head
        + REFINE_TEMPLATE.format(
            power_total=POWER_STEPS + REFINE_STEPS,
            INVERSE_STEPS=INVERSE_STEPS,
            refine_body=refine_body,
            mu_body=mu_body,
        ).rstrip()
        + "\n"
    )


def outputs() -> dict[Path, str]:
    """Every generated module and its text."""
    return {OUT: generate(), OUT_REFINE: generate_refine()}


def main() -> int:
    files = outputs()
    if "--check" in sys.argv:
        return 0 if all(path.read_text() == text for path, text in files.items()) else 1
    for path, text in files.items():
        path.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
