"""Aeroelastic assembly (torchrom.sim.aeroelastic) against the flutter analysis of torchrom.aero.

The reference is independent code: :func:`torchrom.aero.flutter.state_space_matrix` builds the
first-order system of Eqs. 49–50 from a ModalStructure and the RFA, and the flutter altitude
comes from its eigenvalues; here the same system is assembled as a CaseSystem (zero-padded to the
ROM's basis, including a stiff dual coordinate without aerodynamics) and integrated by the
batched Newmark simulator.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.aero.atmosphere import flight_condition
from torchrom.aero.flutter import ModalStructure, state_space_matrix
from torchrom.errors import InputError
from torchrom.paper.linear import linear_checks
from torchrom.sim import LCOCriteria, Newmark
from torchrom.sim.aeroelastic import (
    aero_additions,
    aeroelastic_system,
    check_aero_matches_rom,
    critical_eigenpair,
    growth_rate,
    linear_state_matrix,
)

from .aeroelastic_fixtures import MACH, section_aero, section_model


@pytest.fixture(scope="module")
def model():
    return section_model()


def test_additions_are_the_rfa_terms_scaled_by_the_flight_condition(model):
    aero, n = model.aero, model.rom.n
    fc = flight_condition(MACH, 8000.0)
    V, q, b = float(fc.velocity), float(fc.dynamic_pressure), aero.semichord
    add = aero_additions(aero, [V], [q], n)
    r = aero.rfa
    np.testing.assert_allclose(add["M_add"][0, :2, :2], q * b * b / V / V * r.A2, rtol=1e-14)
    np.testing.assert_allclose(add["C_add"][0, :2, :2], q * b / V * r.A1, rtol=1e-14)
    np.testing.assert_allclose(add["K_add"][0, :2, :2], q * r.A0, rtol=1e-14)
    np.testing.assert_allclose(add["lag_D"][0, :2], q * r.D, rtol=1e-14)
    np.testing.assert_allclose(add["lag_E"][0, :, :2], r.E, rtol=1e-14)
    np.testing.assert_allclose(add["lag_R"][0], V / b * r.R, rtol=1e-14)
    # the dual coordinate gets no aerodynamic force (DESIGN: aero on the first m modes only)
    for key in ("M_add", "C_add", "K_add"):
        assert not add[key][0, 2].any() and not add[key][0, :, 2].any()
    assert not add["lag_D"][0, 2].any() and not add["lag_E"][0, :, 2].any()


def test_linearisation_has_the_eigenvalues_of_the_flutter_state_space(model):
    """Exact up to rounding: the same Eqs. 49–50, assembled by two independent code paths
    (the dual coordinate adds its own decoupled roots)."""
    alpha, gamma = 0.05, 1e-4
    for h in (6000.0, 9587.8, 14000.0):
        ae = aeroelastic_system(model.rom, model.aero, h, alpha=alpha, gamma=gamma)
        fc = flight_condition(MACH, h)
        st = ModalStructure.from_rom(model.rom, 2, alpha, gamma)
        ref = np.linalg.eigvals(state_space_matrix(st, model.aero.rfa, float(fc.velocity),
                                                   float(fc.density)))
        ours = np.linalg.eigvals(linear_state_matrix(ae.system))
        for s in ref:
            assert np.min(np.abs(ours - s)) <= 1e-9 * np.abs(ref).max()
        assert ae.velocity[0] == pytest.approx(float(fc.velocity), rel=1e-14)
        assert ae.dynamic_pressure[0] == pytest.approx(float(fc.dynamic_pressure), rel=1e-14)


def test_simulated_growth_rate_changes_sign_at_the_eigenvalue_flutter_altitude(model):
    """Acceptance: within 50 ft (the trapezoidal rule preserves the sign of Re s exactly, so
    only the peak-fit error remains; observed ~0.01 ft)."""
    check = linear_checks(model, t_end=4.0, table3_altitudes=[6000.0])
    assert abs(check.difference_ft) < 50.0
    g = check.growth
    np.testing.assert_allclose(g["sigma_sim"], g["sigma_eig"], rtol=5e-3)  # peak-fit error
    np.testing.assert_allclose(g["f_sim"], g["f_eig"], rtol=1e-3)  # Newmark period error
    t3 = check.table3.iloc[0]
    assert t3["frequency_sim_hz"] == pytest.approx(t3["frequency_eig_hz"], rel=1e-3)


def test_linear_statuses_diverge_below_and_decay_above_the_flutter_altitude(model):
    """Acceptance: γ = 0 and both nonlinearities off (a linear system) never reaches an LCO:
    below the (matched) flutter altitude it diverges past the cap, above it decays."""
    h_f = model.reference_altitude()
    alpha = model.matched_alpha(0.0)
    alts = h_f + np.array([-2000.0, -500.0, 500.0, 2000.0])
    ae = aeroelastic_system(model.rom, model.aero, alts, alpha=alpha, gamma=0.0,
                            stiffness_nl=0.0, damping_nl=0.0)
    q0 = np.array([0.01, 0.0, 0.0])
    res = Newmark(dt=1e-3).run(ae.system, q0, t_end=60.0, outputs=["A_Tz"],
                               lco=LCOCriteria(max_amplitude=1.0))
    assert list(res.status) == ["diverged", "diverged", "decay", "decay"]


def test_aero_on_other_modes_is_refused(model):
    rom, aero = model.rom, model.aero
    flipped = rom.replace(outputs={"A_Tz": -rom.outputs["A_Tz"], "A_Ty": rom.outputs["A_Ty"]})
    with pytest.raises(InputError, match="mode 1: output A_Tz"):
        check_aero_matches_rom(flipped, aero)
    other = section_aero(rom)
    other.metadata["frequencies_hz"] = [f * 1.01 for f in other.metadata["frequencies_hz"]]
    with pytest.raises(InputError, match="mode 1: the aero data was computed on a mode"):
        check_aero_matches_rom(rom, other)
    dual_first = rom.replace(mode_kinds=["dual", "linear", "linear"])
    with pytest.raises(InputError, match="must be linear modes"):
        check_aero_matches_rom(dual_first, aero)
    with pytest.raises(InputError, match="Mach number"):
        aeroelastic_system(rom, aero, 8000.0, mach=0.7)


def test_dtype_and_batch_of_the_system(model):
    ae = aeroelastic_system(model.rom, model.aero, [4000.0, 8000.0, 12000.0], alpha=[0.1, 0.2, 0.3],
                            gamma=1e-4, stiffness_nl=[True, False, True], dtype=torch.float32)
    s = ae.system
    assert s.batch_size == 3 and s.dtype == torch.float32 and s.n_lag == model.aero.rfa.n_states
    assert s.stiffness_nl.tolist() == [1.0, 0.0, 1.0]
    assert ae.density[0] > ae.density[1] > ae.density[2]


def test_growth_rate_of_a_sampled_damped_sinusoid():
    """Closed form: y = e^{σt} cos(2π f t + φ) sampled at 1 kHz."""
    t = np.arange(0.0, 6.0, 1e-3)
    for sigma, f in ((0.3, 2.1), (-0.5, 1.3), (0.0, 4.0)):
        s, ff = growth_rate(t, np.exp(sigma * t) * np.cos(2 * np.pi * f * t + 0.4))
        assert s == pytest.approx(sigma, abs=2e-3)
        assert ff == pytest.approx(f, rel=1e-4)
    assert np.isnan(growth_rate(t[:100], np.sin(t[:100]))[0])


def test_critical_root_is_the_least_stable_oscillatory_one(model):
    ae = aeroelastic_system(model.rom, model.aero, 6000.0, alpha=0.05, gamma=1e-4)
    lam, vec = critical_eigenpair(ae.system)
    A = linear_state_matrix(ae.system)
    np.testing.assert_allclose(A @ vec, lam * vec, atol=1e-8 * np.abs(lam))
    s = np.linalg.eigvals(A)
    assert lam.real == pytest.approx(s[s.imag > 0].real.max())
