"""Reduced frequencies chosen to cover the flutter range of the modes, and the RFA fitted and
checked where they matter (torchrom.aero.reduced_frequencies).

Independent references: the rules' closed forms (V = ω b / k), and the classical flutter of
Hodges & Pierce's typical section (tests/test_aero_flutter.py: U_F = 2.18391 b ω_α at μ = 20)
with Theodorsen's exact GAFs, written in its mass-normalised modes (a p-k answer does not
depend on the basis): the survey's p-k gives U_F to the table's interpolation (1e-4), the RFA
fitted where it matters gives it in the state space within the stated agreement (1 %).
"""

import numpy as np
import pytest
import scipy

from torchrom.aero import reduced_frequencies as rf
from torchrom.aero.build import _fit
from torchrom.aero.dlm import GAF
from torchrom.aero.theodorsen import TypicalSection

from .test_aero_flutter import HP


def test_default_speeds_and_table_are_the_stated_rules():
    """Modes 0, 0, 2 and 20 Hz (two rigid), b = 1: V_lo = max(ω_1 b / 2, ω_n b / 10),
    V_hi = ω_n b / 0.01 (exact); widened to FLUTTER velocities outside it. The table: 0, the
    quasi-steady 0.001, the listed k, 3 log-spaced k per decade from ω_1 b / V_hi to
    min(ω_n b / V_lo, 10), less those within a factor 1.25 of a listed k."""
    f = [0.0, 0.0, 2.0, 20.0]
    w1, wn = 4 * np.pi, 40 * np.pi
    (lo, hi), source = rf.default_speeds(f, 1.0)
    assert (lo, hi) == pytest.approx((max(w1 / 2, wn / 10), wn / 0.01), rel=1e-14)
    assert source.startswith("the modes")
    (lo2, hi2), source2 = rf.default_speeds(f, 1.0, [-5.0, 5.0, 2e4])
    assert (lo2, hi2) == (5.0, 2e4) and "FLUTTER" in source2
    k = np.array(rf.table_k(f, 1.0, (lo, hi), listed=[0.05, 0.1]))
    assert k[0] == 0.0 and {1e-3, 0.05, 0.1} <= set(k) and np.all(np.diff(k) > 0)
    grid = np.geomspace(w1 / hi, wn / lo, int(np.ceil(3 * np.log10(wn * hi / (w1 * lo)))) + 1)
    kept = [g for g in grid if not any(x / 1.25 < g < x * 1.25 for x in (1e-3, 0.05, 0.1))]
    assert set(k) == {0.0, 1e-3, 0.05, 0.1, *kept}
    assert k.max() == pytest.approx(min(wn / lo, rf.K_TABLE_MAX), rel=1e-12)


def test_fit_points_keep_the_band_below_k_fit_and_the_quasi_steady_point():
    k = np.array([0.0, 0.001, 0.002, 0.01, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0])
    gaf = GAF(0.0, 1.0, k, np.ones((len(k), 1, 1), complex))
    # the first k >= 0.88; at least the 4th positive k (MIN_FIT_K)
    assert rf.first_k_above(gaf, 0.88) == 1.0 and rf.first_k_above(gaf, 1e-4) == 0.05
    assert rf.fit_points(gaf, 1.0).k.tolist() == [0.0, 0.001, 0.05, 0.1, 0.2, 0.5, 1.0]
    # at least MIN_FIT_K positive k
    assert rf.fit_points(gaf, 0.05).k.tolist() == [0.0, 0.001, 0.002, 0.01, 0.05]
    assert rf.matter_range([0.0, 1.0, 10.0], 2.0, (5.0, 500.0), 100.0) == pytest.approx(
        (80.0, 20 * np.pi * 2.0 / 80.0))
    assert rf.matter_range([1.0, 10.0], 2.0, (5.0, 500.0), None)[0] == 5.0


