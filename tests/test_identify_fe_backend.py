"""The FE-model backend of identify (torchrom/identify/fe_backend.py): its static solve."""

from __future__ import annotations

import numpy as np

from .fe_decks import model_of, plate_strip


def test_static_solve_drops_a_continuation_guess_that_fails():
    """A restrained plate strip (co-rotational CQUAD4s) under a tip force that bends it ~8 %
    of its length: from a guess Newton cannot converge from (the linear response reversed and
    30x too large, as the dual-mode walk's scaled previous solution can be past a limit load)
    the backend's solve reaches the solution from no guess (to 1e-8 of it; both converge to
    the backend's tolerance, 1e-8 of the load). static_solve alone, which cuts its load steps
    around its start, did not converge from that guess in 12 cuts (measured: 3 min here)."""
    from torchrom.identify.fe_backend import BuiltinFEBackend

    fe = model_of(plate_strip(8, 2, 1.0, 0.2, 0.002, 7e10, 0.3, 2700.0), "plate")
    row = fe.mesh.grid_row()
    tip = [g for g in fe.grid_ids if abs(fe.grid_xyz[row[g], 0] - 1.0) < 1e-9]
    F = fe.nodal_load({(g, 3): 60.0 / len(tip) for g in tip})
    be = BuiltinFEBackend(fe)
    ref = be.static_solve(F)
    bad = -30.0 * np.linalg.solve(fe.stiffness_matrix().toarray(), F)
    sol = be.static_solve(F, u0=bad)
    assert np.abs(sol.u - ref.u).max() <= 1e-8 * np.abs(ref.u).max()
