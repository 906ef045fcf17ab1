"""GENEL, SPOINT, the deck's AUTOSPC switch and scalar masses against closed forms.

- GENEL: a two-spring chain written as a flexibility GENEL (Z = the chain's influence
  coefficients, S = rigid translation of the root) gives the same stiffness matrix as the two
  CELAS2 springs (to round-off, 1e-12), and K [S; I] = 0 (no load in a rigid motion).
- SPOINT: a scalar point carries one DOF; a spring k to ground and a mass m on it vibrate at
  √(k/m)/2π (1e-9), and an MPC may make it the dependent term of a grid's motion.
- A grounded negative CMASS2 is refused, naming card and field.
- CBUSH between separate grids: the same stiffness as RBE2 links from each grid to the spring
  point and CELAS2 springs along the element axes there (1e-12), and along its axis (K1, K4) the
  CROD of the same EA/L and GJ/L (1e-12).
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.fe.mass import genel_stiffness

from .fe_decks import model_of, new_deck


def _chain(genel: bool):
    """Grid 1 (root, T3 free on a stiff spring so both forms have the same free DOFs), grids 2
    and 3: springs k1 (1-2) and k2 (2-3) on T3, unit masses."""
    k0, k1, k2 = 1e6, 300.0, 200.0
    m = new_deck()
    for g in (1, 2, 3):
        m.add_grid(g, [float(g), 0.0, 0.0], ps="12456")
        m.add_conm2(10 + g, g, 1.0)
    m.add_celas2(1, k0, [1, None], 3)
    if genel:
        z = [1 / k1, 1 / k1, 1 / k1 + 1 / k2]  # lower triangle, column by column
        m.add_genel_flexibility(5, [2, 3, 3, 3], [1, 3], z, s=[1.0, 1.0])
    else:
        m.add_celas2(2, k1, [1, 2], 3, 3)
        m.add_celas2(3, k2, [2, 3], 3, 3)
    return model_of(m)


def test_genel_flexibility_equals_the_springs_it_inverts():
    K_genel = _chain(True).stiffness_matrix().toarray()
    K_springs = _chain(False).stiffness_matrix().toarray()
    assert np.allclose(K_genel, K_springs, rtol=0, atol=1e-12 * np.abs(K_springs).max())
    K = genel_stiffness(np.array([[2.0, -1.0], [-1.0, 3.0]]), np.array([[1.0, 4.0], [1.0, 7.0]]))
    rigid = np.vstack((np.array([[1.0, 4.0], [1.0, 7.0]]), np.eye(2)))
    assert np.abs(K @ rigid).max() <= 1e-12


def test_spoint_spring_mass_and_mpc():
    k, mass = 400.0, 2.5
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0], ps="23456")
    m.add_spoint([101, 102])
    m.add_celas2(1, k, [101, None], 0)
    m.add_cmass2(2, mass, [101, None], 0, 0)
    m.add_celas2(3, k, [1, None], 1)
    m.add_conm2(4, 1, mass)
    m.add_mpc(7, [102, 1], ['0', '1'], [1.0, -1.0])  # SPOINT 102 follows grid 1's T1
    fe = model_of(m)
    f = fe.modes(2).frequencies_hz
    assert f == pytest.approx([np.sqrt(k / mass) / (2 * np.pi)] * 2, rel=1e-9)
    assert fe.n_dof == 2  # grid 1 T1 and SPOINT 101 (102 is dependent)


def test_grounded_negative_scalar_mass_is_refused():
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0])
    m.add_cmass2(5, -1.0, [1, None], 3, 0)
    with pytest.raises(InputError, match=r"CMASS2 5: field M: expected a number >= 0 for a mass"):
        model_of(m)


def test_dmig_on_the_structure_is_refused(tmp_path):
    """DMIG is noted while only the p-set (K2PP) uses it; K2GG would change the modes."""
    from torchrom.fe import read_bdf

    deck = tmp_path / "d.bdf"
    deck.write_text("SOL 103\nCEND\nK2GG = STIFF\nBEGIN BULK\nGRID,1,,0.,0.,0.\n"
                    "CONM2,2,1,,1.\nCELAS2,3,10.,1,1\nDMIG,STIFF,0,6,1,0\n"
                    "DMIG,STIFF,1,1,,1,1,1.\nENDDATA\n")
    with pytest.raises(InputError, match="case control K2GG: direct matrix input"):
        read_bdf(deck)


def _bush_pair():
    """Two separate grids (grid 2 with a rotated displacement system) and the CBUSH's axes for
    each way of orienting it."""
    xa, xb = np.array([0.2, -0.1, 0.3]), np.array([1.1, 0.5, -0.2])
    v = np.array([0.1, 0.2, 1.0])
    ex = (xb - xa) / np.linalg.norm(xb - xa)
    ey = v - (v @ ex) * ex
    ey /= np.linalg.norm(ey)
    return xa, xb, v, np.column_stack((ex, ey, np.cross(ex, ey)))


def _bush_deck(orient: str, links: bool, k6, s: float = 0.5):
    """CBUSH between grids 1 and 2 oriented by X1-X3 ('x'), G0 ('g0') or a CORD2R ('cid'); or
    (``links``) its independent equivalent: the spring point as two grids 3, 4, each an RBE2
    dependent of grid 1 / 2, joined by six CELAS2 springs along the element axes (their CD)."""
    xa, xb, v, axes = _bush_pair()
    m = new_deck()
    m.add_cord2r(8, [0.0, 0.0, 0.0], [0.3, 0.2, 1.0], [1.0, -0.4, 0.1])
    m.add_grid(1, list(xa))
    m.add_grid(2, list(xb), cd=8)
    m.add_grid(5, list(xa + v))
    if orient == "cid":
        m.add_cord2r(9, [0.0, 0.0, 0.0], [0.0, 0.6, 0.8], [1.0, 0.0, 0.0])
        axes = np.column_stack(([1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]))
    else:
        m.add_cord2r(9, [0.0, 0.0, 0.0], list(axes[:, 2]), list(axes[:, 0]))
    if links:
        point = xa + s * (xb - xa)
        m.add_grid(3, list(point), cd=9)
        m.add_grid(4, list(point), cd=9)
        m.add_rbe2(30, 1, "123456", [3])
        m.add_rbe2(31, 2, "123456", [4])
        for c in range(6):
            m.add_celas2(40 + c, k6[c], [3, 4], c + 1, c + 1)
    else:
        m.add_pbush(7, list(k6), [], [])
        x, g0 = {"x": (list(v), None), "g0": (None, 5), "cid": (None, None)}[orient]
        m.add_cbush(1, 7, [1, 2], x, g0, cid=9 if orient == "cid" else None, s=s)
    m.add_spc1(1, "123456", [5])
    return m


@pytest.mark.parametrize("orient", ["x", "g0", "cid"])
def test_cbush_between_separate_grids_equals_rigid_links_and_springs(orient):
    """CBUSH K1..K6 between separate grids, the spring at S = 0.3 on GA-GB: the stiffness on the
    two grids' DOFs equals RBE2 links from each grid to the spring point and six CELAS2 springs
    along the element axes there (1e-12 of the largest entry: rounding), for the element system
    from X1-X3, from G0 and from CID."""
    k6 = [1.0e5, 2.0e4, 3.0e4, 500.0, 700.0, 900.0]
    fa = model_of(_bush_deck(orient, False, k6, 0.3), autospc=False)
    fb = model_of(_bush_deck(orient, True, k6, 0.3), autospc=False)
    ids = [d for d in fb.free_dofs() if d[0] in (1, 2)]
    assert [d for d in fa.free_dofs() if d[0] in (1, 2)] == ids
    ia = [fa.free_dofs().index(d) for d in ids]
    ib = [fb.free_dofs().index(d) for d in ids]
    Ka = fa.stiffness_matrix().toarray()[np.ix_(ia, ia)]
    Kb = fb.stiffness_matrix().toarray()[np.ix_(ib, ib)]
    np.testing.assert_allclose(Ka, Kb, rtol=0, atol=1e-12 * np.abs(Kb).max())


def test_cbush_axial_and_torsion_equal_a_crod():
    """A CBUSH along GA-GB with K1 = EA/L and K4 = GJ/L only is the CROD of that A and J
    (linear stiffness, 1e-12): the rigid links to the mid-point add nothing along the axis."""
    xa, xb, v, _ = _bush_pair()
    E, G, A, J = 7.0e10, 2.6e10, 3e-4, 2e-8
    L = np.linalg.norm(xb - xa)
    mats = []
    for rod in (False, True):
        m = new_deck()
        m.add_grid(1, list(xa))
        m.add_grid(2, list(xb))
        if rod:
            m.add_mat1(1, E, G, None)
            m.add_prod(1, 1, A, j=J)
            m.add_crod(1, 1, [1, 2])
        else:
            m.add_pbush(1, [E * A / L, 0.0, 0.0, G * J / L, 0.0, 0.0], [], [])
            m.add_cbush(1, 1, [1, 2], list(v), None)
        fe = model_of(m, autospc=False)
        mats.append(fe.stiffness_matrix().toarray())
    np.testing.assert_allclose(mats[0], mats[1], rtol=0, atol=1e-12 * np.abs(mats[1]).max())


def test_cbush_between_separate_grids_without_orientation_is_refused():
    m = _bush_deck("x", False, [1.0] * 6)
    m.elements[1].x = [None, None, None]
    with pytest.raises(InputError, match="CBUSH 1: fields X1-X3/G0/CID: expected an orientation"):
        model_of(m)
