"""The slow certificate (torchrom.periodic.slow_certificate) against an independent
continuous-time reference: shooting on the ODE with scipy's DOP853 (tests/ode_reference.py:
its own right-hand side from the ROM's dense tensors, none of torchrom's solvers, kernels or
Fourier machinery), on the typical-section wing (plunge, pitch, one stiff dual coordinate
quadratically coupled to the plunge, 4 aerodynamic lags: self-excited by flutter) on damped and
undamped rows, and (slow-marked) on the Goland 9L12D ROM against the RK4 reference."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.periodic import HarmonicBalanceMethod
from torchrom.periodic.certify import Certificate, certify
from torchrom.periodic.fourier import FourierBasis
from torchrom.periodic.slow_certificate import multiplication_operator, slow_certificate
from torchrom.periodic.solve import orbit_state
from torchrom.sim import LCOCriteria
from torchrom.study.cases import case_system

from .aeroelastic_fixtures import section_model
from .ode_reference import CaseODE, StiffCaseODE, goland_hb_rows, shoot_ode, shoot_ode_rk4

OUTPUTS = ["A_Tz", "A_Ty"]
#: damped (γ = 1e-4, α = 0.05), undamped with mass damping (γ = 0, α = 0.05) and without any
#: damping (γ = 0, α = 0: the dual's own multiplier is 1), and a row whose dual coordinate is
#: overdamped by its Kelvin–Voigt damping (γ = 1e-3: γ k_u/m_u ω ≈ 2.4 at the LCO's
#: frequency, so its dynamic corrections diverge from harmonic ~9 on)
SECTION_CASES = [{"altitude_ft": 8000.0, "gamma": 1e-4, "alpha": 0.05},
                 {"altitude_ft": 8000.0, "gamma": 0.0, "alpha": 0.05},
                 {"altitude_ft": 6000.0, "gamma": 0.0, "alpha": 0.0},
                 {"altitude_ft": 6000.0, "gamma": 1e-3, "alpha": 0.05}]


def test_multiplication_operator_is_the_projection_of_the_product():
    """The real-coefficient matrix of q ↦ T(τ) q against its definition: T (harmonics ≤ 2) and
    q (harmonics ≤ 4) sampled at 23 phases, their product projected onto harmonics 0..4 (exact:
    the product has harmonics ≤ 6 < 23 − 4). Rounding only: 1e-13 of the largest entry."""
    torch.manual_seed(0)
    K, N, a = 4, 23, 3
    b = FourierBasis.build(K, N)
    T = (FourierBasis.build(2, N).E @ torch.randn(1, 5, a * a, dtype=torch.float64)).view(
        1, N, a, a)
    X = torch.randn(1, 2 * K + 1, a, dtype=torch.float64)
    ref = b.P @ (T @ (b.E @ X)[..., None])[..., 0]
    J = multiplication_operator(T, K).reshape(1, (2 * K + 1) * a, -1)
    out = (J @ X.reshape(1, -1, 1)).view_as(ref)
    assert (out - ref).abs().max() <= 1e-13 * ref.abs().max()


@pytest.fixture(scope="module")
def section_rows():
    model = section_model()
    system = case_system(model, SECTION_CASES, dtype=torch.float64)[0]
    C = np.stack([model.rom.outputs[o] for o in OUTPUTS])
    res = HarmonicBalanceMethod().run(system, outputs=OUTPUTS,
                                      lco=LCOCriteria(max_amplitude=10.0))
    assert (res.status == "lco").all()
    return system, C, res


def _dop853(system, C, X, w, i):
    sub = system.select(torch.as_tensor([i]))
    q, v, xi = orbit_state(sub, torch.as_tensor(X[i:i + 1]), torch.as_tensor(w[i:i + 1]))
    return shoot_ode(CaseODE(system, i), np.concatenate([q[0], v[0], xi[0]]),
                     2 * np.pi / float(w[i]), C[0], C)


def test_slow_certificate_bounds_the_section_orbits(section_rows):
    """Every certified row's outputs and frequency within their bounds of the DOP853 orbit
    (rtol 1e-10: its own error ~1e-10 of the amplitude, allowed on top), its verdict the ODE's
    and its critical multiplier within 0.005 of the ODE's (the monodromy condenses the dual at
    first order in (ω/ω_d)² ≈ 5e-4 and uses 32 steps). The overdamped-dual row is refused
    (no harmonics on which the duals' corrections converge). Measured: amplitude errors
    1.3e-8 / 1.5e-8 against bounds 3.8e-8 / 1.5e-7 (γ = 1e-4; A_Tz, A_Ty), 6e-11–1.4e-10
    against 1.2e-8–6.8e-8 (γ = 0; there the bound is mostly the sampled-amplitude enclosure),
    frequency 6e-9 against 2.1e-8, κ = 3e-4–1.2e-3, multipliers 0.6643 against 0.6648 and
    0.9971 against 0.9966 (the α = 0 row: 1 against 0.9988, both stable)."""
    system, C, res = section_rows
    X, w = res.orbits
    out = slow_certificate(system, torch.as_tensor(X), torch.as_tensor(w), C[0], C)
    assert list(out.certified) == [True, True, True, False]
    assert out.harmonics[3] == 0
    for i in range(3):
        ref = _dop853(system, C, X, w, i)
        err = np.abs(out.amplitude[i] - ref.amplitude)
        assert (err <= out.amplitude_error[i] + 1e-9 * ref.amplitude).all(), (i, err)
        assert abs(out.frequency_hz[i] / ref.frequency_hz - 1) <= out.frequency_error[i] + 1e-10
        assert out.stable[i] == (ref.critical < 1.0)
        assert abs(out.critical[i] - ref.critical) < 5e-3


def test_certify_reports_the_slow_orbit(section_rows):
    """Wired into :func:`~torchrom.periodic.certify.certify` (the Fourier certificate off, so
    that the slow one takes the rows): certificate "slow" on the rows it certifies, their
    amplitude and frequency the certificate's corrected orbit (within its stated bounds of the
    DOP853 orbit, as above); the undamped row without mass damping (its dual's own multiplier
    exactly 1: no stability margin above the monodromy's accuracy) and the refused row go to
    shooting."""
    system, C, res = section_rows
    cert = Certificate(fourier=False, slow=True)
    out = certify(system, res, C, 0, cert, 1e-3)
    assert list(out.extra["certificate"]) == ["slow", "slow", "shooting", "shooting"]
    assert all(out.extra["certified"])
    X, w = res.orbits
    ref = _dop853(system, C, X, w, 0)
    rel = np.abs(out.amplitude[0] / ref.amplitude - 1)
    assert (rel <= out.extra["output_error"][0] + 1e-9).all()
    assert out.extra["dt_error"][0] == 0.0 and out.extra["finished"][0] is False


def test_certificate_slow_must_be_a_boolean():
    with pytest.raises(InputError, match="certificate.slow"):
        Certificate(slow="yes")


@pytest.mark.slow
def test_goland_slow_certificate_against_the_rk4_ode(tmp_path):
    """The paper's Goland 9L12D ROM (full pipeline): the harmonic-balance rows at 10,000 ft,
    γ = 0 (which the Fourier certificate refuses) and 4,000 ft, γ = 1e-3, against the RK4 ODE
    orbit at 12,500 steps per period (tests/test_certificate_truth_goland.py; its own error
    below 1e-9 on the amplitudes at γ = 0, ~1e-7 on the damped rows, allowed 1e-6). Asserted:
    both certified, every output and the frequency within their bounds, the verdict the ODE's,
    the critical multiplier within 0.005 of it. Measured (issue 48, bench_lco --quick rows):
    10,000 ft, γ = 0: K = 11, κ = 0.066, A_Tz 2.2e-4 off against 7.9e-4, A_Tx 1.2e-4 / 2.5e-2,
    A_Ty 3.9e-4 / 4.5e-3, max_mode1 2.2e-4 / 1.2e-3, frequency 6.4e-6 / 6.1e-4, multiplier
    0.9307 against 0.9294; 4,000 ft, γ = 1e-3: K = 8, κ = 0.011, A_Tz 9.3e-7 / 1.0e-5, A_Tx
    9.4e-6 / 5.1e-4, multiplier 0.4316 against 0.4314 (the damping decomposition of the
    working tree at the time). 4.5 minutes (the model is built from nothing; passed)."""
    _, system, C, res = goland_hb_rows(tmp_path, ((10000.0, 0.0), (4000.0, 1e-3)))
    assert (res.status == "lco").all()
    X, w = res.orbits
    out = slow_certificate(system, torch.as_tensor(X), torch.as_tensor(w), C[0], C)
    assert out.certified.all()
    for i in range(2):
        sub = system.select(torch.as_tensor([i])).to(dtype=torch.float64)
        q, v, xi = orbit_state(sub, torch.as_tensor(X[i:i + 1]), torch.as_tensor(w[i:i + 1]))
        ode = StiffCaseODE(system.to(dtype=torch.float64), i)
        ref = shoot_ode_rk4(ode, np.concatenate([q[0], v[0], xi[0]]), 2 * np.pi / float(w[i]),
                            C[0], C, steps=12500)
        assert ref.correction < 1e-9
        rel = np.abs(out.amplitude[i] / ref.amplitude - 1)
        assert (rel <= out.amplitude_error[i] / out.amplitude[i] + 1e-6).all(), (i, rel)
        assert abs(out.frequency_hz[i] / ref.frequency_hz - 1) <= out.frequency_error[i] + 1e-6
        assert out.stable[i] == (ref.critical < 1.0)
        assert abs(out.critical[i] - ref.critical) < 5e-3
