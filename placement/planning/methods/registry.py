"""The planning methods by name: the one place that maps a method's name to its strategy."""

from __future__ import annotations

from placement.errors import PlacementError
from placement.method_names import DEFAULT_METHOD
from placement.planning.methods.base import Method
from placement.planning.methods.fixed import Fixed
from placement.planning.methods.optimal import Global, Optimal
from placement.planning.methods.weighted import Irm, Sequential, SingleStep

#: Method name -> strategy class, in the order the CLI and the evaluation list them.
METHODS: dict[str, type[Method]] = {m.name: m for m in (Global, Sequential, SingleStep, Irm, Fixed, Optimal)}


def method_named(name: str) -> Method:
    """The strategy of the method called ``name`` (PlacementError naming the choices for another)."""
    try:
        return METHODS[name]()
    except (KeyError, TypeError):  # TypeError: an unhashable name
        raise PlacementError(f"unknown method '{name}'; choose from {', '.join(METHODS)}") from None


__all__ = ["DEFAULT_METHOD", "METHODS", "method_named"]
