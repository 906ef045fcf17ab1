"""The LCO certificates (torchrom.periodic.certify, .fourier_certificate) against an independent
continuous-time truth: shooting on the ODE with scipy's DOP853 at rtol 1e-10 and its
variational monodromy (tests/ode_reference.py: its own right-hand side from the ROM's dense
tensors, none of torchrom's solvers).

Model: the typical-section aeroelastic wing of tests/aeroelastic_fixtures.py (plunge, pitch, a
stiff quadratically coupled dual coordinate, a 4-lag RFA: the Goland ROM's structure at three
coordinates), post-flutter at 6,000 and 8,000 ft, γ = 0 and the baseline 1e-4 s. The Goland ROM
itself is not here: DOP853 at rtol 1e-10 did not finish one period of its 9L12D system (dual
modes up to 782 Hz, 13 lags) in 10 minutes on the shared 2-core machine.

Each bound is checked on every output's amplitude, the frequency and the stability verdict.
The reference's own accuracy: its Newton corrections end below 1e-9 of the state, and its
amplitudes come from 2,048 samples per period with a parabola at each extreme (relative error
~1e-9), so a bound is asserted to hold to within 1e-8 relative on top of itself.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from torchrom.periodic import HarmonicBalanceMethod
from torchrom.periodic.certify import FINISH_TOL, Certificate, certify
from torchrom.periodic.fourier import resize_harmonics
from torchrom.periodic.solve import orbit_state
from torchrom.sim import LCOCriteria
from torchrom.study.cases import case_system

from .aeroelastic_fixtures import section_model
from .ode_reference import CaseODE, goland_hb_rows, shoot_ode

OUTPUTS = ["A_Tz", "A_Ty"]
#: the reference's resolution (module docstring)
REFERENCE_RESOLUTION = 1e-8
#: the certificates' tolerance in these tests (the default)
CERTIFICATE_TOL = Certificate().tol


def _setup(altitudes, gammas, all_lco: bool = True):
    model = section_model()
    cases = [{"altitude_ft": a, "gamma": g, "alpha": 0.05} for g in gammas for a in altitudes]
    system = case_system(model, cases)[0]
    C = np.stack([model.rom.outputs[o] for o in OUTPUTS])
    res = HarmonicBalanceMethod().run(system, outputs=OUTPUTS, lco=LCOCriteria(max_amplitude=10.0))
    assert (res.status == "lco").all() or not all_lco
    return system, C, res


def _reference(system, C, X, w, i):
    """The ODE orbit of case i from the Fourier orbit X[i], ω[i]."""
    one = torch.as_tensor([i])
    q, v, xi = orbit_state(system.select(one), torch.as_tensor(X[i:i + 1]),
                           torch.as_tensor(w[i:i + 1]))
    return shoot_ode(CaseODE(system, i), np.concatenate([q[0], v[0], xi[0]]),
                     2 * np.pi / float(w[i]), C[0], C)


def _check_against_truth(system, C, res, out) -> dict:
    """Every certified row: each output's amplitude, the frequency and the stability within
    the certificate's statements of the ODE's orbit (returned per row)."""
    X, w = res.orbits
    refs = {}
    for i in np.flatnonzero(out.extra["certified"] == True):  # noqa: E712 (object column)
        ref = refs[i] = _reference(system, C, X, w, i)
        assert ref.correction < 1e-9
        amp_err = np.abs(out.amplitude[i] / ref.amplitude - 1)
        freq_err = abs(out.frequency_hz[i] / ref.frequency_hz - 1)
        kind = out.extra["certificate"][i]
        if kind == "fourier":
            # one bound for every output (relative to each output's own amplitude)
            assert (amp_err <= out.extra["output_error"][i] + REFERENCE_RESOLUTION).all()
            assert amp_err[0] <= out.extra["orbit_error"][i] + REFERENCE_RESOLUTION
            assert freq_err <= out.extra["frequency_error"][i] + REFERENCE_RESOLUTION
        else:
            # shooting: estimates exact to first order (one Newton step and Richardson's
            # extrapolation): within 1.05 of them, the decision output's orbit_error +
            # dt_error, every output's output_error and the frequency's frequency_error, and
            # nothing below the finish's own resolution (a finished orbit stops within
            # FINISH_TOL x tol of the discrete one; as bench_lco)
            floor = FINISH_TOL * CERTIFICATE_TOL + REFERENCE_RESOLUTION
            dt = np.nan_to_num(out.extra["dt_error"][i])
            assert amp_err[0] <= 1.05 * (out.extra["orbit_error"][i] + dt) + floor
            assert (amp_err <= 1.05 * out.extra["output_error"][i] + floor).all()
            assert freq_err <= 1.05 * out.extra["frequency_error"][i] + floor
        # the stability of record is the continuous-time system's
        assert out.extra["stable"][i] == (ref.critical < 1.0)
    return refs


def test_fourier_certificates_bound_the_ode_orbit_on_every_output():
    """HB orbits (H = 5) of four post-flutter cases, γ = 0 and 1e-4: all certified by the
    Fourier certificate (no time step, dt_error 0), each output's amplitude and the frequency
    within their bounds of the ODE orbit; measured (amplitude bounds through the corrected
    orbit, :meth:`~torchrom.periodic.fourier_certificate.FourierBound.amplitude_error`): A_Tz
    bounds 2.0e-8–1.6e-6 against errors 1.7e-8–1.4e-6, A_Ty 4.2e-7–2.0e-5 against
    3.6e-7–2.0e-5, frequency 2.3e-12–1.7e-9 against 2.3e-12–1.6e-9: the bounds are tight
    (within a factor 2.2), so an error in the bound's construction would show."""
    system, C, res = _setup((6000.0, 8000.0), (0.0, 1e-4))
    out = certify(system, res, C, 0, Certificate(), 1e-3)
    assert list(out.extra["certificate"]) == ["fourier"] * 4
    assert (out.extra["dt_error"] == 0).all()
    assert (out.extra["orbit_error"] < 1e-5).all()
    refs = _check_against_truth(system, C, res, out)
    # the critical multiplier of record is the continuous-time system's: at γ = 0 the stiff
    # dual coordinate's own (exp(−α T/2) ≈ 0.997: only α M damps it), which the monodromy
    # condenses out of its slow state (0.31–0.38 there); measured within 0.0012 of the ODE's at
    # γ = 0 and 0.0008 at γ = 1e-4 (0.011 before the condensation carried the dual coordinates'
    # inertia, issue 48); asserted within 0.005
    for i, ref in refs.items():
        assert abs(out.extra["critical_multiplier"][i] - ref.critical) < 0.005
        assert abs(out.extra["stability_margin"][i] - (1 - ref.critical)) < 0.005
    # and tight: every measured error of A_Tz is at least a quarter of its bound
    for i, ref in refs.items():
        error = abs(out.amplitude[i, 0] / ref.amplitude[0] - 1)
        assert error >= 0.25 * out.extra["orbit_error"][i] - REFERENCE_RESOLUTION


