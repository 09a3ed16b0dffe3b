"""The scene file's validator: the package's generic checks with the scene's conventions.

Every check raises the error class it was given with ``WHERE: KEY.PATH: problem``, so a user sees
the file (or stream line) and the key at once. Numbers must be finite; booleans are never numbers.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.validation import Checker, describe, join, show

#: Words that mean a 3D rotation; in version 1 scenes shapes rotate about z only.
ROTATION_WORDS = ("orientation", "quaternion", "rotation", "rpy", "roll", "pitch", "euler")


def fmt(v: float) -> str:
    """A number as it reads best in a message."""
    return f"{v:.6g}"


class Validator(Checker):
    """The package's :class:`~placement.validation.Checker` with the scene file's conventions: unknown
    keys named with their whole path (and a hint for rotation words), upper bounds on numbers,
    null lists read as empty, and point lists."""

    def __init__(self, where: str, error: type[PlacementError] = PlacementError) -> None:
        super().__init__(where, error)  # a default error class: scene parts are parsed in updates too

    # -- structure -----------------------------------------------------
    def mapping(
        self, value: Any, path: str, allowed: Mapping[str, str] | Iterable[str], required: Iterable[str] = ()
    ) -> dict[str, Any]:
        """``value`` must be a mapping with string keys among ``allowed`` and every ``required`` key."""
        if not isinstance(value, dict):
            self.fail(path, f"expected a mapping, got {describe(value)}")
        for key in value:
            if key not in allowed:
                hint = ""
                if show(key).lower() in ROTATION_WORDS:
                    hint = " (shapes and objects rotate about z only: use 'yaw' [rad])"
                self.fail("", f"unknown key '{join(path, key)}'; allowed: {', '.join(sorted(allowed))}{hint}")
        for key in required:
            if key not in value:
                self.fail("", f"missing required key '{join(path, key)}'")
        return value

    def items(self, value: Any, path: str) -> list[Any]:
        """A list (null reads as an empty list)."""
        if value is None:
            return []
        if not isinstance(value, list):
            self.fail(path, f"expected a list, got {describe(value)}")
        return value

    # -- scalars -------------------------------------------------------
    def number(
        self, value: Any, path: str, minimum: float | None = None, strict: bool = False, maximum: float | None = None
    ) -> float:
        """A finite number, optionally ``>= minimum`` (``>`` with ``strict``) and ``<= maximum``."""
        v = super().number(value, path, minimum, strict)
        if maximum is not None and v > maximum:
            self.fail(path, f"must be <= {maximum:g}, got {show(value)}")
        return v

    def positive(self, value: Any, path: str, maximum: float | None = None) -> float:
        return self.number(value, path, 0.0, strict=True, maximum=maximum)

    def integer(self, value: Any, path: str, minimum: int | None = None, maximum: int | None = None) -> int:
        v = super().integer(value, path, minimum)
        if maximum is not None and v > maximum:
            self.fail(path, f"must be <= {maximum}, got {show(value)}")
        return v

    def vector(
        self,
        value: Any,
        path: str,
        length: int | None = None,
        what: str = "numbers",
        *,
        positive: bool = False,
        maximum: float | None = None,
    ) -> tuple[float, ...]:
        """A list of ``length`` (any number if None) finite numbers (each > 0 with ``positive``, each
        |v| <= ``maximum``)."""
        count = "" if length is None else f"{length} "
        if not isinstance(value, list):
            self.fail(path, f"expected a list of {count}{what}, got {describe(value)}")
        if length is not None and len(value) != length:
            self.fail(path, f"expected {count}{what}, got {len(value)}")
        out = []
        for i, v in enumerate(value):
            p = f"{path}[{i}]"
            x = self.positive(v, p) if positive else self.number(v, p)
            if maximum is not None and abs(x) > maximum:
                self.fail(p, f"must be within +-{maximum:g}, got {show(v)}")
            out.append(x)
        return tuple(out)

    def points(self, value: Any, path: str, minimum: int, maximum: float | None = None) -> npt.NDArray[np.float64]:
        """A list of at least ``minimum`` [x, y] points -> (k, 2) array."""
        if not isinstance(value, list):
            self.fail(path, f"expected a list of [x, y] points, got {describe(value)}")
        if len(value) < minimum:
            self.fail(path, f"expected at least {minimum} points, got {len(value)}")
        return np.array([self.vector(q, f"{path}[{i}]", 2, maximum=maximum) for i, q in enumerate(value)])
