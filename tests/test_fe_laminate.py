"""PCOMP laminates: classical lamination theory against hand values, PCOMP of isotropic plies
equal to PSHELL, an orthotropic cantilever strip against beam theory, bad lay-ups refused."""

from __future__ import annotations

import numpy as np
import pytest
from pyNastran.bdf.bdf import BDF

from torchrom.errors import InputError
from torchrom.fe.laminate import laminate, rotate_q

from .fe_decks import model_of, plate_strip
from .test_fe_solvers import BETA, _bending_freqs

E1, E2, NU12, G12 = 1.5e11, 1.0e10, 0.3, 5.0e9


def _mat8_deck(nu12=NU12) -> BDF:
    m = BDF(debug=None)
    m.add_mat8(2, E1, E2, nu12, G12, 4e9, 3e9, rho=1600.0)
    return m


def test_cross_ply_a_and_d_match_hand_values():
    """[0/90]s, plies 0.1 thick: A = Σ Q̄ t, D = Σ Q̄ (z_k³ − z_(k−1)³)/3 by hand."""
    m = _mat8_deck()
    p = m.add_pcomp(1, [2, 2], [0.1, 0.1], [0.0, 90.0], lam="SYM")
    lam = laminate(p, m.materials)
    nu21 = NU12 * E2 / E1
    q11, q22, q12 = E1 / (1 - NU12 * nu21), E2 / (1 - NU12 * nu21), NU12 * E2 / (1 - NU12 * nu21)
    assert lam.A[0, 0] == pytest.approx(0.2 * (q11 + q22))
    assert lam.A[0, 1] == pytest.approx(0.4 * q12) and lam.A[2, 2] == pytest.approx(0.4 * G12)
    # outer 0° plies at |z| in [0.1, 0.2], inner 90° plies in [0, 0.1]
    outer, inner = 2 * (0.2**3 - 0.1**3) / 3, 2 * 0.1**3 / 3
    assert lam.D[0, 0] == pytest.approx(q11 * outer + q22 * inner)
    assert lam.D[1, 1] == pytest.approx(q22 * outer + q11 * inner)
    assert lam.thickness == pytest.approx(0.4) and lam.mass_per_area == pytest.approx(640.0)
    assert lam.shear == pytest.approx(5 / 6 * 0.4 * 3.5e9)
    # a 90° rotation swaps the axes; ±45 gives equal A11 = A22
    Q = np.array([[q11, q12, 0], [q12, q22, 0], [0, 0, G12]])
    np.testing.assert_allclose(rotate_q(Q, 90.0)[[1, 0, 2]][:, [1, 0, 2]], Q, atol=1e-6 * q11)
    R45 = rotate_q(Q, 45.0)
    assert R45[0, 0] == pytest.approx(R45[1, 1])
    assert R45[0, 0] == pytest.approx((q11 + q22 + 2 * q12 + 4 * G12) / 4)


def test_pcomp_of_isotropic_plies_equals_pshell():
    """Three MAT1 plies (any angles) of total thickness t: the PSHELL matrices of thickness t."""
    L, b, t, E, nu, rho = 1.0, 0.1, 0.01, 7e10, 0.3, 2700.0
    ref = model_of(plate_strip(6, 2, L, b, t, E, nu, rho))
    m = plate_strip(6, 2, L, b, t, E, nu, rho)
    m.properties.pop(1)
    m.add_pcomp(1, [1, 1, 1], [0.3 * t, 0.4 * t, 0.3 * t], [0.0, 30.0, 0.0])
    fe = model_of(m)
    assert any("PCOMP 1: equivalent laminate" in n for n in fe.notes)
    for name in ("stiffness_matrix", "mass_matrix"):
        A, B = getattr(fe, name)(), getattr(ref, name)()
        # MAT1 G = E/(2(1+ν)) as PSHELL; transverse shear 5/6 G t against PSHELL's TS/T default,
        # which pyNastran stores rounded (0.833333): 4e-7 relative in the shear terms
        assert abs(A - B).max() <= 1e-6 * abs(B).max(), name


def test_orthotropic_cantilever_strip_matches_beam_theory():
    """Unidirectional MAT8 (ν12 = 0: no Poisson coupling) along the span: the strip bends like a
    beam with E I = b D11; first two modes within 2 % (as the isotropic strip)."""
    L, b, t, rho = 1.0, 0.1, 0.01, 1600.0
    m = plate_strip(20, 2, L, b, t, 1.0, 0.0, rho)
    m.properties.pop(1)
    m.materials.pop(1)
    m.add_mat8(1, E1, E2, 0.0, G12, 4e9, 3e9, rho=rho)
    m.add_pcomp(1, [1, 1], [t / 2, t / 2], [0.0, 0.0])
    fe = model_of(m)
    EI, mass = b * E1 * t**3 / 12, rho * b * t
    fb = _bending_freqs(fe)
    for k in range(2):
        exact = BETA[k] ** 2 / (2 * np.pi * L**2) * np.sqrt(EI / mass)
        assert fb[k] == pytest.approx(exact, rel=0.02)


def test_unsymmetric_and_unbalanced_laminates_are_refused():
    m = plate_strip(2, 1, 1.0, 0.1, 0.01, 7e10, 0.3, 2700.0)
    m.properties.pop(1)
    m.add_mat8(2, E1, E2, NU12, G12, 4e9, 3e9, rho=1600.0)
    m.add_pcomp(1, [2, 2], [0.005, 0.005], [0.0, 90.0])
    with pytest.raises(InputError, match="PCOMP 1: the laminate couples membrane and bending"):
        model_of(m)
    m.properties.pop(1)
    m.add_pcomp(1, [2, 2, 2], [0.003, 0.004, 0.003], [30.0, 30.0, 30.0])
    with pytest.raises(InputError, match=r"unbalanced laminate \(A16/A26"):
        model_of(m)