def test_shooting_certificates_bound_every_output_and_the_frequency():
    """The same four orbits certified by shooting alone (``fourier = false``) at h = 1 ms:
    accepted against the Richardson extrapolation of the discrete orbits, and finished to the
    discrete orbits (``always_finish``): every output's amplitude within ``output_error`` and
    the frequency within ``frequency_error`` of the DOP853 orbit, as the decision output within
    orbit_error + dt_error (first-order estimates: within 1.05 of them, above the finish's
    resolution). The coarse orbits at 2 and 4 ms are one evaluation each, exact to first order
    in their start's distance; here the square of it shows (the converged orbits' errors
    scale by 4.0 per doubling, the one-evaluation ones do not), so every row is taken as
    outside Newmark's asymptotic range and its bounds are the spread of the discrete orbits
    at h, 2h, 4h: valid, and loose. Measured: accepted, A_Tz 1.7e-8–1.4e-6 off against
    1.2e-4–6.9e-4, A_Ty 3.6e-7–2.0e-5 against output_error 8.2e-4–1.9e-3, frequency
    2e-12–1.6e-9 against 3.6e-3–3.9e-3 (the row reports harmonic balance's frequency; the
    bound includes the discrete orbits' own error); finished, A_Tz 2.6e-6–2.2e-5 against
    6.6e-5–6.0e-4, A_Ty 8.9e-6–4.1e-5 against 6.5e-4–1.6e-3, frequency 2.5e-4–2.6e-4 (Newmark's
    period error at 1 ms) against 3.6e-3–3.9e-3."""
    system, C, res = _setup((6000.0, 8000.0), (0.0, 1e-4))
    for cert in (Certificate(fourier=False), Certificate(fourier=False, always_finish=True)):
        out = certify(system, res, C, 0, cert, 1e-3)
        assert list(out.extra["certificate"]) == ["shooting"] * 4
        assert all(out.extra["certified"])
        assert list(out.extra["finished"]) == [cert.always_finish] * 4
        # every output's bound covers the decision output's
        dec = out.extra["orbit_error"] + out.extra["dt_error"]
        assert (out.extra["output_error"] >= dec * (1 - 1e-12)).all()
        refs = _check_against_truth(system, C, res, out)
        assert len(refs) == 4
        if cert.always_finish:
            # the discrete orbits' frequencies are off by Newmark's period error, and the
            # bound states it within a factor 20
            for i, ref in refs.items():
                err = abs(out.frequency_hz[i] / ref.frequency_hz - 1)
                assert out.extra["frequency_error"][i] < 20.0 * err


