"""Static load sets (torchrom/fe/loads.py): GRAV.

References: a rigid mass under a uniform acceleration a carries the force m a at its centre of
gravity, i.e. m a and the moment w × m a at its grid for a CONM2 offset w (closed form); the
acceleration of a GRAV is A N (N not normalised, MSC QRG GRAV) in its system CID; the weight of a
whole model is its total mass times a and its moment about the origin is the first moment of
mass times a (the model's rigid-body mass, as Nastran's grid point weight generator prints it).
"""

from __future__ import annotations

import numpy as np
import pytest

from .fe_decks import model_of, new_deck

OFFSET = np.array([0.1, -0.05, 0.2])


def _masses(grav_cid: int, n_vec):
    """A CBAR (with mass) and a CONM2 at an offset on a clamped-free pair of grids, and a GRAV
    of A = 9.81 along ``n_vec`` in system ``grav_cid``."""
    m = new_deck()
    m.add_grid(1, [1.0, 2.0, 3.0])
    m.add_grid(2, [2.0, 2.0, 3.0])
    m.add_mat1(1, 7e10, 2.7e10, None, rho=2700.0)
    m.add_pbar(1, 1, A=1e-3, i1=1e-6, i2=1e-6, j=1e-6)
    m.add_cbar(1, 1, [1, 2], [0.0, 1.0, 0.0], None)
    m.add_conm2(5, 2, 2.0, X=list(OFFSET))
    # system 7: its x axis along basic −z, y along basic y
    m.add_cord2r(7, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0])
    m.add_grav(1, 9.81, list(n_vec), cid=grav_cid)
    m.add_spc1(1, "123456", [1])
    return m


@pytest.mark.parametrize("cid, n_vec", [(0, (0.0, 0.0, -2.0)), (7, (2.0, 0.0, 0.0))],
                         ids=["basic", "cord2r"])
def test_grav_is_mass_times_acceleration(cid, n_vec):
    """a = A N = (0, 0, −19.62) both ways (|N| = 2 is not normalised; system 7's x is basic −z):
    the tip grid's load is the CONM2's m a and w × m a plus half the bar's weight (its lumped
    mass), to 1e-12; the load set's resultant is the total mass times a."""
    fe = model_of(_masses(cid, n_vec), autospc=False)
    a = np.array([0.0, 0.0, -2.0 * 9.81])
    f = fe.expand(fe.load_vector(1))[1]  # grid 2 (free), basic axes
    bar = 2700.0 * 1e-3 * 1.0
    np.testing.assert_allclose(f[:3], (2.0 + bar / 2) * a, rtol=1e-12)
    np.testing.assert_allclose(f[3:], np.cross(OFFSET, 2.0 * a), rtol=1e-12, atol=1e-12)


def test_grav_resultant_is_the_weight_at_each_centre_of_gravity():
    """A model of every mass kind the reader makes (CBAR, CQUAD4, CBEAM with neutral-axis offsets
    (N1, N2), CONM2 at an offset): the load set's force and moment about the origin (Dᵀ f, D the
    rigid-body motions) are Σ m a and Σ r × m a over each part's mass m at its centre of
    gravity r, computed here from the geometry (1e-12): the beam's structural mass is at its
    neutral axis, N1 along the element y (basic z), N2 along the element z (basic x)."""
    from torchrom.fe.mass import rigid_links

    m = _masses(0, (0.0, 0.0, -1.0))
    m.add_grid(3, [2.0, 3.0, 3.0])
    m.add_grid(4, [1.0, 3.0, 3.0])
    m.add_pshell(2, 1, 0.004, 1, None, 1)
    m.add_cquad4(10, 2, [1, 2, 3, 4])
    m.add_pbeam(3, 1, [0.0], ["YES"], [2e-4], [3e-9], [2e-9], [0.0], [1e-9])
    beam = m.properties[3]
    beam.n1a, beam.n2a, beam.n1b, beam.n2b = 0.004, -0.003, 0.004, -0.003
    m.add_cbeam(20, 3, [2, 3], [0.0, 0.0, 1.0], None)
    fe = model_of(m, autospc=False)
    rho = 2700.0
    parts = [(rho * 1e-3 * 1.0, [1.5, 2.0, 3.0]),  # CBAR
             (2.0, np.array([2.0, 2.0, 3.0]) + OFFSET),  # CONM2
             (rho * 0.004 * 1.0, [1.5, 2.5, 3.0]),  # CQUAD4, 1 x 1
             (rho * 2e-4 * 1.0, [2.0 - 0.003, 2.5, 3.0 + 0.004])]  # CBEAM at its neutral axis
    a = np.array([0.0, 0.0, -9.81])
    force = sum(mass * a for mass, _ in parts)
    moment = sum(np.cross(r, mass * a) for mass, r in parts)
    D = rigid_links(fe.grid_xyz).reshape(-1, 6)
    resultant = D.T @ fe._loads_all[1]
    np.testing.assert_allclose(resultant, np.concatenate((force, moment)), rtol=1e-12,
                               atol=1e-12 * np.abs(moment).max())
