"""GENEL, SPOINT, the deck's AUTOSPC switch and scalar masses against closed forms.

- GENEL: a two-spring chain written as a flexibility GENEL (Z = the chain's influence
  coefficients, S = rigid translation of the root) gives the same stiffness matrix as the two
  CELAS2 springs (to round-off, 1e-12), and K [S; I] = 0 (no load in a rigid motion).
- SPOINT: a scalar point carries one DOF; a spring k to ground and a mass m on it vibrate at
  √(k/m)/2π (1e-9), and an MPC may make it the dependent term of a grid's motion.
- A grounded negative CMASS2 is refused, naming card and field.
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
