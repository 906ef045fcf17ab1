"""The Fourier certificate (torchrom.periodic.fourier_certificate): its norms against closed
forms, its bounds against a second method (harmonic balance at H = 25, converged to rounding on
this oscillator) and its contraction check on an orbit far off."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchrom.periodic import HarmonicBalanceMethod, HBOptions
from torchrom.periodic.fourier import basis_at
from torchrom.periodic.fourier_certificate import (
    fourier_bound,
    sampled_amplitude,
    state_norm,
    sup_norm_bound,
)
from torchrom.periodic.solve import orbit_amplitude
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.sim import CaseSystem

ROM = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
ROW = np.array([[1.0]])


def _orbits(H: int, alphas=(0.0, 0.1)):
    system = CaseSystem.build(ROM, len(alphas), alpha=list(alphas), gamma=1.0)
    res = HarmonicBalanceMethod(HBOptions(harmonics=H, max_harmonics=H)).run(
        system, outputs=["sum"])
    assert (res.status == "lco").all()
    X, w = res.orbits
    return system, res, torch.as_tensor(X[:, : 2 * H + 1]), torch.as_tensor(w)


def test_the_sup_norm_bound_is_exact_for_one_harmonic_and_bounds_several():
    """a cos kτ + b sin kτ peaks at sqrt(a² + b²) exactly; a sum of harmonics peaks at most at
    the sum of their magnitudes (sampled at 4,096 phases)."""
    X = torch.zeros(1, 7, 2, dtype=torch.float64)
    X[0, 3, 0], X[0, 4, 0] = 3.0, 4.0  # harmonic 2 of coordinate 0
    rows = torch.eye(2, dtype=torch.float64)
    assert torch.allclose(sup_norm_bound(X, rows), torch.tensor([[5.0, 0.0]],
                                                                 dtype=torch.float64))
    g = torch.Generator().manual_seed(0)
    X = torch.randn(1, 7, 2, dtype=torch.float64, generator=g)
    tau = torch.linspace(0, 2 * math.pi, 4097, dtype=torch.float64)[:-1]
    y = basis_at(tau, 3) @ X[0]  # (P, 2)
    assert (y.abs().amax(0) <= sup_norm_bound(X, rows)[0] + 1e-12).all()
    assert (y.norm(dim=1).amax() <= state_norm(X)[0] + 1e-12)


def test_the_sampled_amplitude_encloses_the_true_one():
    """Â ≤ A ≤ Â + ½(π/P)²Σk²|Y_k|: one harmonic (A = sqrt(a² + b²) in closed form) at a phase
    the 16 samples miss, and random three-harmonic outputs against their amplitude on 2²⁰
    phases refined by a parabola (a second method; its error ~1e-12 of the curvature bound's
    scale, far below the enclosures, ~10 % at P = 16 and ~2 % at 64)."""
    Y = torch.zeros(1, 5, 1, dtype=torch.float64)
    Y[0, 3, 0], Y[0, 4, 0] = math.cos(0.3), math.sin(0.3)  # cos(2τ − 0.3): A = 1
    amp, e = sampled_amplitude(Y, samples=16)
    assert float(amp) < 1.0 <= float(amp + e)
    assert float(e) == pytest.approx(0.5 * (math.pi / 16) ** 2 * 4)
    g = torch.Generator().manual_seed(1)
    Y = torch.randn(6, 7, 2, dtype=torch.float64, generator=g)
    for P in (16, 64):
        amp, e = sampled_amplitude(Y, samples=P)
        fine = orbit_amplitude(Y, np.array(["lco"] * 6, dtype=object), n_points=2**20)
        assert (amp.numpy() <= fine + 1e-12).all() and (fine <= (amp + e).numpy()).all()
    assert (e.numpy() < 0.05 * fine).all()  # at P = 64 the enclosure is a few per cent


def test_the_bound_covers_the_distance_to_a_converged_high_harmonic_orbit():
    """H = 3 orbits of the Van der Pol–Duffing oscillator (α = 0 and 0.1): the amplitude and
    frequency of the H = 25 orbits (a second method: the continuous orbit to rounding) lie
    within the bounds, which are tight (each measured error at least a quarter of its bound)
    and contract (κ ≤ 1/2)."""
    system, res, X, w = _orbits(3)
    _, ref, _, _ = _orbits(25)
    b = fourier_bound(system, X, w, ROW[0], ROW)
    assert b.converged.all() and (b.contraction <= 0.5).all()
    amp_err = np.abs(res.amplitude[:, 0] - ref.amplitude[:, 0])
    freq_err = np.abs(res.frequency_hz / ref.frequency_hz - 1)
    assert (amp_err > 1e-6).all()  # the truncation at H = 3 is measurable
    assert (amp_err <= b.output_error[:, 0]).all()
    assert (amp_err >= 0.25 * b.output_error[:, 0]).all()
    assert (freq_err <= b.frequency_error).all()
    # the coordinate bound is the output bound of the unit row
    assert np.allclose(b.coordinate_error[:, 0], b.output_error[:, 0])
    assert (b.tail > 0).all()
    # the amplitude bound through the corrected orbit also covers it, is never looser than
    # the sup-distance one, and tight (measured: errors 3.05e-4 and 1.97e-4 within 0.4 % of
    # it; the sup-distance bounds are 1.2x the errors)
    amp_bound = b.amplitude_error(np.abs(res.amplitude))[:, 0]
    assert (amp_err <= amp_bound).all() and (amp_bound <= b.output_error[:, 0]).all()
    assert (amp_err >= 0.9 * amp_bound).all()


def test_an_orbit_far_off_does_not_contract():
    """The H = 3 orbits scaled by 1.5: the chord steps through the Jacobian at the wrong orbit
    do not contract by half (or their bound is of the size of the error), so no bound is
    claimed below it; measured: κ = 0.24, amplitude errors 0.77 and 0.71 against amplitude
    bounds 0.82 and 0.75 (sup-distance 0.82 and 0.75)."""
    system, res, X, w = _orbits(3)
    b = fourier_bound(system, 1.5 * X, w, ROW[0], ROW)
    err = np.abs(1.5 * res.amplitude[:, 0] - res.amplitude[:, 0])
    assert (~b.converged | (b.output_error[:, 0] >= err)).all()
    assert (~b.converged | (b.amplitude_error(1.5 * np.abs(res.amplitude))[:, 0] >= err)).all()
