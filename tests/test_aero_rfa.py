"""RFA: Theodorsen's function with two lags, synthetic minimum-state recovery, Roger exactness."""

import numpy as np
import pytest

from torchrom.aero.dlm import GAF
from torchrom.aero.rfa import RFA, default_lag_roots, fit_minimum_state, fit_roger
from torchrom.aero.theodorsen import theodorsen_function
from torchrom.errors import InputError

# REFERENCE Sec. 2: exact C(k) = F + iG
REF_K = np.array([0.01, 0.05, 0.10, 0.20, 0.50, 1.00, 2.00])
REF_C = np.array(
    [
        0.98242 - 0.04565j,
        0.90901 - 0.13064j,
        0.83192 - 0.17230j,
        0.72758 - 0.18862j,
        0.59794 - 0.15071j,
        0.53943 - 0.10027j,
        0.51295 - 0.05769j,
    ]
)


def test_theodorsen_function_matches_reference_table():
    np.testing.assert_allclose(theodorsen_function(REF_K), REF_C, atol=6e-6)
    assert theodorsen_function(0.0) == 1.0
    # R. T. Jones' two-lag approximation is within about 0.015 (REFERENCE Sec. 2)
    p = 1j * REF_K
    jones = 1 - 0.165 * p / (p + 0.0455) - 0.335 * p / (p + 0.3)
    assert np.abs(jones - REF_C).max() < 0.015


def _theodorsen_gaf():
    k = np.r_[0.0, np.geomspace(0.005, 2.0, 40)]  # log spacing: C(k) varies with log k
    return GAF(0.0, 1.0, k, theodorsen_function(k)[:, None, None])


def test_two_lag_scalar_fit_of_theodorsen_is_within_0_02():
    fit = fit_minimum_state(
        _theodorsen_gaf(), n_lags=2, include_a1=False, include_a2=False, optimize_roots=True
    )
    err = np.abs(fit.evaluate(REF_K)[:, 0, 0] - REF_C)
    assert err.max() < 0.02  # acceptance; observed 0.011
    assert fit.A0[0, 0] == pytest.approx(1.0)  # A0 = Q(0) = C(0)
    # the optimised roots land near Jones' (0.0455, 0.3)
    np.testing.assert_allclose(fit.lag_roots, [0.0455, 0.3], rtol=0.15)
    # C(∞) = 1/2 follows from the fit: A0 + Σ d_l e_l
    assert (fit.A0 + fit.D @ fit.E)[0, 0] == pytest.approx(0.5, abs=0.02)
    assert fit.fit_error["rms_relative"] < 0.02


def _synthetic(seed=3, m=4, gam=(0.2, 0.6, 1.3)):
    rng = np.random.default_rng(seed)
    gam = np.asarray(gam)
    nl = len(gam)
    true = RFA(
        rng.normal(size=(m, m)),
        rng.normal(size=(m, m)),
        0.1 * rng.normal(size=(m, m)),
        rng.normal(size=(m, nl)),
        -np.diag(gam),
        rng.normal(size=(nl, m)),
        gam,
        "truth",
        1.0,
    )
    k = np.r_[0.0, np.geomspace(0.01, 2.0, 25)]
    return true, GAF(0.5, 1.0, k, true.evaluate(k)), rng


@pytest.mark.parametrize("polish", [False, True])
def test_minimum_state_recovers_synthetic_model(polish):
    true, gaf, rng = _synthetic()
    # start the alternating least squares from a random D, not from the (exact) Roger guess
    fit = fit_minimum_state(
        gaf, lag_roots=true.lag_roots, polish=polish, initial_d=rng.normal(size=true.D.shape)
    )
    k = np.linspace(0.0, 3.0, 61)  # also between and beyond the fitted frequencies
    ref = true.evaluate(k)
    assert np.abs(fit.evaluate(k) - ref).max() / np.abs(ref).max() < 1e-6
    for name in ("A0", "A1", "A2"):
        np.testing.assert_allclose(getattr(fit, name), getattr(true, name), atol=1e-6)
    for l in range(3):  # each lag term D_l E_l is unique (the split is not)
        np.testing.assert_allclose(
            np.outer(fit.D[:, l], fit.E[l]), np.outer(true.D[:, l], true.E[l]), atol=1e-6
        )
    assert fit.fit_error["rms_relative"] < 1e-6


def test_roger_is_exact_on_roger_data_and_has_state_space_form():
    true, gaf, _ = _synthetic(seed=5, m=3, gam=(0.3, 0.9))
    fit = fit_roger(gaf, lag_roots=true.lag_roots)
    k = np.linspace(0.0, 3.0, 31)
    np.testing.assert_allclose(fit.evaluate(k), true.evaluate(k), atol=1e-10)
    assert fit.D.shape == (3, 6) and fit.R.shape == (6, 6) and fit.E.shape == (6, 3)
    np.testing.assert_allclose(np.diag(fit.R), -np.repeat([0.3, 0.9], 3))


def test_default_lag_roots():
    np.testing.assert_allclose(default_lag_roots(3, 2.0), 1.7 * 2.0 * (np.arange(1, 4) / 4) ** 2)


