"""Element kernels: Green-strain points (rods, membranes, shear panels) and linear blocks.

Each module turns a set of cards (arrays in :mod:`torchrom.fe.mesh`) into either integration points
for the nonlinear kernel (:mod:`.green`) or dense element blocks (DOF indices into the all-grid
vector and ``(n, k, k)`` matrices) that :mod:`torchrom.fe.assembly` scatters into sparse matrices.
"""
