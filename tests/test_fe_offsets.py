"""CQUAD4/CTRIA3 with ZOFFS (torchrom.fe.elements.offset) against plate and beam closed forms.

Cantilever strips L × b in the x-y plane, grids at z = 0, clamped at x = 0, MAT1 with ν = 0 (so
that a strip bends as a beam: no anticlastic curvature) unless stated, loads shared between
the tip grids (half at the two edge grids).
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.fe.elements.offset import offset_mass_blocks, offset_stiffness_blocks
from torchrom.fe.elements.quad4 import area_mass_blocks
from torchrom.fe.mesh import QuadSet, TriaSet

from .fe_decks import model_of, new_deck

E, T, L, B = 7.0e10, 0.01, 1.0, 0.1
EI, EA, KGA = E * B * T**3 / 12, E * B * T, 5 / 6 * E / 2 * B * T  # ν = 0: G = E/2


def _strip(plates, nx=10, ny=2, nu=0.0, tria=False, pcomp=False):
    """(model, tip grid ids) of a strip whose every cell carries one shell per (thickness,
    ZOFFS) in ``plates`` on the same grids (CQUAD4, or two CTRIA3s per cell); PSHELL, or PCOMP
    with one MAT1 ply."""
    m = new_deck()

    def gid(i, j):
        return 1 + i * (ny + 1) + j

    for i in range(nx + 1):
        for j in range(ny + 1):
            m.add_grid(gid(i, j), [L * i / nx, B * j / ny, 0.0], ps="123456" if i == 0 else "")
    m.add_mat1(1, E, None, nu, rho=2700.0)
    eid = 1
    for k, (t, _) in enumerate(plates):
        if pcomp:
            m.add_pcomp(k + 1, [1], [t], [0.0])
        else:
            m.add_pshell(k + 1, mid1=1, t=t, mid2=1, mid3=1)
    for i in range(nx):
        for j in range(ny):
            g = [gid(i, j), gid(i + 1, j), gid(i + 1, j + 1), gid(i, j + 1)]
            for k, (_, z0) in enumerate(plates):
                if tria:
                    m.add_ctria3(eid, k + 1, [g[0], g[1], g[2]], zoffset=z0)
                    m.add_ctria3(eid + 1, k + 1, [g[0], g[2], g[3]], zoffset=z0)
                    eid += 2
                else:
                    m.add_cquad4(eid, k + 1, g, zoffset=z0)
                    eid += 1
    return model_of(m), [gid(nx, j) for j in range(ny + 1)]


def _tip_load(fe, tip, component: int, total: float) -> np.ndarray:
    """Grid displacements (n_grid, 6) under ``total`` shared by the tip grids (a uniform line
    load's consistent share: half at the two edge grids)."""
    share = np.full(len(tip), 1.0 / (len(tip) - 1))
    share[[0, -1]] *= 0.5
    f = fe.nodal_load({(g, component): total * s for g, s in zip(tip, share)})
    return fe.expand(fe.linear_static(f))


def _difference(U, V) -> float:
    return float(np.abs(U - V).max() / np.abs(V).max())


@pytest.mark.parametrize("tria", [False, True], ids=["CQUAD4", "CTRIA3"])
def test_two_offset_plates_are_one_plate_of_twice_the_thickness(tria):
    """Two plates of thickness t on the same grids with ZOFFS = ±t/2 are one plate of 2t:
    A = 2 A_t, B = (t/2 − t/2) A_t = 0, D = 2 (D_t + (t/2)² A_t) = E (2t)³ / 12 — the offset's
    z0² A adds exactly the missing bending stiffness. Tip-loaded cantilever strip, all
    displacements and rotations compared.

    CQUAD4, ν = 0: without the quad's residual bending flexibility (RBF) the two were equal to
    1e-8 (3e-11 observed): the offset membrane's z0² A is integrated at the same 2×2 points as
    the bending (cylindrical bending has no twist, which the membrane integrates at the centre).
    With it, each plate's transverse shear carries ℓ²/(12 D_t) of its own bending stiffness, the
    single plate's ℓ²/(12 · 8 D_t): the pair is softer by an O(h²) term (the RBF sees each
    element's own D, which is exact for a uniformly offset plate, below, where the offset's
    membrane strain cancels): 10×2 cells within 1 % (observed 0.500 %), 20×4 within a third of
    that (observed 0.125 %, then 0.031 % at 40×8). CTRIA3: the offset part of the bending comes
    from the CST membrane of the linearly interpolated rotations, the plate's own from DKT, so
    the two agree only as the mesh converges: 10×2 cells within 0.5 % (observed 0.40 %), 20×4
    within a third of that (observed 0.25 ×, the O(h²) of both). CQUAD4, ν = 0.3: the strip's
    anticlastic twist near the root adds the centre-integrated offset twisting stiffness and
    the RBF's excess where the shear comes from a twist gradient (O(h), the simply supported
    plate of tests/test_fe_solvers.py), so only the first refinement is asserted to halve the
    difference: 10×2 within 1 % (observed 0.48 %), 20×4 within half of that (observed 0.15 %;
    0.19 % at 40×8)."""
    pair, tip = _strip([(T, T / 2), (T, -T / 2)], tria=tria)
    one, _ = _strip([(2 * T, 0.0)], tria=tria)
    d = _difference(_tip_load(pair, tip, 3, 1.0), _tip_load(one, tip, 3, 1.0))
    pair2, tip2 = _strip([(T, T / 2), (T, -T / 2)], 20, 4, tria=tria)
    one2, _ = _strip([(2 * T, 0.0)], 20, 4, tria=tria)
    d2 = _difference(_tip_load(pair2, tip2, 3, 1.0), _tip_load(one2, tip2, 3, 1.0))
    assert d <= (1e-2 if not tria else 5e-3) and d2 <= d / 3
    if not tria:
        pair, tip = _strip([(T, T / 2), (T, -T / 2)], nu=0.3)
        one, _ = _strip([(2 * T, 0.0)], nu=0.3)
        d = _difference(_tip_load(pair, tip, 3, 1.0), _tip_load(one, tip, 3, 1.0))
        pair2, tip2 = _strip([(T, T / 2), (T, -T / 2)], 20, 4, nu=0.3)
        one2, _ = _strip([(2 * T, 0.0)], 20, 4, nu=0.3)
        d2 = _difference(_tip_load(pair2, tip2, 3, 1.0), _tip_load(one2, tip2, 3, 1.0))
        assert d <= 1e-2 and d2 <= d / 2


@pytest.mark.parametrize("tria,pcomp", [(False, False), (True, False), (False, True)],
                         ids=["CQUAD4", "CTRIA3", "CQUAD4-PCOMP"])
def test_offset_cantilever_eccentric_axial_load(tria, pcomp):
    """Plate with ZOFFS = z0 = 2t, a tip force P along x at the grids, i.e. at −z0 from the
    plate's neutral (reference) plane: the beam with the shifted neutral axis carries P and the
    constant moment P z0, so w_tip = P z0 L² / (2EI) and the grids' u_tip = PL/EA + z0² PL/EI
    (EI = E b t³/12, EA = E b t). Constant curvature is exact in both elements (linear rotations,
    quadratic w at the grids): 1e-8 (observed ≤ 2e-10, the conditioning of K). The same with a
    one-ply PCOMP (its laminate A, D about the ply's mid-plane, offset by the element's ZOFFS)."""
    z0, P = 2 * T, 1.0
    fe, tip = _strip([(T, z0)], tria=tria, pcomp=pcomp)
    U = _tip_load(fe, tip, 1, P)
    k = tip[1] - 1
    assert U[k, 2] == pytest.approx(P * z0 * L**2 / (2 * EI), rel=1e-8)
    assert U[k, 0] == pytest.approx(P * L / EA + z0**2 * P * L / EI, rel=1e-8)


def test_offset_cantilever_transverse_load():
    """Plate with ZOFFS = z0 = 2t, tip force P along z: the neutral axis is free to stretch, so
    no axial force builds up and the bending stiffness stays EI (the offset does not stiffen
    it); the grids, at −z0 from the neutral axis, move along x by u_tip = −z0 θ_y,tip
    = z0 PL²/(2EI). Checks: the tip deflection equals the plate's without offset (1e-9: the
    offset adds a zero-energy way for u to follow −z0 θ_y, nothing else); u_tip and θ_y,tip to
    1e-8 (nodal rotations of this element are exact under a linear moment, observed 2e-10); the
    tip deflection vs Timoshenko's PL³/(3EI) + PL/(κGA) within 0.3 % with 10 cells (observed
    −0.25 %: the bending part's −1/(4n²) of linear rotations with mid-point shear)."""
    z0, P = 2 * T, 1.0
    fe, tip = _strip([(T, z0)])
    plain, _ = _strip([(T, 0.0)])
    U, V = _tip_load(fe, tip, 3, P), _tip_load(plain, tip, 3, P)
    k = tip[1] - 1
    assert U[k, 2] == pytest.approx(V[k, 2], rel=1e-9)
    assert U[k, 4] == pytest.approx(-P * L**2 / (2 * EI), rel=1e-8)
    assert U[k, 0] == pytest.approx(z0 * P * L**2 / (2 * EI), rel=1e-8)
    assert U[k, 2] == pytest.approx(P * L**3 / (3 * EI) + P * L / KGA, rel=3e-3)


def _one_element(tria: bool, z0: float):
    X = np.array([[0.0, 0.0, 0.0], [1.1, 0.1, 0.02], [1.2, 0.9, -0.03], [0.1, 1.0, 0.01]])
    nodes = np.arange(3 if tria else 4)[None]
    kw = dict(eids=np.array([1]), nodes=nodes, t=np.array([0.01]), E=np.array([E]),
              nu=np.array([0.3]), G=np.array([E / 2.6]), rho=np.array([2700.0]),
              nsm=np.array([0.5]), bend_E=np.array([E]), bend_nu=np.array([0.3]),
              shear_G=np.array([E / 2.6 * 5 / 6]), zoffs=np.array([z0]))
    return (TriaSet if tria else QuadSet)(**kw), X[: 3 if tria else 4]


@pytest.mark.parametrize("tria", [False, True], ids=["CQUAD4", "CTRIA3"])
def test_free_offset_element_rigid_modes_and_mass(tria):
    """One free offset element (ZOFFS = 0.05, five thicknesses): six zero eigenvalues of the
    slightly warped element (relative 1e-10: the rigid offset maps rigid motions to rigid
    motions, the drilling spring stays at the grids), the seventh positive. Mass on the
    reference plane (flat element in the x-y plane, a grid at the origin): the same total
    translational mass m, and a rigid rotation about an in-plane axis through the grids has
    twice the kinetic energy m z0² more than without offset — the point masses move by z0 × the
    rotation more, and their first moment about the grids' plane is zero — lumped and
    consistent (1e-12, rounding)."""
    z0 = 0.05
    shells, X = _one_element(tria, z0)
    K = offset_stiffness_blocks(shells, X)[1][0]
    lam = np.linalg.eigvalsh(K)
    assert np.all(np.abs(lam[:6]) <= 1e-10 * lam[-1]) and lam[6] > 1e-8 * lam[-1]
    X[:, 2] = 0.0
    plain = _one_element(tria, 0.0)[0]
    axis = np.array([np.cos(0.4), np.sin(0.4), 0.0])
    rot = np.concatenate([np.concatenate((np.cross(axis, x), axis)) for x in X])
    for coupled in (True, False):
        M = offset_mass_blocks(shells, X, coupled)[1][0]
        M0 = offset_mass_blocks(plain, X, coupled)[1][0]
        m = M[0::6, 0::6].sum()
        assert m == pytest.approx(M0[0::6, 0::6].sum(), rel=1e-12)
        assert rot @ M @ rot - rot @ M0 @ rot == pytest.approx(m * z0**2, rel=1e-12)
    if not tria:  # without offset the blocks are the element's own translational mass
        M0 = offset_mass_blocks(plain, X, True)[1][0]
        own = area_mass_blocks(X, plain.nodes, np.array([2700.0 * 0.01 + 0.5]), True)[1][0]
        idx = (6 * np.arange(4)[:, None] + np.arange(3)).reshape(-1)
        assert M0[np.ix_(idx, idx)] == pytest.approx(own, rel=1e-14)


def test_nonlinear_analysis_of_an_offset_deck_is_refused():
    """ZOFFS is a small-rotation offset: modes and linear statics work; the internal force and
    the tangent (what nonlinear statics, transients and the reduced-order models use) raise a
    one-line error naming the file, the first offset element and the field."""
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0], ps="123456")
    m.add_grid(2, [1.0, 0.0, 0.0])
    m.add_grid(3, [1.0, 1.0, 0.0])
    m.add_grid(4, [0.0, 1.0, 0.0], ps="123456")
    m.add_mat1(1, E, None, 0.3, rho=2700.0)
    m.add_pshell(1, mid1=1, t=T, mid2=1, mid3=1)
    m.add_cquad4(5, 1, [1, 2, 3, 4], zoffset=0.005)
    m.add_ctria3(6, 1, [2, 3, 4], zoffset=-0.005)
    fe = model_of(m, "offset")
    assert fe.modes(2).frequencies_hz[0] > 0
    u = np.zeros(fe.n_dof)
    words = (r"^offset.bdf: CQUAD4 5: field ZOFFS = 0.005: offset shells are linear only; "
             r"the internal force f\(u\) \(nonlinear analysis\) is not supported for a model "
             r"with ZOFFS \(2 offset elements\)")
    with pytest.raises(InputError, match=words):
        fe.internal_force(u)
    with pytest.raises(InputError, match="CQUAD4 5: field ZOFFS .* the tangent stiffness"):
        fe.tangent_stiffness(u)
    assert "\n" not in str(pytest.raises(InputError, fe.internal_force, u).value)


@pytest.mark.parametrize("tria", [False, True], ids=["CQUAD4", "CTRIA3"])
def test_uniformly_offset_strip_has_the_plain_strips_modes(tria):
    """Every shell offset by the same z0 = 2t, grids clamped at the root: the offset is a change
    of variables (u_ref, θ) ↔ (u, θ) that keeps the clamp, with stiffness and mass both on the
    reference plane, so the six lowest modes (bending, in-plane, torsion; ν = 0.3) are the
    plain strip's. Only the drilling spring, left at the grids, differs: CQUAD4 within 1e-6
    (observed ≤ 1.3e-7), CTRIA3 within 1e-4 (observed ≤ 3.1e-5). Mass left at the grids
    would change them by 0.09 % (first bending) to 8 % (checked by hand)."""
    offset, _ = _strip([(T, 2 * T)], nu=0.3, tria=tria)
    plain, _ = _strip([(T, 0.0)], nu=0.3, tria=tria)
    f, f0 = offset.modes(6).frequencies_hz, plain.modes(6).frequencies_hz
    assert f == pytest.approx(f0, rel=1e-4 if tria else 1e-6)
