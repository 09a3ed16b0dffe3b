"""A small validation library for documents read from YAML or JSON: one-line errors with key paths.

Every check raises the error class it was given with ``WHERE: KEY.PATH: problem``, so a user sees
the file (or stream line) and the key at once. Numbers must be finite; booleans are never numbers.
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import PlacementError

#: Words that mean a 3D rotation; in version 1 scenes shapes rotate about z only.
ROTATION_WORDS = ("orientation", "quaternion", "rotation", "rpy", "roll", "pitch", "euler")


def join(path: str, key) -> str:
    """``path.key`` (or ``key`` at the top level)."""
    return f"{path}.{key}" if path else str(key)


def type_name(v) -> str:
    """A short description of a value's type for error messages."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, dict):
        return "mapping"
    if isinstance(v, list):
        return "list"
    if isinstance(v, str):
        return f"string {v[:30]!r}"
    return type(v).__name__


def fmt(v: float) -> str:
    """A number as it reads best in a message."""
    return f"{v:.6g}"


class Validator:
    """Checks on parsed values; ``where`` names the document (a file path, or a stream line)."""

    def __init__(self, where: str, error: type[PlacementError] = PlacementError):
        self.where = where
        self.error = error

    def fail(self, path: str, msg: str):
        raise self.error(f"{self.where}: {path}: {msg}" if path else f"{self.where}: {msg}")

    # -- structure -----------------------------------------------------
    def mapping(self, value, path: str, allowed, required=()) -> dict:
        """``value`` must be a mapping with string keys among ``allowed`` and every ``required`` key."""
        if not isinstance(value, dict):
            self.fail(path, f"expected a mapping, got {type_name(value)}")
        for key in value:
            if key not in allowed:
                hint = ""
                if str(key).lower() in ROTATION_WORDS:
                    hint = " (shapes and objects rotate about z only: use 'yaw' [rad])"
                raise self.error(f"{self.where}: unknown key '{join(path, key)}'; allowed: "
                                 f"{', '.join(sorted(allowed))}{hint}")
        for key in required:
            if key not in value:
                raise self.error(f"{self.where}: missing required key '{join(path, key)}'")
        return value

    def items(self, value, path: str) -> list:
        """A list (null reads as an empty list)."""
        if value is None:
            return []
        if not isinstance(value, list):
            self.fail(path, f"expected a list, got {type_name(value)}")
        return value

    # -- scalars -------------------------------------------------------
    def number(self, value, path: str, minimum: float | None = None, strict: bool = False,
               maximum: float | None = None) -> float:
        """A finite number, optionally ``>= minimum`` (``>`` with ``strict``) and ``<= maximum``."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {type_name(value)}")
        try:
            v = float(value)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            self.fail(path, f"expected a finite number, got {value}")
        if minimum is not None and (v <= minimum if strict else v < minimum):
            self.fail(path, f"must be {'>' if strict else '>='} {minimum:g}, got {value}")
        if maximum is not None and v > maximum:
            self.fail(path, f"must be <= {maximum:g}, got {value}")
        return v

    def positive(self, value, path: str, maximum: float | None = None) -> float:
        return self.number(value, path, 0.0, strict=True, maximum=maximum)

    def integer(self, value, path: str, minimum: int, maximum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, f"expected an integer, got {type_name(value)}")
        if value < minimum:
            self.fail(path, f"must be >= {minimum}, got {value}")
        if maximum is not None and value > maximum:
            self.fail(path, f"must be <= {maximum}, got {value}")
        return value

    def string(self, value, path: str) -> str:
        if not isinstance(value, str) or not value.strip():
            self.fail(path, f"expected a non-empty string, got {type_name(value)}")
        return value

    def boolean(self, value, path: str) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"expected true or false, got {type_name(value)}")
        return value

    def vector(self, value, path: str, n: int, positive: bool = False,
               maximum: float | None = None) -> tuple[float, ...]:
        """A list of ``n`` finite numbers (each > 0 with ``positive``, each |v| <= ``maximum``)."""
        if not isinstance(value, list):
            self.fail(path, f"expected a list of {n} numbers, got {type_name(value)}")
        if len(value) != n:
            self.fail(path, f"expected {n} numbers, got {len(value)}")
        out = []
        for i, v in enumerate(value):
            p = f"{path}[{i}]"
            x = self.positive(v, p) if positive else self.number(v, p)
            if maximum is not None and abs(x) > maximum:
                self.fail(p, f"must be within +-{maximum:g}, got {v}")
            out.append(x)
        return tuple(out)

    def points(self, value, path: str, minimum: int, maximum: float | None = None) -> np.ndarray:
        """A list of at least ``minimum`` [x, y] points -> (k, 2) array."""
        if not isinstance(value, list):
            self.fail(path, f"expected a list of [x, y] points, got {type_name(value)}")
        if len(value) < minimum:
            self.fail(path, f"expected at least {minimum} points, got {len(value)}")
        return np.array([self.vector(q, f"{path}[{i}]", 2, maximum=maximum) for i, q in enumerate(value)])
