"""Built-in geometrically nonlinear FE solver, Nastran BDF input/output, heavy Goland wing.

Public API (contract with :mod:`torchrom.identify` and :mod:`torchrom.aero`)::

    from torchrom.fe import FEModel, read_bdf, write_bdf, goland
    fe = read_bdf("model.bdf")      # or goland(store_x=..., density=None -> calibrated)
    fe.n_dof, fe.grid_ids, fe.grid_xyz, fe.expand(u), fe.dof_index(grid_id, component)
    fe.mass_matrix(), fe.stiffness_matrix()                      # scipy.sparse, free DOFs
    fe.internal_force(u), fe.tangent_stiffness(u), fe.material_tangent(u)
    fe.internal_force_torch(u), fe.material_force_torch(u, v)     # differentiable (torch)
    fe.modes(n), fe.static_solve(load, ...), fe.transient(...), fe.pressure_load(p)
    solve_static("deck.bdf")        # the deck's own static subcases (SOL 101/106/400)
    fe.output_points, fe.name, fe.units, fe.source, fe.bdf (pyNastran deck incl. aero cards)
"""

from .bdf_read import read_bdf
from .bdf_write import write_bdf
from .goland import (
    DEFAULT_STORE_X,
    TABLE2_HZ,
    calibrate_density,
    goland,
    goland_bdf,
    goland_stiffness,
)
from .model import FEModel, LinearElementWarning
from .solvers import Modes, StaticResult, TransientResult
from .static_cases import StaticRun, solve_static

__all__ = [
    "FEModel",
    "LinearElementWarning",
    "Modes",
    "StaticResult",
    "StaticRun",
    "solve_static",
    "TransientResult",
    "read_bdf",
    "write_bdf",
    "goland",
    "goland_bdf",
    "goland_stiffness",
    "calibrate_density",
    "DEFAULT_STORE_X",
    "TABLE2_HZ",
]
