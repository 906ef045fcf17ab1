"""The exact condensation about a deformed state (torchrom.trim.condensed) against the closed
form of test_identify_condensation's bending–membrane model: its membrane relaxed exactly, the
condensed force of (w1, w2) is known, and so its equilibrium under a steady "aerodynamic" load
and its tangent there; with a linear skin D added on the ROM's coordinates only."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from torchrom.errors import ConvergenceError
from torchrom.trim.condensed import CondensedModel
from torchrom.trim.reduced import SteadyModalAero

from .test_identify_condensation import (
    _backend,
    _condensed_force,
    _condensed_tangent_closed_form,
    _membrane_tangent,
)

PHI = np.eye(3)[:, :2]                       # the bending DOFs: the ROM's two coordinates
SKIN = np.array([[0.5, 0.2], [0.2, 0.3]])   # D: a skin the solved structure lacks
AERO = SteadyModalAero(np.array([[-0.8, 0.3], [0.1, -0.5]]), np.array([1.0, -0.6]))


def _model():
    K1 = PHI.T @ _membrane_tangent(np.zeros(3)) @ PHI + SKIN
    return CondensedModel(_backend(), PHI, K1)


def test_equilibrium_and_tangent_are_the_closed_forms():
    """R(q) = D q + f_c(q) + q∞ Q0 q + q∞ Q_α α = 0 solved by Newton on the scalar closed form
    (scipy's fsolve to 1e-13) and K_c = D + ∂f_c/∂q there: the condensation's q within 1e-8
    (the FE solves stop at 1e-10 of their load, the membrane's 1e6 stiffness multiplies the
    rest) and its tangent within 1e-7 of the largest entry."""
    model = _model()
    dyn, aoa = 0.4, 0.3

    def residual(q):
        return SKIN @ q + _condensed_force(q) + dyn * AERO.Q0 @ q + dyn * aoa * AERO.incidence

    want = scipy.optimize.fsolve(residual, np.zeros(2), xtol=1e-13)
    assert np.abs(residual(want)).max() < 1e-12 and np.abs(want).max() > 0.05
    st = model.equilibrium(AERO, dyn, aoa, np.zeros(2))
    np.testing.assert_allclose(st.q, want, atol=1e-8)
    Kc = model.tangent(st)
    expected = SKIN + _condensed_tangent_closed_form(want)
    np.testing.assert_allclose(Kc, expected, atol=1e-7 * np.abs(expected).max())
    assert st.iterations >= 2


def test_equilibrium_that_does_not_converge_is_an_error():
    with pytest.raises(ConvergenceError, match="condensed equilibrium: not converged in 1"):
        _model().equilibrium(AERO, 0.4, 0.3, np.zeros(2), max_iter=1)
