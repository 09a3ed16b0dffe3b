"""Time-efficient robot base placement for mobile manipulation.

Public API (see README and docs/): robots (:func:`load_robot`), the manipulability measure, reachability
maps (:func:`build_map`, :func:`open_map`, :func:`check_map`), IK, and planning (:func:`plan`,
:class:`Planner`, typed results). The names and where they live are listed once, in ``__init__.pyi``:
each loads its module on first use, so importing the package costs no numba, zarr or pinocchio (about
1.6 s), a command's ``--help`` answers at once and opening a map (the online path) does not pay for the
builder. Importing it changes no environment variable (:mod:`placement.process_env`).
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
