"""Pure numba kernels: arrays in, arrays out. Nothing here knows about robots or files."""
