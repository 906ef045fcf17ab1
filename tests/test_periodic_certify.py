"""LCO certificates (torchrom.periodic.certify): the error they state against the errors
measured with independent orbits (converged shooting, harmonic balance at high H)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

from torchrom.periodic import HarmonicBalanceMethod, HBOptions
from torchrom.periodic.certify import FINISH_TOL, UNCERTIFIED, Certificate, certify
from torchrom.periodic.shooting import OrbitStart, ShootingOptions, shoot
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.sim import CaseSystem, LCOCriteria, Newmark

ROM = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
ROW = np.array([[1.0]])


def _system(alphas=(0.0, 0.1, 0.8)):
    return CaseSystem.build(ROM, len(alphas), alpha=list(alphas), gamma=1.0)


def test_a_newmark_lco_is_certified_with_the_distance_to_the_discrete_orbit():
    """A Newmark LCO accepted at rtol 1e-3 sits near, not on, the simulator's discrete orbit:
    the certificate's orbit_error (one Newton correction) equals the distance to the
    converged discrete orbit to within 10 % of it (Newton's error is quadratic in the
    distance); the decaying case (α = 0.8 > 0.6) is not touched."""
    system = _system()
    dt = 5e-3
    res = Newmark(dt=dt, iterations=3).run(system, [0.5], t_end=100.0, outputs=["sum"],
                                          lco=LCOCriteria(rtol=1e-3, cycles=2))
    assert list(res.status) == ["lco", "lco", "decay"]
    out = certify(system, res, ROW, 0, Certificate(tol=1e-2), dt)
    assert list(out.status) == ["lco", "lco", "decay"]
    lco = slice(0, 2)
    exact = shoot(system.select([0, 1]), OrbitStart(torch.as_tensor(res.q[lco]),
                                                      torch.as_tensor(res.v[lco]),
                                                      torch.zeros(2, 0),
                                                      torch.as_tensor(1 / res.frequency_hz[lco])),
                  ROW[0], options=ShootingOptions(dt=dt))
    distance = np.abs(res.amplitude[lco, 0] / exact.amplitude[:, 0] - 1)
    assert (distance > 1e-6).all()
    assert np.allclose(out.extra["orbit_error"][lco], distance, rtol=0.1, atol=1e-7)
    assert list(out.extra["certified"][lco]) == [True, True]
    assert all(s is True for s in out.extra["stable"][lco])
    assert np.isnan(out.extra["orbit_error"][2]) and out.extra["certified"][2] is None


def test_a_newmark_lco_is_taken_as_it_is_only_well_within_tol():
    """A time integration's row is accepted on its one-step estimate only within
    MARCHED_ACCEPT × tol (the estimate's error is quadratic in the distance: on the Goland
    γ = 0, 8,500 ft row of bench_lco it fell 13 % short at 3.4e-4); between that and tol it
    is finished to the discrete orbit, whose amplitude the row then reports."""
    from torchrom.periodic.certify import MARCHED_ACCEPT

    system = _system((0.0,))
    dt = 5e-3
    res = Newmark(dt=dt, iterations=3).run(system, [0.5], t_end=100.0, outputs=["sum"],
                                          lco=LCOCriteria(rtol=1e-3, cycles=2))
    exact = shoot(system, OrbitStart(torch.as_tensor(res.q), torch.as_tensor(res.v),
                                     torch.zeros(1, 0), torch.as_tensor(1 / res.frequency_hz)),
                  ROW[0], options=ShootingOptions(dt=dt))
    distance = abs(res.amplitude[0, 0] / exact.amplitude[0, 0] - 1)
    assert distance > 1e-6
    # within tol but not within MARCHED_ACCEPT × tol: finished
    tol = 2.0 * distance
    out = certify(system, res, ROW, 0, Certificate(tol=tol, richardson=False), dt)
    assert out.extra["finished"][0] == True  # noqa: E712
    assert out.extra["certified"][0] == True  # noqa: E712
    assert abs(out.amplitude[0, 0] / exact.amplitude[0, 0] - 1) < FINISH_TOL * tol
    assert out.extra["orbit_error"][0] < FINISH_TOL * tol
    # well within tol: taken as it is, with the estimate as its orbit_error
    tol = 2.0 * distance / MARCHED_ACCEPT
    out = certify(system, res, ROW, 0, Certificate(tol=tol, richardson=False), dt)
    assert out.extra["finished"][0] == False  # noqa: E712
    assert out.amplitude[0, 0] == res.amplitude[0, 0]
    assert math.isclose(out.extra["orbit_error"][0], distance, rel_tol=0.1)


def test_an_orbit_off_by_two_percent_is_finished_or_flagged():
    """HB orbits scaled by 1.02: the certificate states ≈ 2 % (to 10 % of it); with ``finish``
    the rows report the discrete orbits (the converged shooting's amplitude), else their status
    is lco_uncertified with their numbers kept. A decaying case between them is untouched."""
    system = _system((0.0, 0.8, 0.1))
    res = HarmonicBalanceMethod(HBOptions(harmonics=9)).run(system, outputs=["sum"])
    assert list(res.status) == ["lco", "decay", "lco"]
    X, w = res.orbits
    bad = dataclasses.replace(res, orbits=(X * 1.02, w), amplitude=res.amplitude * 1.02)
    lco = [0, 2]
    dt = float(1 / np.nanmax(res.frequency_hz)) / 256
    flagged = certify(system, bad, ROW, 0, Certificate(finish=False, richardson=False), dt)
    assert list(flagged.status) == [UNCERTIFIED, "decay", UNCERTIFIED]
    assert np.allclose(flagged.extra["orbit_error"][lco], 0.02 / 1.02, rtol=0.1)
    assert np.array_equal(flagged.amplitude, bad.amplitude, equal_nan=True)
    done = certify(system, bad, ROW, 0, Certificate(richardson=False), dt)
    assert list(done.status) == ["lco", "decay", "lco"]
    assert all(done.extra["finished"][lco]) and done.extra["finished"][1] is None
    # the finish stops once its scaled correction is below FINISH_TOL × tol (1e-5): the last
    # correction's amplitude change, the row's orbit_error, is no larger
    finish_tol = FINISH_TOL * Certificate().tol
    assert (done.extra["orbit_error"][lco] < finish_tol).all()
    assert np.allclose(done.amplitude[lco, 0], res.amplitude[lco, 0], rtol=2e-4)
    # a finished row's state is its discrete orbit's: one evaluation from it corrects nothing
    again = shoot(system.select(lco), OrbitStart(torch.as_tensor(done.q[lco]),
                                                 torch.as_tensor(done.v[lco]),
                                                 torch.as_tensor(done.xi[lco]),
                                                 torch.as_tensor(1 / done.frequency_hz[lco])),
                  ROW[0], options=ShootingOptions(dt=dt, max_iterations=0))
    assert (again.first_correction <= finish_tol).all()


def test_a_continuous_orbit_is_judged_against_the_extrapolated_discrete_orbits():
    """An HB orbit converged in H (continuous time) against a tolerance of 1e-6: at 256 steps
    per period the discrete orbit at dt is ~1.3e-6 off it (the map's (ωh)² error), so a
    comparison with the discrete orbit alone would fail it; measured against the Richardson
    extrapolation of the discrete orbits at dt and 2 dt it is certified as it is (not
    finished), and its dt_error bounds the step's error (see below)."""
    system = _system((0.0, 0.1))
    res = HarmonicBalanceMethod(HBOptions(harmonics=15, max_harmonics=15)).run(
        system, outputs=["sum"])
    dt = float(1 / np.nanmax(res.frequency_hz)) / 256
    tol = 1e-6
    out = certify(system, res, ROW, 0, Certificate(fourier=False, tol=tol), dt)
    assert list(out.status) == ["lco", "lco"]
    assert not any(out.extra["finished"]) and all(out.extra["certified"])
    assert (out.extra["orbit_error"] < tol).all()
    discrete = shoot(system, OrbitStart(torch.as_tensor(res.q), torch.as_tensor(res.v),
                                        torch.zeros(2, 0), torch.as_tensor(1 / res.frequency_hz)),
                     ROW[0], options=ShootingOptions(dt=dt))
    step_error = np.abs(discrete.amplitude[:, 0] / res.amplitude[:, 0] - 1)
    assert (step_error > tol).all()
    # above the step's error, and not by orders of magnitude: the coarse orbits at 2h and 4h
    # of one evaluation each are exact to first order in the start's distance, and on this
    # weakly attracting orbit the square of it moves their amplitudes by 2.8e-6 and 2.9e-5
    # (against converged ones), so the ratio of differences reads 7.4-8.6 instead of 4.0-4.1:
    # outside Newmark's asymptotic range, the row states the spread of the three orbits,
    # 35x its step error of 1.2e-6-1.4e-6 (a finished row's coarse orbits start on its
    # discrete orbit)
    dt_error = out.extra["dt_error"].astype(float)
    assert (step_error <= dt_error).all() and (dt_error <= 50 * step_error).all()


def test_the_certificate_bounds_the_error_against_the_continuous_orbit():
    """At 512 steps per period the discrete orbit is measurably off the continuous one:
    the reported amplitude's error against HB at H = 15 (converged in H to 1e-10 on this
    oscillator) stays within orbit_error + dt_error, and dt_error is the Richardson estimate
    of that error to within 25 % (Newmark is second order; the estimate from dt and 2 dt leaves
    the O(dt⁴) term, and the amplitude read at 2 dt from 256 samples per period with a parabola
    through the peak carries ≈ (2π/256)⁴/8 ≈ 5e-8, 15 % of these 3e-7 errors)."""
    system = _system((0.0, 0.1))
    hb = HarmonicBalanceMethod(HBOptions(harmonics=15, max_harmonics=15)).run(
        system, outputs=["sum"])
    dt = float(1 / hb.frequency_hz.max()) / 512
    res = Newmark(dt=dt, iterations=3).run(system, [0.5], t_end=100.0, outputs=["sum"],
                                          lco=LCOCriteria(rtol=1e-4, cycles=2))
    out = certify(system, res, ROW, 0, Certificate(fourier=False), dt)
    err = np.abs(out.amplitude[:, 0] / hb.amplitude[:, 0] - 1)
    bound = out.extra["orbit_error"] + out.extra["dt_error"]
    assert (err <= bound * 1.05).all() and (err > 1e-8).all()
    exact = shoot(system, OrbitStart(torch.as_tensor(res.q), torch.as_tensor(res.v),
                                     torch.zeros(2, 0), torch.as_tensor(1 / res.frequency_hz)),
                  ROW[0], options=ShootingOptions(dt=dt))
    dt_true = np.abs(exact.amplitude[:, 0] / hb.amplitude[:, 0] - 1)
    assert np.allclose(out.extra["dt_error"], dt_true, rtol=0.25)


def test_an_orbit_the_step_does_not_resolve_is_uncertified():
    """``dt_tol``: a row whose dt_error (here ≈ 1e-4 at 1/200 of the period) exceeds it is
    lco_uncertified with its numbers kept; within it (the default 0.1) the same row is lco."""
    system = _system((0.0,))
    dt = 5e-3
    res = Newmark(dt=dt, iterations=3).run(system, [0.5], t_end=100.0, outputs=["sum"],
                                          lco=LCOCriteria(rtol=1e-3, cycles=2))
    ok = certify(system, res, ROW, 0, Certificate(fourier=False, tol=1e-2), dt)
    dt_error = float(ok.extra["dt_error"][0])
    assert list(ok.status) == ["lco"] and 0 < dt_error < 0.1
    tight = certify(system, res, ROW, 0,
                    Certificate(fourier=False, tol=1e-2, dt_tol=dt_error / 2), dt)
    assert list(tight.status) == [UNCERTIFIED] and tight.extra["certified"][0] is False
    for k in ("orbit_error", "dt_error", "critical_multiplier"):
        assert tight.extra[k][0] == pytest.approx(ok.extra[k][0], rel=1e-12)
    assert tight.amplitude[0, 0] == ok.amplitude[0, 0]


def test_disabled_and_bad_settings():
    system = _system((0.0,))
    res = Newmark(dt=5e-3, iterations=3).run(system, [0.5], t_end=100.0, outputs=["sum"],
                                             lco=LCOCriteria(rtol=1e-3, cycles=2))
    out = certify(system, res, ROW, 0, Certificate(enabled=False), 5e-3)
    assert list(out.status) == ["lco"] and math.isnan(out.extra["orbit_error"][0])
    from torchrom.errors import InputError

    with pytest.raises(InputError, match="certificate.tol"):
        Certificate(tol=0.0)
    with pytest.raises(InputError, match="certificate.dt_tol"):
        Certificate(dt_tol=-1.0)
    with pytest.raises(InputError, match="certificate.finish"):
        Certificate(finish="yes")


def test_richardson_error_is_trusted_only_in_the_asymptotic_range():
    """Amplitudes A(h) = 1 + c h² (second order: the ratio of differences is 4) give
    Richardson's |A(2h) − A(h)|/(3A(h)) = c h² exactly (to rounding); an erratic sequence
    (ratio −1: outside the asymptotic range) gives the whole difference, three times that;
    differences below the resolution are taken as they are."""
    from torchrom.periodic.certify import richardson_error

    c, h = 0.3, 0.01
    a = {k: 1 + c * (k * h) ** 2 for k in (1, 2, 4)}
    err = richardson_error(np.array([a[1]]), np.array([a[2]]), np.array([a[4]]), 1e-12)
    assert np.isclose(err[0], c * h**2 / a[1], rtol=1e-9)
    erratic = richardson_error(np.array([1.0]), np.array([1.003]), np.array([1.0]), 1e-12)
    assert np.isclose(erratic[0], 0.003)
    tiny = richardson_error(np.array([1.0]), np.array([1.0 + 3e-9]), np.array([1.0]), 1e-5)
    assert np.isclose(tiny[0], 1e-9)


def test_richardson_error_judges_a_row_as_a_whole():
    """A row's quantities (its outputs' amplitudes and its frequency, columns) are in Newmark's
    asymptotic range together or not at all, and outside it the error is the spread of the
    three discrete orbits. The numbers: the Goland 7,000 ft, γ = 0 orbit's relative errors
    against the RK4 ODE orbit at h, 2h, 4h = 1, 2, 4 ms (A_Tz +9.8e-4, +2.0e-3, +6.7e-3: a
    ratio of differences of 4.59, outside 4 ± 10 %; its frequency −3.6) — Richardson's A_Tz
    estimate, 3.4e-4, fell short of the error 9.8e-4; the spread, 5.7e-3, does not — and a
    second row whose two quantities are both second order (ratio 4)."""
    from torchrom.periodic.certify import richardson_error

    true = 3.6746708  # the RK4 orbit's A_Tz (ft)
    goland = {1: (9.8e-4, 6.3e-5), 2: (2.0e-3, 2.18e-4), 4: (6.7e-3, -3.44e-4)}
    c, h = 0.3, 0.01
    second = {k: (c * (k * h) ** 2, 0.1 * c * (k * h) ** 2) for k in (1, 2, 4)}
    a = {k: np.array([[true * (1 + goland[k][0]), 1 + goland[k][1]],
                      [1 + second[k][0], 1 + second[k][1]]]) for k in (1, 2, 4)}
    err = richardson_error(a[1], a[2], a[4], 1e-12)
    assert err.shape == (2, 2)
    spread = np.maximum(np.abs(a[2] - a[1]), np.abs(a[4] - a[1]))[0] / a[1][0]
    assert np.allclose(err[0], spread)
    assert err[0, 0] >= 9.8e-4 / (1 + 9.8e-4)  # the error it states covers the RK4 one
    assert np.allclose(err[1], [c * h**2 / a[1][1, 0], 0.1 * c * h**2 / a[1][1, 1]],
                       rtol=1e-8)
    # A_Tz alone (these rounded errors: a ratio of 4.62) is outside 4 ± 10 % too
    alone = richardson_error(a[1][:1, :1], a[2][:1, :1], a[4][:1, :1], 1e-12)
    assert np.isclose(alone[0, 0], spread[0])


def test_a_row_whose_coarse_evaluation_fails_is_uncertified(monkeypatch):
    """With ``richardson`` the discretisation error is part of the certificate: where the
    evaluation at 4h fails (NaN: on the Goland γ = 0 orbits at h = 2 ms the 8 ms one does,
    and those rows' amplitudes were 2–3e-3 off the RK4 ODE orbit while the distance to the
    2 ms orbit said 3e-10) the row is lco_uncertified with dt_error, output_error and
    frequency_error NaN; without ``richardson`` the same row is certified on its distance
    to the discrete orbit."""
    import torchrom.periodic.certify as cert_module

    system = _system((0.0,))
    dt = 5e-3
    res = Newmark(dt=dt, iterations=3).run(system, [0.5], t_end=100.0, outputs=["sum"],
                                          lco=LCOCriteria(rtol=1e-3, cycles=2))
    real_coarse = cert_module._coarse

    def failing_at_4h(sub, state, c, C, h):
        d = real_coarse(sub, state, c, C, h)
        if h > dt:  # the evaluation at 4h
            return cert_module._Discrete(d.amplitudes * np.nan, d.frequency_hz * np.nan)
        return d

    monkeypatch.setattr(cert_module, "_coarse", failing_at_4h)
    out = certify(system, res, ROW, 0, Certificate(tol=1e-2), dt)
    assert list(out.status) == [UNCERTIFIED]
    for k in ("dt_error", "output_error", "frequency_error"):
        assert math.isnan(out.extra[k][0])
    plain = certify(system, res, ROW, 0, Certificate(tol=1e-2, richardson=False), dt)
    assert list(plain.status) == ["lco"] and plain.extra["output_error"][0] >= 0
