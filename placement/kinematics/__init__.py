"""Arm kinematics over a robot preset: the extended manipulability measure and inverse kinematics
(typed wrappers around the numba kernels of :mod:`placement.kernels`)."""
