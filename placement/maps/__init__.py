"""Reachability maps, the offline half: the grid, build specs, sampling and the build, witnesses,
completion, self-collision filtering, the accuracy check, and the map object the planner opens.

Importing this package imports nothing heavy: :mod:`placement.maps.rmap` (open a map) does not
import the builder (:mod:`placement.maps.build`), so the online path never pays for it.
"""
