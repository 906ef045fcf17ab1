"""CBAR/CBEAM offsets (OFFT), pin flags and the product of inertia I12.

References: the same bars with their offsets built as separate grids and RBAR rigid links
(exact, so to rounding), the Euler–Bernoulli pinned-pinned frequencies
ω_n = (nπ)² √(EI/ρA) / L² (with the mesh's convergence, measured), the propped cantilever
under a mid-span load δ = 7 P L³ / (768 E I) (by superposition; Hermite elements are exact for
nodal loads), the cantilever flexibility of an unsymmetric section
(u_tip = L³/3 D⁻¹ P, D = E [[I1, I12], [I12, I2]]) and the same section about its principal
axes with the orientation vector turned accordingly.
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError

from .fe_decks import model_of, new_deck, rotation

E, G, RHO = 2.0e11, 8.0e10, 7800.0


def _close(a, b, rel):
    a, b = a.toarray(), b.toarray()
    np.testing.assert_allclose(a, b, rtol=0, atol=rel * np.abs(b).max())


def _offset_frames():
    """A skew cantilever of four bars whose grids have rotated displacement systems; per bar
    (OFFT, WA, WB, v as given on the card)."""
    axis = np.array([1.0, 0.4, -0.3])
    pts = [axis * k + np.array([0.0, 0.05 * k * k, 0.0]) for k in range(5)]
    cards = [("GGG", [0.1, 0.2, -0.05], [0.0, -0.1, 0.15], [0.0, 0.0, 1.0]),
             ("BGO", [0.05, -0.1, 0.2], [0.1, 0.0, -0.2], [0.2, 0.1, 1.0]),
             ("GOG", [0.02, 0.3, -0.1], [-0.1, 0.05, 0.1], [0.0, 1.0, 0.3]),
             ("BOO", [-0.1, 0.1, 0.1], [0.2, -0.2, 0.05], [0.1, 0.0, 1.0])]
    return pts, cards


def _cd_axes(k):
    """Displacement-system axes (columns) of grid k + 1 in the offset decks (CD 7 on odd k)."""
    return rotation([0.3, 1.0, 0.2], 0.7) if k % 2 else np.eye(3)


def _offset_deck(with_rbar: bool, coupled: bool, card: str = "CBAR"):
    m = new_deck()
    Rcd = rotation([0.3, 1.0, 0.2], 0.7)
    m.add_cord2r(7, [0.0, 0.0, 0.0], list(Rcd[:, 2]), list(Rcd[:, 0]))
    m.add_mat1(1, E, G, None, rho=RHO)
    if card == "CBAR":
        m.add_pbar(1, 1, A=1e-3, i1=2e-6, i2=5e-7, j=1e-6, nsm=0.3)
        add = m.add_cbar
    else:  # CBEAM: Timoshenko shear (K1 = K2 = 1 by default) and torsional inertia
        m.add_pbeam(1, 1, [0.0], ["C"], [1e-3], [2e-6], [5e-7], [0.0], [1e-6], nsm=[0.3])
        add = m.add_cbeam
    if coupled:
        m.add_param("COUPMASS", [1])
    pts, cards = _offset_frames()
    for k, p in enumerate(pts):
        m.add_grid(k + 1, list(p), cd=7 if k % 2 else 0)
    for k, (offt, wa, wb, x) in enumerate(cards):
        ga, gb = k + 1, k + 2
        if not with_rbar:
            add(k + 1, 1, [ga, gb], x, None, offt=offt, wa=wa, wb=wb)
            continue
        # the same bar between two new grids at its ends, rigidly linked to GA and GB; the
        # offsets and v converted to basic here, by the card's definition (MSC QRG CBAR)
        v = _cd_axes(k) @ np.array(x) if offt[0] == "G" else np.array(x)
        d = pts[k + 1] - pts[k]
        ex = d / np.linalg.norm(d)
        ey = v - (v @ ex) * ex
        ey /= np.linalg.norm(ey)
        offset_axes = np.column_stack((ex, ey, np.cross(ex, ey)))
        ends = []
        for code, w, j in ((offt[1], wa, k), (offt[2], wb, k + 1)):
            frame = {"G": _cd_axes(j), "B": np.eye(3), "O": offset_axes}[code]
            ends.append(pts[j] + frame @ np.array(w))
        a, b = 100 + 2 * k, 101 + 2 * k
        m.add_grid(a, list(ends[0]))
        m.add_grid(b, list(ends[1]))
        m.add_rbar(200 + 2 * k, [ga, a], "123456", "", "", "123456")
        m.add_rbar(201 + 2 * k, [gb, b], "123456", "", "", "123456")
        add(k + 1, 1, [a, b], list(v), None, offt="BGG")
    m.add_spc1(1, "123456", [1])
    return m


@pytest.mark.parametrize("card", ["CBAR", "CBEAM"])
@pytest.mark.parametrize("coupled", [False, True], ids=["lumped", "coupled"])
def test_offset_bars_equal_bars_with_rbar_links(coupled, card):
    """Offsets in every OFFT flavour (grid CD, basic, offset system) and rotated CD systems:
    K and M equal those of the bars between separate end grids carried by RBARs (1e-10 of the
    largest entry: the two are the same rigid transformation, so rounding only)."""
    fa = model_of(_offset_deck(False, coupled, card), autospc=False)
    fb = model_of(_offset_deck(True, coupled, card), autospc=False)
    assert fa.free_dofs() == fb.free_dofs()
    _close(fa.stiffness_matrix(), fb.stiffness_matrix(), 1e-10)
    _close(fa.mass_matrix(), fb.mass_matrix(), 1e-10)
    # and the offsets matter: without them the tip flexibility differs by far more
    plain = _offset_deck(False, coupled, card)
    for e in plain.elements.values():
        e.wa, e.wb = None, None
    fc = model_of(plain, autospc=False)
    diff = np.abs(fc.stiffness_matrix() - fa.stiffness_matrix()).max()
    assert diff > 1e-2 * np.abs(fa.stiffness_matrix()).max()


def _planar_beam(n: int, L: float, pins: bool, I1: float, A: float):
    """n CBARs along x, bending in the x-y plane only (components 3, 4, 5 constrained), both
    end grids clamped; with ``pins`` the end bars release θz (component 6) at the supports."""
    m = new_deck()
    m.add_mat1(1, E, G, None, rho=RHO)
    m.add_pbar(1, 1, A=A, i1=I1, i2=I1, j=1e-6)
    m.add_param("COUPMASS", [1])
    for i in range(n + 1):
        m.add_grid(i + 1, [L * i / n, 0.0, 0.0], ps="345")
    for i in range(n):
        pa = 6 if pins and i == 0 else 0
        pb = 6 if pins and i == n - 1 else 0
        m.add_cbar(i + 1, 1, [i + 1, i + 2], [0.0, 1.0, 0.0], None, pa=pa, pb=pb)
    m.add_spc1(1, "123456", [1, n + 1])
    return m


def test_pin_flags_make_a_pinned_pinned_beam():
    """Clamped supports released by PA/PB = 6: the bending frequencies are the pinned-pinned
    ones, ω_n = (nπ)² √(EI/ρA) / L². Cubic elements with consistent mass converge as h⁴: the
    relative error of mode n on N elements is measured at ≈ (nπ/N)⁴ / 1440 (3e-6, 5e-5, 3e-4
    for modes 1-3 on 12 elements), above the exact value (Rayleigh–Ritz), and falls 16-fold
    from 12 to 24 elements; asserted: 0 < error < (nπ/N)⁴ / 1000 and the ratio 16 ± 10 %.
    Clamped ends instead give 22.3733 / π² = 2.27 times the first frequency."""
    L, I1, A = 2.0, 3e-6, 2e-3
    n_mode = np.arange(1, 4)
    exact = (n_mode * np.pi) ** 2 * np.sqrt(E * I1 / (RHO * A)) / L**2
    errors = []
    for n in (12, 24):
        fe = model_of(_planar_beam(n, L, True, I1, A))
        errors.append(np.sqrt(fe.modes(3).eigenvalues) / exact - 1.0)
        assert np.all(errors[-1] > 0)
        assert np.all(errors[-1] < (n_mode * np.pi / n) ** 4 / 1000)
    np.testing.assert_allclose(errors[0] / errors[1], 16.0, rtol=0.1)
    clamped = np.sqrt(model_of(_planar_beam(12, L, False, I1, A)).modes(1).eigenvalues[0])
    assert clamped / exact[0] == pytest.approx(22.3733 / np.pi**2, rel=1e-4)


def test_pin_flag_propped_cantilever_midspan_load():
    """Clamped at x = 0, pinned at x = L by PB = 6 on the last bar, P at mid-span: by
    superposition (cantilever under P at L/2 and the prop's 5P/16 at L) the deflection is
    y(x) = P x² (9L − 11x) / (96 E I) for x ≤ L/2, 7 P L³ / (768 E I) under the load (cubic
    elements are exact for nodal loads: 1e-9)."""
    n, L, I1, P = 8, 3.0, 4e-6, 1.0e3
    m = _planar_beam(n, L, False, I1, 1e-3)
    m.elements[n].pb = 6
    fe = model_of(m)
    u = fe.expand(fe.linear_static(fe.nodal_load({(n // 2 + 1, 2): P})))
    row = fe.mesh.grid_row()
    x = L * np.arange(n // 2 + 1) / n
    y = np.array([u[row[i + 1], 1] for i in range(n // 2 + 1)])
    np.testing.assert_allclose(y, P * x**2 * (9 * L - 11 * x) / (96 * E * I1), rtol=1e-9,
                               atol=1e-12 * y.max())
    assert y[-1] == pytest.approx(7 * P * L**3 / (768 * E * I1), rel=1e-9)


def _unsymmetric(I1, I2, I12, x, k=None):
    m = new_deck()
    m.add_mat1(1, E, G, None, rho=RHO)
    k1 = k2 = k
    m.add_pbar(1, 1, A=1e-3, i1=I1, i2=I2, i12=I12, j=1e-6, k1=k1, k2=k2)
    m.add_param("COUPMASS", [1])
    axis = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    for i in range(4):
        m.add_grid(i + 1, list(axis * 0.8 * i))
    for i in range(3):
        m.add_cbar(i + 1, 1, [i + 1, i + 2], list(x), None)
    m.add_spc1(1, "123456", [1])
    return m, axis


@pytest.mark.parametrize("k", [None, 0.8], ids=["euler-bernoulli", "timoshenko"])
def test_product_of_inertia_equals_principal_axes(k):
    """PBAR I12 ≠ 0: K and M equal those of the bar with the principal moments I1', I2' (the
    eigenvalues of [[I1, I12], [I12, I2]]) and the orientation vector turned onto the first
    principal axis (1e-10: the same element, so rounding). Exact with equal shear factors K1 =
    K2, whose shear flexibility does not depend on the axes."""
    I1, I2, I12 = 4e-6, 1e-6, 1.5e-6
    x = np.array([0.0, 0.0, 1.0])
    ma, axis = _unsymmetric(I1, I2, I12, x, k)
    ey = x - (x @ axis) * axis
    ey /= np.linalg.norm(ey)
    ez = np.cross(axis, ey)
    lam, V = np.linalg.eigh(np.array([[I1, I12], [I12, I2]]))
    c, s = V[:, 1]  # the principal axis of the larger moment, in (y, z)
    # a point at (y, z) has y' = c y + s z: the new y axis is c ey + s ez, and I1' = ∫y'² dA
    mb, _ = _unsymmetric(lam[1], lam[0], 0.0, c * ey + s * ez, k)
    fa, fb = model_of(ma), model_of(mb)
    _close(fa.stiffness_matrix(), fb.stiffness_matrix(), 1e-10)
    _close(fa.mass_matrix(), fb.mass_matrix(), 1e-10)
    if k is None:
        # cantilever tip under P along y: (v, w) = L³/(3E) [[I1, I12], [I12, I2]]⁻¹ (P, 0)
        P, Ltot = 100.0, 2.4
        load = {(4, c + 1): P * ey[c] for c in range(3)}
        u = fa.expand(fa.linear_static(fa.nodal_load(load)))[3, :3]
        vw = Ltot**3 / (3 * E) * np.linalg.solve([[I1, I12], [I12, I2]], [P, 0.0])
        np.testing.assert_allclose([u @ ey, u @ ez], vw, rtol=1e-9)


def test_bar_refusals():
    """Bad OFFT, pin flags without stiffness behind them, and I1 I2 ≤ I12² are one-line
    errors naming the card, element and field."""
    m, _ = _unsymmetric(4e-6, 1e-6, 0.0, [0.0, 0.0, 1.0])
    m.elements[2].offt = "OGG"
    with pytest.raises(InputError, match=r"CBAR 2: field OFFT: expected one of GGG"):
        model_of(m)
    m, _ = _unsymmetric(4e-6, 1e-6, 0.0, [0.0, 0.0, 1.0])
    m.elements[2].pa, m.elements[2].pb = 4, 4  # torsion released at both ends
    with pytest.raises(InputError, match=r"CBAR 2: fields PA/PB: .*mechanism"):
        model_of(m)
    m, _ = _unsymmetric(4e-6, 1e-6, 3e-6, [0.0, 0.0, 1.0])
    with pytest.raises(InputError, match=r"PBAR 1: field I12: expected I1 I2 > I12²"):
        model_of(m)


# -- tapered CBEAM (PBEAM stations) ---------------------------------------------------------------

def _tapered_cantilever(n: int, stations, coupled: bool = False, k=0.0, nsi=(0.0, 0.0),
                        v=(0.0, 1.0, 0.3)):
    """Cantilever along x of n CBEAMs (orientation vector v) sharing one PBEAM whose stations
    (x/L, A, I1, I2, I12, J, NSM) are given, clamped at x = 0."""
    m = new_deck()
    m.add_mat1(1, E, G, None, rho=RHO)
    x, A, I1, I2, I12, J, nsm = (list(map(float, c)) for c in zip(*stations))
    m.add_pbeam(1, 1, x, ["YES"] * len(x), A, I1, I2, I12, J, nsm=nsm, k1=k, k2=k,
                nsia=nsi[0], nsib=nsi[1])
    for i in range(n + 1):
        m.add_grid(i + 1, [2.0 * i / n, 0.0, 0.0])
    for i in range(n):
        m.add_cbeam(i + 1, 1, [i + 1, i + 2], list(v), None)
    m.add_spc1(1, "123456", [1])
    if coupled:
        m.add_param("COUPMASS", [1])
    return m


def _linear(a, b, x):
    return a + (b - a) * x


TAPER = [(0.0, 2e-3, 6e-6, 2e-6, 5e-7, 3e-6, 0.4), (0.3, 1.6e-3, 4e-6, 1.5e-6, 3e-7, 2e-6, 0.3),
         (1.0, 1e-3, 1e-6, 8e-7, 1e-7, 5e-7, 0.1)]


def test_tapered_beam_with_equal_stations_is_the_prismatic_element():
    """The tapered element's integrals (flexibility, mass) with equal stations give the
    prismatic element's closed forms (round-off): K with Timoshenko shear and I12, the lumped
    and the coupled M. The same PBEAM with a station at mid-length is read as prismatic."""
    from torchrom.fe.elements.bar import (
        HERMITE_M,
        PLANES,
        _add_plane,
        bar_frames,
        element_stiffness,
        tapered_mass,
        tapered_stiffness,
    )
    from torchrom.fe.mesh import Taper

    row = TAPER[0]
    fe = model_of(_tapered_cantilever(1, [row, (1.0,) + row[1:]], k=0.8))
    bars = fe.mesh.bars
    assert not bars.taper
    L, _ = bar_frames(bars, fe.mesh.xyz)
    taper = Taper(np.array([0.0, 0.4, 1.0]), *(np.full(3, v) for v in row[1:]), np.zeros(3))
    K = element_stiffness(bars, L)[0]
    Kt = tapered_stiffness(taper, E, G, (0.8, 0.8), L[0])
    np.testing.assert_allclose(Kt, K, rtol=0, atol=1e-13 * np.abs(K).max())
    for coupled in (False, True):
        m = (RHO * row[1] + row[6]) * L[0]
        M = np.zeros((1, 12, 12))
        ip = RHO * (row[2] + row[3]) * L[0] / 2
        M[0, 3, 3] = M[0, 9, 9] = ip
        if coupled:
            M[0][np.ix_((0, 6), (0, 6))] = m * np.array([[2.0, 1.0], [1.0, 2.0]]) / 6
            rot = np.array([0, 1, 0, 1])
            for plane in PLANES:
                _add_plane(M, m / 420 * HERMITE_M * L[0] ** np.add.outer(rot, rot), plane)
        else:
            for i in (0, 1, 2, 6, 7, 8):
                M[0, i, i] = m / 2
        Mt = tapered_mass(taper, RHO, L[0], coupled)
        np.testing.assert_allclose(Mt, M[0], rtol=0, atol=1e-14 * m)


def test_tapered_bar_axial_and_cantilever_tip_closed_forms():
    """One tapered CBEAM (A and I1 linear from end A to end B, no shear flexibility) is exact
    for end loads (round-off, the flexibility is integrated): axial stiffness
    E (A_B − A_A) / (L ln(A_B/A_A)) and tip deflection under a tip force
    P L³/(E I_A) ∫₀¹ (1−ξ)²/(1+cξ) dξ = P L³/(E I_A c³) [b² ln b − 2b(b − 1) + (b² − 1)/2],
    c = I_B/I_A − 1, b = 1 + c (I12 = 0, J constant)."""
    Aa, Ab, Ia, Ib = 2e-3, 5e-4, 6e-6, 1.5e-6
    stations = [(0.0, Aa, Ia, 2e-6, 0.0, 1e-6, 0.0), (1.0, Ab, Ib, 2e-6, 0.0, 1e-6, 0.0)]
    fe = model_of(_tapered_cantilever(1, stations, v=(0.0, 1.0, 0.0)))
    assert fe.mesh.bars.taper
    L, P = 2.0, 1000.0
    u = fe.expand(fe.linear_static(fe.nodal_load({(2, 1): P, (2, 2): P})))[1]
    assert u[0] == pytest.approx(P * L * np.log(Ab / Aa) / (E * (Ab - Aa)), rel=1e-12)
    c = Ib / Ia - 1
    b = 1 + c
    tip = P * L**3 / (E * Ia * c**3) * (b**2 * np.log(b) - 2 * b * (b - 1) + (b**2 - 1) / 2)
    assert u[1] == pytest.approx(tip, rel=1e-12)


def _beam_of_sections(n: int, sections, coupled: bool, k: float):
    """Cantilever along x (length 2, clamped at x = 0) of n CBEAMs, element i with its own
    PBEAM ``sections(a, b)`` → stations (local x/L, A, I1, I2, I12, J, NSM, NSI) over the
    fractions a..b of the length."""
    m = new_deck()
    m.add_mat1(1, E, G, None, rho=RHO)
    for i in range(n):
        st = sections(i / n, (i + 1) / n)
        x, A, I1, I2, I12, J, nsm, nsi = (list(map(float, c)) for c in zip(*st))
        m.add_pbeam(i + 1, 1, x, ["YES"] * len(x), A, I1, I2, I12, J, nsm=nsm, k1=k, k2=k,
                    nsia=nsi[0], nsib=nsi[-1])
        m.add_cbeam(i + 1, i + 1, [i + 1, i + 2], [0.0, 1.0, 0.3], None)
    for i in range(n + 1):
        m.add_grid(i + 1, [2.0 * i / n, 0.0, 0.0])
    m.add_spc1(1, "123456", [1])
    if coupled:
        m.add_param("COUPMASS", [1])
    return m


def _profile(xi):
    """The beam's section at the fractions xi: TAPER's stations, NSI linear 2e-4 → 5e-5."""
    xs = [s[0] for s in TAPER]
    cols = [np.interp(xi, xs, [s[c] for s in TAPER]) for c in range(1, 7)]
    return np.stack(cols + [_linear(2e-4, 5e-5, np.asarray(xi))], axis=-1)


def _tapered_segment(a, b):
    """Stations of the beam over a..b: its ends and TAPER's breakpoints inside."""
    inner = [s[0] for s in TAPER if a < s[0] < b]
    x = np.array([a] + inner + [b])
    return [((xi - a) / (b - a), *_profile(xi)) for xi in x]


@pytest.mark.parametrize("coupled", [False, True], ids=["lumped", "coupled"])
def test_tapered_cantilever_modes_match_a_fine_stepped_model(coupled):
    """A tapered cantilever (A, I1, I2, I12, J and NSM piecewise linear with a break at 0.3 of
    the length, NSI linear, Timoshenko shear): 64 tapered CBEAMs (each its own PBEAM with end
    stations and, in the 20th, one intermediate station at the break) against 800 prismatic
    ones, each with the section at its mid-length (a fine uniform-segment model of the same
    beam). First six modes within 0.01 % coupled, 0.1 % lumped (measured 0.0086 % and
    0.066 %: the 64-element mesh's own error, mostly its lumped mass; 64 stepped elements are
    further off, 0.011 % and 0.074 %)."""
    ft = model_of(_beam_of_sections(64, _tapered_segment, coupled, 0.9)).modes(6).frequencies_hz

    def stepped(a, b):
        mid = _profile(0.5 * (a + b))
        return [(0.0, *mid), (1.0, *mid)]

    fs = model_of(_beam_of_sections(800, stepped, coupled, 0.9)).modes(6).frequencies_hz
    diff = 100 * (ft - fs) / fs
    print("tapered vs stepped, % by mode:", np.round(diff, 4))
    assert np.abs(diff).max() <= (0.01 if coupled else 0.1)


def test_tapered_beam_lumped_mass_keeps_total_mass_and_centre():
    """Lumped mass of one tapered CBEAM: total ∫ (ρA + NSM) dx and its first moment exact."""
    fe = model_of(_tapered_cantilever(1, TAPER))
    M = fe.mass_matrix().toarray()  # end B's six DOFs (end A clamped)
    from scipy.integrate import quad

    def mu(xi):
        return RHO * _profile(xi)[0] + _profile(xi)[5]

    total = 2.0 * quad(mu, 0.0, 1.0, points=[0.3], epsabs=0)[0]
    moment = 2.0 * quad(lambda xi: mu(xi) * xi, 0.0, 1.0, points=[0.3], epsabs=0)[0]
    assert M[0, 0] == pytest.approx(moment, rel=1e-8)  # end B's share: ∫ μ ξ dx
    fe_free = model_of(_tapered_cantilever(1, TAPER))
    from torchrom.fe.model import assemble_mass
    Mall = assemble_mass(fe_free.mesh).toarray()
    assert Mall[0, 0] + Mall[6, 6] == pytest.approx(total, rel=1e-8)


def test_pbeam_fields_not_modelled_are_refused():
    """PBEAM S1/S2 (shear relief), M1/M2 with NSM, CBEAM SA/SB: one-line
    errors naming the card and field (they change the answer; not silently dropped)."""
    for field, value, msg in (("s2", 0.5, "shear relief"),
                              ("m2b", 0.02, "offset non-structural mass")):
        m = _tapered_cantilever(2, TAPER)
        setattr(m.properties[1], field, value)
        with pytest.raises(InputError, match=rf"PBEAM 1: fields .*{msg}"):
            model_of(m)
    m = _tapered_cantilever(2, TAPER)
    m.add_spoint([101])
    m.elements[1].sa = 101
    with pytest.raises(InputError, match=r"CBEAM 1: fields SA/SB: warping"):
        model_of(m)
    bad = [TAPER[0], (0.5,) + TAPER[1][1:], (0.5,) + TAPER[2][1:]]
    with pytest.raises(InputError, match=r"PBEAM 1: field X/XB: expected increasing"):
        model_of(_tapered_cantilever(2, bad))


# PBEAM neutral axis offsets (N1, N2): a prismatic cantilever along basic x, v = basic y, so the
# element axes are the basic ones; I12 = 0, K1 = K2 = 1 (Timoshenko)
NA_SECTION = dict(A=2e-3, I1=3e-6, I2=8e-7, J=5e-7)
NA_OFFSET = (0.012, -0.007)  # (N1, N2) of the neutral axis relative to the shear centre


def _na_cantilever(n: int, na=NA_OFFSET, offset_grids: bool = False, nsm: float = 0.0):
    """n CBEAMs of length 2 along x clamped at grid 1; the PBEAM's neutral axis at ``na``, or
    (``offset_grids``) no N1/N2 and the beam moved there by WA/WB offsets instead."""
    m = new_deck()
    m.add_mat1(1, E, G, None, rho=RHO)
    s = NA_SECTION
    pbeam = m.add_pbeam(1, 1, [0.0], ["YES"], [s["A"]], [s["I1"]], [s["I2"]], [0.0], [s["J"]],
                        nsm=[nsm])
    w = [0.0, *na] if offset_grids else None
    if not offset_grids:
        pbeam.n1a, pbeam.n2a, pbeam.n1b, pbeam.n2b = na[0], na[1], None, None
    for i in range(n + 1):
        m.add_grid(i + 1, [2.0 * i / n, 0.0, 0.0])
    for i in range(n):
        m.add_cbeam(i + 1, 1, [i + 1, i + 2], [0.0, 1.0, 0.0], None, offt="GGG", wa=w, wb=w)
    m.add_spc1(1, "123456", [1])
    return m


def _tip_response(fe, n: int, comp: int, value: float = 1.0) -> np.ndarray:
    """(6,) tip grid displacements (basic) under a unit load on its component ``comp``."""
    return fe.expand(fe.linear_static(fe.nodal_load({(n + 1, comp): value})))[n]


def test_neutral_axis_offset_cantilever_closed_forms():
    """One CBEAM (exact for end loads) with its neutral axis at (N1, N2) from the shear centre:
    an axial tip force P at the shear centre acts on the neutral axis with the moments
    (My, Mz) = (−N2 P, N1 P), so v = N1 P L² / (2 E I1), w = N2 P L² / (2 E I2) and
    u = P L / E (1/A + N1²/I1 + N2²/I2); a torque twists it about the shear centre (T L / G J, no
    bending), a transverse force bends it without twist (shear through the shear centre):
    w = P L³ / (3 E I2) + P L / (K2 G A). Tolerance 1e-9: closed forms of the same element."""
    L, (n1, n2), s = 2.0, NA_OFFSET, NA_SECTION
    fe = model_of(_na_cantilever(1), autospc=False)
    u = _tip_response(fe, 1, 1)
    expected = np.array([L / E * (1 / s["A"] + n1**2 / s["I1"] + n2**2 / s["I2"]),
                         n1 * L**2 / (2 * E * s["I1"]), n2 * L**2 / (2 * E * s["I2"]),
                         0.0, -n2 * L / (E * s["I2"]), n1 * L / (E * s["I1"])])
    np.testing.assert_allclose(u, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    twist = _tip_response(fe, 1, 4)
    np.testing.assert_allclose(twist, [0, 0, 0, L / (G * s["J"]), 0, 0], rtol=0,
                               atol=1e-9 * L / (G * s["J"]))
    bend = _tip_response(fe, 1, 3)
    w = L**3 / (3 * E * s["I2"]) + L / (G * s["A"])
    assert bend[2] == pytest.approx(w, rel=1e-9)
    assert abs(bend[3]) <= 1e-9 * abs(bend[4])  # no twist
    # by reciprocity the axial force's bending is the bending load's axial motion
    assert bend[0] == pytest.approx(u[2], rel=1e-9)


def test_neutral_axis_offset_equals_the_beam_moved_by_offsets():
    """The same beam moved to the neutral axis by WA/WB rigid offsets is the same element but
    for where torsion and transverse shear act (there, at the neutral axis): with the twist
    restrained (component 4 constrained at every grid) the stiffness matrices agree to
    rounding (1e-10 of the largest entry), and the masses agree with the twist free too (the
    structural mass is at the neutral axis in both); a non-structural mass stays at the shear
    centre (it adds the mass of the beam without offsets)."""
    n = 4
    for twist_free in (False, True):
        decks = [_na_cantilever(n), _na_cantilever(n, offset_grids=True)]
        if not twist_free:
            for m in decks:
                m.add_spc1(1, "4", list(range(2, n + 2)))
        fa, fb = (model_of(m, autospc=False) for m in decks)
        _close(fa.mass_matrix(), fb.mass_matrix(), 1e-10)
        if not twist_free:
            _close(fa.stiffness_matrix(), fb.stiffness_matrix(), 1e-10)
        else:  # the offsets matter: the moved beam couples shear and twist, Nastran's does not
            diff = np.abs(fa.stiffness_matrix() - fb.stiffness_matrix()).max()
            assert diff > 1e-4 * np.abs(fa.stiffness_matrix()).max()  # measured 4.3e-4
    with_nsm = model_of(_na_cantilever(n, nsm=0.7), autospc=False).mass_matrix()
    plain = model_of(_na_cantilever(n), autospc=False).mass_matrix()
    nsm_alone = (model_of(_na_cantilever(n, na=(0.0, 0.0), nsm=0.7), autospc=False).mass_matrix()
                 - model_of(_na_cantilever(n, na=(0.0, 0.0)), autospc=False).mass_matrix())
    _close(with_nsm, plain + nsm_alone, 1e-12)