def test_an_orbit_two_percent_off_fails_the_fourier_certificate():
    """The same orbits scaled by 1.02: the Fourier certificate refuses every one (its bound is
    ~2 %, above tol 1e-3); without a finish they are lco_uncertified, with one the shooting
    certificate takes them over."""
    system, C, res = _setup((6000.0,), (0.0, 1e-4))
    X, w = res.orbits
    bad = dataclasses.replace(res, orbits=(X * 1.02, w), amplitude=res.amplitude * 1.02)
    out = certify(system, bad, C, 0, Certificate(finish=False, richardson=False), 1e-3)
    assert all(k == "shooting" for k in out.extra["certificate"])
    assert list(out.status) == ["lco_uncertified"] * 2


def test_a_truncated_tail_fails_or_is_bounded():
    """The orbits cut to their first harmonic (the tail of harmonics 2–5 dropped): the
    Fourier certificate may not certify them within tol at the reported numbers unless its
    bound covers the ODE's error; measured: every one is refused (bound above tol)."""
    system, C, res = _setup((6000.0,), (1e-4,))
    X, w = res.orbits
    cut = resize_harmonics(resize_harmonics(torch.as_tensor(X), 1), (X.shape[1] - 1) // 2)
    extra = {**res.extra, "harmonics": np.ones_like(res.extra["harmonics"])}
    from torchrom.periodic.solve import orbit_amplitude

    amp = orbit_amplitude(cut @ torch.as_tensor(C).T, res.status)
    bad = dataclasses.replace(res, orbits=(cut.numpy(), w), amplitude=amp, extra=extra)
    out = certify(system, bad, C, 0, Certificate(tol=1e-4, finish=False, richardson=False),
                  1e-3)
    assert out.extra["certificate"][0] == "shooting"
    assert out.status[0] == "lco_uncertified"


def test_a_refused_orbit_raised_to_more_harmonics_is_fourier_certified():
    """The orbits cut to their first harmonic, γ = 0 and 1e-4 at 6,000 ft, refused at H = 1
    (tol 1e-4; as above), with ``max_harmonics`` = 7: re-solved at H = 3, where the Fourier
    certificate takes the γ = 1e-4 row (its amplitude bound through the corrected orbit:
    A_Tz 5.5e-5 off the DOP853 orbit, within tol; A_Ty 1.8e-4 against output_error 1.8e-3,
    frequency 2.5e-5 against 5.1e-5), then the γ = 0 row at 7 (A_Tz 4.3e-9 and A_Ty 9.3e-9
    against output_error 2.2e-7, frequency 2.6e-12 against 2.6e-12); every output's amplitude,
    the frequency and the stability (recomputed at the new H) within the certificate's
    statements of the DOP853 orbit; critical multiplier 0.9972 against the ODE's 0.9960
    (γ = 0) and 0.377 against 0.368."""
    system, C, res = _setup((6000.0,), (0.0, 1e-4))
    X, w = res.orbits
    cut = resize_harmonics(resize_harmonics(torch.as_tensor(X), 1), (X.shape[1] - 1) // 2)
    extra = {**res.extra, "harmonics": np.ones_like(res.extra["harmonics"])}
    from torchrom.periodic.solve import orbit_amplitude

    amp = orbit_amplitude(cut @ torch.as_tensor(C).T, res.status)
    bad = dataclasses.replace(res, orbits=(cut.numpy(), w), amplitude=amp, extra=extra)
    cert = Certificate(tol=1e-4, finish=False, richardson=False)
    without = certify(system, bad, C, 0, cert, 1e-3)
    assert list(without.extra["certificate"]) == ["shooting"] * 2
    out = certify(system, bad, C, 0, dataclasses.replace(cert, max_harmonics=7), 1e-3)
    assert list(out.extra["certificate"]) == ["fourier"] * 2
    assert list(out.extra["harmonics"]) == [7, 3]
    assert list(out.status) == ["lco"] * 2
    # the references start from the raised orbits (those the rows now report)
    refs = _check_against_truth(system, C, out, out)
    assert len(refs) == 2
    for i, ref in refs.items():
        assert abs(out.extra["critical_multiplier"][i] - ref.critical) < 0.02


@pytest.mark.slow
def test_fourier_certificates_bound_the_ode_orbit_on_more_cases():
    """The fuller form: five altitudes from far beyond flutter to near it, γ = 0, 1e-4, 1e-3
    (at 1e-3 the two highest decay: untouched by the certificate); every LCO certified."""
    system, C, res = _setup((4000.0, 6000.0, 7000.0, 8000.0, 9000.0), (0.0, 1e-4, 1e-3),
                            all_lco=False)
    out = certify(system, res, C, 0, Certificate(), 1e-3)
    lco = res.status == "lco"
    assert lco.sum() >= 13
    assert all(out.extra["certified"][lco])
    _check_against_truth(system, C, res, out)


@pytest.mark.slow
def test_goland_fourier_bounds_hold_against_harmonic_balance_at_39_harmonics(tmp_path):
    """The paper's Goland 9L12D ROM (full pipeline), at 10,000 ft with γ = 0 and at 8,500 and
    10,000 ft with γ = 1e-3, harmonic balance with its defaults (H = 7): the Fourier bound of
    every output's amplitude and of the frequency holds against the same orbits re-solved at
    H = 39 (the second method the issue names: HB at much higher H; DOP853 does not finish a
    period of this ROM), to within the reference's own resolution, taken as its change from
    H = 29 to 39. The γ = 0 row is bounded directly (its harmonic-balance stability is
    unresolved, so ``certify`` hands it to shooting); the orbits scaled by 1.02 are refused.
    Measured: γ = 0 A_Tz 1.3e-4 off against a bound of 4.2e-4 (the sup-distance bound alone,
    1.04e-3, refused it), A_Tx 2.4e-3 against 1.3e-2, frequency 1.6e-5 against 2.2e-4; γ =
    1e-3 errors 8e-6–2.9e-3 of the outputs against bounds 2.6e-5–4.8e-3 (A_Tz to A_Tx); the
    pipeline build is most of its 110 s."""
    from torchrom.periodic.fourier_certificate import fourier_bound
    from torchrom.periodic.solve import HBOptions, orbit_amplitude, refine_harmonics

    _, system, C, res = goland_hb_rows(tmp_path, ((10000.0, 0.0), (8500.0, 1e-3), (10000.0, 1e-3)))
    assert (res.status == "lco").all()
    X, w = res.orbits
    H = int(res.extra["harmonics"][0])
    assert (res.extra["harmonics"] == H).all()
    X = torch.as_tensor(X[:, : 2 * H + 1])
    w = torch.as_tensor(w)
    a = np.abs(res.amplitude)
    b = fourier_bound(system, X, w, C[0], C)
    assert b.converged.all()
    bound = b.amplitude_error(a) / a
    refs = {}
    for h in (29, 39):
        Xh, wh, conv, _, _ = refine_harmonics(system, resize_harmonics(X, h), w,
                                              torch.as_tensor(C[0]), h, HBOptions(),
                                              torch.arange(3))
        assert bool(conv.all())
        refs[h] = (orbit_amplitude(Xh @ torch.as_tensor(C).T, res.status), wh.numpy())
    resolution = np.abs(refs[29][0] / refs[39][0] - 1)
    amp_err = np.abs(a / refs[39][0] - 1)
    assert (amp_err <= bound + resolution).all()
    freq_err = np.abs(w.numpy() / refs[39][1] - 1)
    assert (freq_err <= b.frequency_error + np.abs(refs[29][1] / refs[39][1] - 1)).all()
    assert bound[0, 0] < 1e-3  # the γ = 0 row within tol through the corrected orbit
    # the γ = 1e-3 rows: certified by the Fourier certificate (their stability resolves)
    out = certify(system, res, C, 0, Certificate(finish=False, richardson=False), 1e-3)
    assert list(out.extra["certificate"][1:]) == ["fourier"] * 2
    # 2 % off: refused on every row
    far = fourier_bound(system, 1.02 * X, w, C[0], C)
    far_bound = far.amplitude_error(1.02 * a)[:, 0] / (1.02 * a[:, 0])
    assert (~far.converged | (far_bound > 1e-3)).all()