def test_rfa_input_errors():
    _, gaf, _ = _synthetic()
    no_zero = GAF(0.5, 1.0, gaf.k[1:], gaf.Q[1:])
    with pytest.raises(InputError, match="k = 0"):
        fit_minimum_state(no_zero, n_lags=2)
    with pytest.raises(InputError, match="distinct positive"):
        fit_minimum_state(gaf, lag_roots=[0.2, 0.2])


def _free_aircraft_rfa():
    """A free 'aircraft' in the RFA's own form: rigid plunge h and pitch θ (0 Hz) and one
    elastic mode, M = I. Its Q(p) obeys the rigid-body kinematic identity exactly: the plunge
    column is zero at p = 0 and its slope is c times the pitch column at p = 0 (a climb at
    constant speed is force-free), so s = 0 is an exact double root of the state space."""
    rng = np.random.default_rng(7)
    m, gam = 3, np.array([0.08, 0.4, 1.1])
    a0 = rng.normal(size=(m, m)) * 0.05
    a0[:, 0] = 0.0  # no force from a plunge displacement
    slope = rng.normal(size=(m, m)) * 0.05
    slope[:, 0] = -1.75 * a0[:, 1]  # the kinematic identity, c = -1.75
    d = rng.normal(size=(m, len(gam))) * 0.02
    e = rng.normal(size=(len(gam), m))
    # A1 such that the slope A1 - D R⁻¹ E is the identity's
    a1 = slope - d @ np.diag(1 / gam) @ e
    a2 = rng.normal(size=(m, m)) * 0.01
    return RFA(a0, a1, a2, d, -np.diag(gam), e, gam, "minimum-state", 2.0), slope


def _roots_near_zero(rfa, velocity=300.0, density=1.225):
    from torchrom.aero.flutter import ModalStructure, state_space_matrix

    st = ModalStructure(M=np.eye(3), K=np.diag([0.0, 0.0, 400.0]))
    s = np.linalg.eigvals(state_space_matrix(st, rfa, velocity, density))
    return s[np.argsort(np.abs(s))][:2], s


def test_quasi_steady_slope_of_a_free_aircraft_restores_the_double_root_at_zero():
    """The fitted RFA misses the rigid columns' k -> 0 slope and splits the exact double root
    s = 0 (altitude, flight-path angle) into a spurious real root; imposing the table's slope
    on the rigid columns puts it back at zero, leaves Q(0) and the elastic column alone and
    moves the tabulated Q by at most |Δ| k_d (the lag added at γ0 = k_d)."""
    from torchrom.aero.rfa import impose_quasi_steady_slope, quasi_steady_slope, slope_at_zero

    true, slope = _free_aircraft_rfa()
    exact, _ = _roots_near_zero(true)
    assert np.abs(exact).max() < 1e-6  # a Jordan pair: ~sqrt(machine epsilon) apart
    k = np.array([0.0, 0.001, 0.05, 0.1, 0.2, 0.5, 1.0])
    gaf = GAF(0.2, 2.0, k, true.evaluate(k))
    table_slope, k_d = quasi_steady_slope(gaf)
    assert k_d == 0.001
    # Im Q(ik)/k = Q1 - k² Q3: the table's slope to O(k_d²); here the slowest lag's
    # (k_d / γ_1)² |D R⁻¹ E| = (0.001 / 0.08)² 0.25 = 4e-5
    np.testing.assert_allclose(table_slope, slope, atol=1e-4)
    fit = fit_minimum_state(gaf, n_lags=2, weighting="point", weight_floor=1e-4)
    split, _ = _roots_near_zero(fit)
    print("fitted RFA: roots nearest 0", split, "slope error",
          np.abs(slope_at_zero(fit) - slope)[:, :2].max())
    assert np.abs(split).max() > 1e-4  # the artefact (measured 7.7 1/s here)
    rigid = np.array([True, True, False])
    fixed = impose_quasi_steady_slope(fit, gaf, rigid, weight_floor=1e-4)
    np.testing.assert_allclose(slope_at_zero(fixed)[:, :2], table_slope[:, :2], atol=1e-12)
    np.testing.assert_array_equal(slope_at_zero(fixed)[:, 2], slope_at_zero(fit)[:, 2])
    np.testing.assert_array_equal(fixed.A0, fit.A0)
    restored, _ = _roots_near_zero(fixed)
    print("slope imposed: roots nearest 0", restored)
    # the table's slope is the true one to 4e-5 (above): the split shrinks by about the
    # ratio of the slope errors
    assert np.abs(restored).max() < 0.1 * np.abs(split).max()
    delta = np.abs(table_slope - slope_at_zero(fit))[:, :2].max()
    moved = np.abs(fixed.evaluate(k) - fit.evaluate(k)).max()
    assert moved <= delta * k_d * (1 + 1e-9)
    assert fixed.n_states == fit.n_states + 2
    assert fixed.fit_error["rms_relative"] <= fit.fit_error["rms_relative"] + delta * k_d


def test_impose_quasi_steady_slope_needs_a_positive_k():
    from torchrom.aero.rfa import impose_quasi_steady_slope

    true, _ = _free_aircraft_rfa()
    gaf = GAF(0.2, 2.0, np.array([0.0]), true.evaluate([0.0]))
    with pytest.raises(InputError, match="no k > 0"):
        impose_quasi_steady_slope(true, gaf, [True, False, False])
    # nothing rigid: the RFA itself
    assert impose_quasi_steady_slope(true, gaf, [False] * 3) is true
