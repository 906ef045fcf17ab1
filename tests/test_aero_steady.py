"""Steady (k = 0) aerodynamics (torchrom.aero.steady): the rigid incidence's box motion and its
generalized forces.

Independent references: the rigid pitch written out (h = −(x − x₀), ∂h/∂x = −1 on a flat wing;
a rotation about y seen along a tilted box's normal), and the horseshoe-vortex lattice of
tests/test_aero_dlm.py (Biot–Savart written there) for the lift of a unit incidence.
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.aero.dlm import BoxMotion
from torchrom.aero.panels import lattice, rectangular_wing
from torchrom.aero.steady import incidence_motion, stack_motions, steady_gaf

from .test_aero_dlm import _horseshoe_lift_slope


def test_incidence_of_a_flat_wing_is_the_rigid_pitch():
    """On boxes in the xy plane: h = −(x − x₀) at the load and control points, slope −1
    (to rounding)."""
    wing = rectangular_wing(1.0, 2.0, 4, 6)
    m = incidence_motion(wing, origin=(0.25, 0.0, 0.0))
    assert np.allclose(m.h_load[0], -(wing.doublet_points[:, 0] - 0.25), atol=1e-14)
    assert np.allclose(m.h_control[0], -(wing.control_points[:, 0] - 0.25), atol=1e-14)
    assert np.allclose(m.slope_control[0], -1.0, atol=1e-14)


def test_incidence_of_a_tilted_box_is_seen_along_its_normal():
    """A box rolled 30° about x (dihedral): the pitch's normalwash is cos 30° of the flat box's
    (the rotation ŷ × x̂ = −ẑ projected on the normal (0, −sin, cos))."""
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    box = lattice((0, 0, 0), (1, 0, 0), (1, c, s), (0, c, s), np.linspace(0, 1, 2),
                  np.linspace(0, 1, 2), first_box_id=1, caero_id=1)
    m = incidence_motion(box)
    assert m.slope_control[0, 0] == pytest.approx(-c, abs=1e-12)


def test_unit_incidence_lift_matches_the_horseshoe_lattice():
    """The lift of a unit incidence, −Q(plunge, α)(k = 0)/S, of an aspect-ratio-4 rectangular
    wing against the independent horseshoe lattice (the same discretisation: 1e-3, measured
    ~1e-5); stack_motions keeps the rows' order."""
    wing = rectangular_wing(1.0, 2.0, 6, 12)
    plunge = BoxMotion.from_function(wing, [(lambda x, y: np.ones_like(x),
                                             lambda x, y: np.zeros_like(x))])
    Q = steady_gaf(wing, stack_motions(plunge, incidence_motion(wing)), 0.0, 0.5, "quartic")
    cla = -Q[0, 1] / wing.areas[~wing.mirrored].sum()
    assert cla == pytest.approx(_horseshoe_lift_slope(wing), rel=1e-3)
    # a plunge has no steady normalwash: no force at k = 0
    assert np.allclose(Q[:, 0], 0.0, atol=1e-12)
