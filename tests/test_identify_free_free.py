"""Free-free structures in the identification (issue 35 item 2): rigid-body modes kept in the
ROM basis at 0 Hz, the dual-mode static solves under inertia relief, the nonlinear terms on the
elastic coordinates only.

Model: a free CQUAD4 strip (8 x 2 elements, 1 m x 0.2 m x 2 mm aluminium), six rigid-body
modes, geometrically nonlinear (total Lagrangian).
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError

from .fe_decks import model_of, plate_strip


@pytest.fixture(scope="module")
def free_plate():
    m = plate_strip(8, 2, 1.0, 0.2, 0.002, 7e10, 0.3, 2700.0)
    m.spcs.clear()
    return model_of(m, "free_plate")


def test_rigid_translations_strain_nothing_rigid_rotations_do(free_plate):
    """Why the ROM keeps the nonlinear terms off its rigid-body coordinates: fitted on a basis
    of the six rigid motions (mass-normalised) and two elastic modes, every K2/K3 entry that
    involves a translation is round-off (measured ≤ 2e-11 of the elastic K1 at the
    identification amplitude; bound 1e-8), while K3 entries involving a (linearised) rotation
    are of the order of the elastic ones (measured 0.68 of the largest elastic K3; bound 0.1):
    u = θ × x strains a total-Lagrangian model at second order, an artificial stiffening."""
    from torchrom.fe.rigid import rigid_motions_on_free
    from torchrom.identify.build import as_backend
    from torchrom.identify.stiffness import identification_amplitudes, identify_stiffness_tangent

    be = as_backend(free_plate)
    _, V = be.modes(8)
    M = free_plate.mass_matrix()
    X, _, _ = rigid_motions_on_free(free_plate.T, free_plate.grid_xyz)
    X = X / np.sqrt(np.einsum("ik,ik->k", X, M @ X))
    Phi = np.concatenate([X, V[:, 6:8]], axis=1)
    amps = identification_amplitudes(Phi, 0.01, be.reference_length, be.translational_dofs)
    st, *_ = identify_stiffness_tangent(be, Phi, amps)
    el, tr, rot = [6, 7], [0, 1, 2], [3, 4, 5]
    k1, a = np.abs(st.K1[np.ix_(el, el)]).max(), amps.max()

    def largest(A, idx):
        return max(np.abs(np.take(A, idx, axis=ax)).max() for ax in range(A.ndim))

    assert largest(st.K2, tr) * a / k1 <= 1e-8
    assert largest(st.K3, tr) * a * a / k1 <= 1e-8
    assert np.abs(st.K1[:6]).max() <= 1e-8 * k1
    assert largest(st.K3, rot) >= 0.1 * np.abs(st.K3[np.ix_(el, el, el, el)]).max()


def test_identify_a_free_structure(free_plate):
    """identify on a free structure: the six rigid-body modes first at 0 Hz with zero rows in
    K1, K2, K3 and the damping, the elastic frequencies the FE's (1e-9), dual modes from static
    solves under inertia relief, M-orthogonal to the rigid-body modes (1e-10)."""
    from torchrom.identify.basis import DualModeOptions, transverse_combinations
    from torchrom.identify.build import IdentifyOptions, as_backend, identify

    modes = free_plate.modes(3)
    kinds = ["rigid-body"] * modes.n_rigid + list(modes.kinds)
    comb = transverse_combinations(kinds)
    assert min(min(c) for c in comb) == 7
    be = as_backend(free_plate)
    res = identify(be, IdentifyOptions(n_linear=9, n_dual=2, dual=DualModeOptions(
        combinations=comb, n_amplitudes=4)))
    rom, r = res.rom, 6
    f = np.asarray(rom.frequencies_hz)
    assert np.all(f[:r] == 0.0)
    assert np.allclose(f[r:9], modes.frequencies_hz, rtol=1e-9)
    for name in ("K1", "K2", "K3", "D1", "D2", "D3"):
        A = np.asarray(getattr(rom, name))
        assert all(np.abs(np.take(A, range(r), axis=ax)).max() == 0.0 for ax in range(A.ndim))
        assert np.abs(A).max() > 0.0
    assert res.counters["static_solves"] > 0
    G, dual = res.basis.Phi[:, :r], res.basis.Phi[:, 9:]
    assert np.abs(G.T @ (free_plate.mass_matrix() @ dual)).max() <= 1e-10
    assert rom.metadata["basis"]["n_rigid"] == r
    # the default output is where the first *elastic* mode moves most (a rigid-body mode moves
    # every grid alike, so its largest entry says nothing about the wing)
    names, C = rom.output_matrix(["max_mode1"])
    phi1 = res.basis.Phi[:, r]
    assert abs(C[0, r]) == pytest.approx(np.abs(phi1[be.translational_dofs]).max(), rel=1e-12)


def test_dual_combination_on_a_rigid_body_mode_is_refused(free_plate):
    from torchrom.identify.basis import DualModeOptions, dual_basis, linear_basis
    from torchrom.identify.build import as_backend

    be = as_backend(free_plate)
    with pytest.raises(InputError, match=r"combination \(1, 7\) loads a rigid-body mode"):
        dual_basis(be, linear_basis(be, 7), 1, DualModeOptions(combinations=((1, 7),)))