def _section_in_modes():
    """Hodges & Pierce's typical section (b = 3, ω_α = 100, μ = 20 at ρ = 1.2) in its
    mass-normalised modes: (frequencies Hz, Q(k) in those modes, ρ, b, ω_α)."""
    b, w_a, rho = 3.0, 100.0, 1.2
    ts = TypicalSection(b, HP["a"], HP["x_alpha"], HP["r_alpha_sq"],
                        HP["mu"] * np.pi * rho * b**2, HP["sigma"] * w_a, w_a)
    w2, phi = scipy.linalg.eigh(ts.stiffness_matrix(), ts.mass_matrix())

    def gaf(k):
        return np.einsum("ia,kij,jb->kab", phi, ts.gaf(k), phi)

    return np.sqrt(w2) / (2 * np.pi), gaf, rho, b, w_a


def test_survey_fit_and_check_on_the_typical_section():
    """The default choice on the typical section: the survey's p-k flutter speed is the
    classical U_F = 2.18391 b ω_α (1e-4), the RFA is fitted on the k that matter (its k_fit
    recorded in the RFA, at or above k_m = ω_2 b / (0.8 U_F)), its error there is within the
    limit and the state space within 1 % of the p-k: no warning. A Roger RFA without lag
    states (quasi-steady, no Theodorsen lag) fails the check with warnings that say what to
    do (--lags)."""
    f, gaf_of, rho, b, w_a = _section_in_modes()
    survey = rf.plan(f, b, rho, "test")
    gaf = GAF(0.0, b, np.array(survey.k_table), gaf_of(np.array(survey.k_table)))
    rfa = rf.fit_and_check(survey, gaf, lambda g: _fit(g, 8, "minimum-state", False, f))
    assert survey.flutter_speed == pytest.approx(2.18391 * b * w_a, rel=1e-4)
    assert survey.matter_speed == pytest.approx(0.8 * survey.flutter_speed)
    assert survey.k_matter == pytest.approx(2 * np.pi * f[-1] * b / survey.matter_speed)
    assert survey.k_check >= survey.k_matter and rfa.fit_error["k_fit"] == survey.k_fit
    assert survey.rfa_error <= rf.RFA_ERROR_LIMIT
    assert survey.state_space_speed == pytest.approx(survey.flutter_speed, rel=rf.AGREEMENT)
    assert survey.ok and survey.as_dict()["ok"] is True
    assert any("p-k flutter at 655.2" in line for line in survey.describe("m/s"))

    from torchrom.aero.rfa import fit_roger

    bad = rf.plan(f, b, rho, "test")
    rf.fit_and_check(bad, gaf, lambda g: fit_roger(g, n_lags=0))
    assert bad.rfa_error > rf.RFA_ERROR_LIMIT and not bad.ok
    assert all("--lags" in w for w in bad.warnings)


def test_user_k_is_fitted_whole_and_checked_where_it_matters():
    """With the user's --k the table is theirs and the fit uses all of it (no k_fit recorded:
    the state space is searched over the table's range); the check is made at the k that
    matter all the same."""
    f, gaf_of, rho, b, _ = _section_in_modes()
    k_user = [0.05, 0.1, 0.2, 0.4, 0.8]
    survey = rf.plan(f, b, rho, "test", k_list=k_user)
    assert survey.k_table == [0.0, *k_user]
    gaf = GAF(0.0, b, np.array(survey.k_table), gaf_of(np.array(survey.k_table)))
    rfa = rf.fit_and_check(survey, gaf, lambda g: _fit(g, 8, "minimum-state", False, f),
                           cut=False)
    assert survey.k_fit == 0.8 and "k_fit" not in rfa.fit_error
    # the survey runs where the table holds every mode's k: from ω_2 b / 0.8
    assert survey.speeds[0] == pytest.approx(2 * np.pi * f[-1] * b / 0.8)
    # 5e-3: the p-k interpolates Q between the user's five k (0.19 % measured)
    assert survey.flutter_speed == pytest.approx(2.18391 * b * 100.0, rel=5e-3)
    assert survey.rfa_error <= rf.RFA_ERROR_LIMIT and survey.ok
