"""The planning methods' names and the default one, without importing the planner.

For what needs only the names (the command line's ``--method`` choices and help): the planner's
registry (:mod:`placement.planning.methods.registry`) maps the same names, in the same order, to
their strategies, and a test keeps the two equal.
"""

#: The method names, in the order the command line and the evaluation list them.
METHOD_NAMES: tuple[str, ...] = ("global", "sequential", "single-step", "irm", "fixed", "optimal")

#: The method a planner uses unless told otherwise.
DEFAULT_METHOD = "global"

__all__ = ["DEFAULT_METHOD", "METHOD_NAMES"]
