"""Beam sections (PBAR/PBARL/PBEAM/PBEAML) and the CBAR/CBEAM element against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from pyNastran.bdf.cards.properties.bars import PBARL

from torchrom.errors import InputError
from torchrom.fe.sections import rectangles, section, torsion_constant

from .fe_decks import model_of, new_deck


def test_library_sections_match_closed_forms():
    # ROD r = 0.5, TUBE (1, 0.8): exact π r⁴/4 and π r⁴/2
    s = section(PBARL(1, 1, "ROD", [0.5]), "PBARL 1")
    assert s.A == pytest.approx(np.pi * 0.25) and s.I1 == pytest.approx(np.pi * 0.5**4 / 4)
    assert s.J == pytest.approx(np.pi * 0.5**4 / 2) and s.k1 == 0.9
    s = section(PBARL(1, 1, "TUBE", [1.0, 0.8]), "PBARL 1")
    assert s.I2 == pytest.approx(np.pi * (1 - 0.8**4) / 4)
    assert s.J == pytest.approx(np.pi * (1 - 0.8**4) / 2)
    # BAR b = 2 (z), h = 3 (y): b h³/12, h b³/12; J of a 2:3 rectangle: β a c³ with the series
    # solution β(1.5) = 0.196 (Roark Table 10.7: 0.1958); the formula is within 0.5 %
    s = section(PBARL(1, 1, "BAR", [2.0, 3.0]), "PBARL 1")
    assert (s.A, s.I1, s.I2) == pytest.approx((6.0, 2 * 27 / 12, 3 * 8 / 12))
    assert s.J == pytest.approx(0.1958 * 3 * 8, rel=5e-3)
    # BOX 4 (z) x 3 (y), top/bottom t 0.2, sides 0.3: outer minus inner rectangle; Bredt J
    s = section(PBARL(1, 1, "BOX", [4.0, 3.0, 0.2, 0.3]), "PBARL 1")
    assert s.A == pytest.approx(12 - 3.4 * 2.6)
    assert s.I1 == pytest.approx((4 * 27 - 3.4 * 2.6**3) / 12)
    assert s.J == pytest.approx(4 * (3.7 * 2.8) ** 2 / (2 * 3.7 / 0.2 + 2 * 2.8 / 0.3))
    # its shear factors: the side walls' share between top and bottom (plane 1, shear along
    # y), the top and bottom walls' between the sides (plane 2); TUBE 0.5 (thin-walled tube)
    assert (s.k1, s.k2) == pytest.approx((2 * 2.6 * 0.3 / s.A, 2 * 3.4 * 0.2 / s.A))
    assert section(PBARL(1, 1, "TUBE", [1.0, 0.8]), "p").k1 == 0.5
    # I: depth 10, flanges 6 x 0.8, web 0.5: Σ w h³/12 + a d², thin-walled J = Σ b t³/3
    s = section(PBARL(1, 1, "I", [10.0, 6.0, 6.0, 0.5, 0.8, 0.8]), "PBARL 1")
    web = 10 - 1.6
    I1 = 2 * (6 * 0.8**3 / 12 + 6 * 0.8 * (5 - 0.4) ** 2) + 0.5 * web**3 / 12
    assert s.A == pytest.approx(2 * 4.8 + 0.5 * web) and s.I1 == pytest.approx(I1)
    assert s.I2 == pytest.approx(2 * 0.8 * 6**3 / 12 + web * 0.5**3 / 12)
    assert s.J == pytest.approx((2 * 6 * 0.8**3 + (10 - 0.8) * 0.5**3) / 3)
    # T [0.03, 0.03, 0.004, 0.004] as NX Nastran prints its PBAR equivalent (see
    # library_shear_factors): A, I1, I2, J and the shear factors K1, K2
    t = section(PBARL(1, 1, "T", [0.03, 0.03, 0.004, 0.004]), "p")
    assert (t.A, t.I1, t.I2, t.J) == pytest.approx((2.24e-4, 1.8554e-8, 9.1387e-9, 1.2373e-9),
                                                   rel=5e-5)
    assert (t.k1, t.k2) == pytest.approx((0.46429, 0.53571), rel=1e-5)
    # T and CHAN are symmetric about one axis: no product of inertia
    assert section(PBARL(1, 1, "T", [6.0, 10.0, 0.8, 0.5]), "p").I12 == pytest.approx(0.0)
    ch = section(PBARL(1, 1, "CHAN", [4.0, 10.0, 0.5, 0.8]), "p")
    assert ch.I12 == pytest.approx(0.0, abs=1e-12)
    assert ch.A == pytest.approx(10 * 0.5 + 2 * 3.5 * 0.8)


def test_rectangles_and_torsion_errors():
    # two squares side by side = one 1 x 2 rectangle
    A, I1, I2, I12 = rectangles([(0.5, 0.5, 1, 1), (0.5, 1.5, 1, 1)])
    assert (A, I1, I2, I12) == pytest.approx((2.0, 2 / 12, 8 / 12, 0.0))
    with pytest.raises(InputError, match="HAT"):
        torsion_constant("HAT", [1, 2, 3, 4])


def _cantilever(kind: str, n: int = 4, L: float = 2.0, coupmass: bool = False):
    m = new_deck()
    if coupmass:
        m.add_param("COUPMASS", [1])
    for i in range(n + 1):
        m.add_grid(i + 1, [L * i / n, 0.0, 0.0], ps="123456" if i == 0 else "")
    m.add_mat1(1, 2.0e11, 8.0e10, None, rho=7800.0)
    if kind == "CBEAM":
        m.add_pbeam(1, 1, [0.0], ["C"], [0.01], [2e-5], [3e-5], [0.0], [4e-5], [0.0],
                    k1=0.6, k2=0.7)
    else:
        m.add_pbarl(1, 1, "ROD", [0.05])
    for i in range(n):
        add = m.add_cbeam if kind == "CBEAM" else m.add_cbar
        add(i + 1, 1, [i + 1, i + 2], [0.0, 0.0, 1.0], None)
    return model_of(m)


def test_cbeam_tip_deflection_includes_shear_exactly():
    """Two-node Timoshenko element: tip deflection of a cantilever under a tip load is exact,
    δ = P L³/(3 E I) + P L/(K G A), in both planes (PBEAM K1 = 0.6, K2 = 0.7)."""
    fe = _cantilever("CBEAM")
    E, G, A, L, P = 2.0e11, 8.0e10, 0.01, 2.0, 1000.0
    # orientation vector along z: element y = basic z (plane 1: I1, K1), element z = -basic y
    for comp, I, K in ((3, 2e-5, 0.6), (2, 3e-5, 0.7)):
        u = fe.linear_static(fe.nodal_load({(5, comp): P}))
        tip = fe.expand(u)[4, comp - 1]
        assert tip == pytest.approx(P * L**3 / (3 * E * I) + P * L / (K * G * A), rel=1e-10)


def test_cbeam_torsional_inertia_and_tapered_area():
    """CBEAM lumps ρ (I1 + I2) L / 2 of torsional inertia at each end (as Nastran's CBEAM;
    CBAR has none): the first torsion mode of the 4-element cantilever equals the lumped chain's
    ω_1 = 2 √(G J / (h I_p)) sin(π / (4N)) with end inertia half the interior one I_p."""
    fe = _cantilever("CBEAM")
    h, N, G, J = 0.5, 4, 8.0e10, 4e-5
    Ip = 7800.0 * 5e-5 * h
    modes = fe.modes(12)
    torsion = [f for f, k in zip(modes.frequencies_hz, modes.kinds) if k == "torsion"]
    w1 = 2 * np.sqrt(G * J / h / Ip) * np.sin(np.pi / (4 * N))
    assert torsion[0] == pytest.approx(w1 / (2 * np.pi), rel=1e-10)
    # PARAM COUPMASS: the torsional inertia stays lumped (as MSC Nastran's coupled CBEAM mass,
    # tests/decks/pynastran_buckled), so the torsion mode is the same lumped chain's
    modes = _cantilever("CBEAM", coupmass=True).modes(12)
    torsion = [f for f, k in zip(modes.frequencies_hz, modes.kinds) if k == "torsion"]
    assert torsion[0] == pytest.approx(w1 / (2 * np.pi), rel=1e-10)
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0])
    m.add_grid(2, [1.0, 0.0, 0.0])
    m.add_mat1(1, 2.0e11, 8.0e10, None, rho=7800.0)
    m.add_pbeam(1, 1, [0.0, 1.0], ["C", "YES"], [0.01, 0.02], [2e-5, 2e-5], [3e-5, 3e-5],
                [0.0, 0.0], [4e-5, 4e-5], [0.0, 0.0])
    m.add_cbeam(1, 1, [1, 2], [0.0, 0.0, 1.0], None)
    # tapered (A from 0.01 to 0.02, linear): the axial stiffness E ΔA / (L ln(A_B / A_A))
    K = model_of(m, autospc=False).stiffness_matrix().toarray()
    assert K[0, 0] == pytest.approx(2.0e11 * 0.01 / np.log(2.0), rel=1e-12)


def test_tapered_pbeaml_stations():
    """PBEAML ROD with radius 0.05 at end A and 0.08 at end B: each station's section from its
    dimensions (A = π r², J = π r⁴ / 2), linear between stations; the axial stiffness of the
    element is then E (A_B − A_A) / (L ln(A_B / A_A)) (round-off) and NSM per station is kept."""
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0])
    m.add_grid(2, [1.5, 0.0, 0.0])
    m.add_mat1(1, 2.0e11, 8.0e10, None, rho=7800.0)
    m.add_pbeaml(1, 1, "ROD", [0.0, 1.0], [[0.05], [0.08]], so=["YES", "YES"], nsm=[0.2, 0.6])
    m.add_cbeam(1, 1, [1, 2], [0.0, 0.0, 1.0], None)
    fe = model_of(m, autospc=False)
    (taper,) = fe.mesh.bars.taper.values()
    Aa, Ab = np.pi * 0.05**2, np.pi * 0.08**2
    np.testing.assert_allclose(taper.A, [Aa, Ab], rtol=1e-14)
    np.testing.assert_allclose(taper.J, [np.pi * 0.05**4 / 2, np.pi * 0.08**4 / 2], rtol=1e-14)
    np.testing.assert_allclose(taper.nsm, [0.2, 0.6])
    K = fe.stiffness_matrix().toarray()
    assert K[0, 0] == pytest.approx(2.0e11 * (Ab - Aa) / (1.5 * np.log(Ab / Aa)), rel=1e-12)


def test_pbeam_neutral_axis_fields():
    """PBEAM N1(A), N2(A), N1(B), N2(B) become ``Section.na``; a blank end B takes end A's
    values (MSC QRG PBEAM), and blank fields are 0 (the neutral axis on the shear centre)."""
    m = new_deck()
    m.add_mat1(1, 7e10, 2.7e10, None, rho=2700.0)
    p = m.add_pbeam(1, 1, [0.0], ["YES"], [1e-4], [2e-9], [3e-9], [0.0], [1e-9])
    assert section(p, "PBEAM 1").na == (0.0, 0.0, 0.0, 0.0)
    p.n1a, p.n2a, p.n1b, p.n2b = -0.004, 0.003, None, None
    assert section(p, "PBEAM 1").na == (-0.004, 0.003, -0.004, 0.003)
    p.n1b, p.n2b = 0.001, 0.0
    assert section(p, "PBEAM 1").na == (-0.004, 0.003, 0.001, 0.0)
