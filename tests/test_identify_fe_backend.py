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


def test_projected_tangents_of_several_points_equal_the_protocols_one_by_one():
    """The backend's projected tangents Φᵀ K_T(Φq) Φ of several points at once (the FE's
    tangent_stiffnesses: one co-rotational pass for them all) equal the protocol's default,
    a tangent per point (FEBackend.projected_tangents), to 1e-13 of the largest entry
    (measured 1e-16), at displacements of a tenth of the strip's length; each point counts as
    one tangent evaluation."""
    from torchrom.identify.backend import FEBackend
    from torchrom.identify.fe_backend import BuiltinFEBackend

    fe = model_of(plate_strip(6, 2, 1.0, 0.2, 0.002, 7e10, 0.3, 2700.0), "plate")
    be = BuiltinFEBackend(fe)
    _, Phi = be.modes(4)
    Q = 0.1 * np.random.default_rng(0).normal(size=(5, 4)) / np.abs(Phi).max()
    batch, none = be.projected_tangents(Phi, Q)
    assert none is None and be.counters.tangent_evaluations == 5
    ref, _ = FEBackend.projected_tangents(be, Phi, Q)
    assert be.counters.tangent_evaluations == 10
    assert np.abs(batch - ref).max() <= 1e-13 * np.abs(ref).max()
