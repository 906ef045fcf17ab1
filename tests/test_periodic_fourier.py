"""Fourier layout and alias-free AFT sampling (torchrom.periodic.fourier)."""

from __future__ import annotations

import math

import numpy as np
import torch

from torchrom.periodic.fourier import (
    FourierBasis,
    coefficients_from_samples,
    harmonic_magnitudes,
    resize_harmonics,
    sample_count,
)


def test_basis_round_trip_and_derivative():
    torch.manual_seed(0)
    H = 4
    b = FourierBasis.build(H, 32)
    X = torch.randn(3, 2 * H + 1, 2, dtype=torch.float64)
    samples = b.E @ X
    # the projection and the FFT both recover the coefficients exactly (to rounding)
    assert torch.allclose(b.P @ samples, X, atol=1e-13)
    assert torch.allclose(coefficients_from_samples(samples, H), X, atol=1e-13)
    # the derivative matrix on coefficients equals the derivative of the samples
    assert torch.allclose(b.dE @ X, b.E @ (b.D @ X), atol=1e-12)


def test_cubic_products_are_alias_free_at_4H_plus_1_samples():
    """The harmonics 0..H of a cubic product of H-harmonic signals are exact with N = 4H + 1
    samples (compared with a dense 64-sample evaluation, which cannot alias here), and wrong
    with one sample less — the reason for the sample count in the module docstring."""
    torch.manual_seed(1)
    H = 3
    X = torch.randn(1, 2 * H + 1, 1, dtype=torch.float64)

    def cubic_coefficients(N):
        b = FourierBasis.build(H, N)
        return coefficients_from_samples((b.E @ X) ** 3, H)

    exact = cubic_coefficients(64)
    N = sample_count(H)
    assert N == 4 * H + 1
    assert torch.allclose(cubic_coefficients(N), exact, atol=1e-12)
    assert (cubic_coefficients(N - 1) - exact).abs().max() > 1e-3


def test_resize_and_magnitudes():
    X = torch.arange(7, dtype=torch.float64).reshape(1, 7, 1)
    assert resize_harmonics(X, 1).shape == (1, 3, 1)
    padded = resize_harmonics(X, 5)
    assert padded.shape == (1, 11, 1) and padded[0, 7:].abs().max() == 0
    mags = harmonic_magnitudes(torch.tensor([2.0, 3.0, 4.0]))
    assert torch.allclose(mags, torch.tensor([2.0, 5.0])) and math.isclose(float(mags[1]), 5.0)


def test_band_limited_extreme_reads_a_sampled_orbit_exactly():
    """y(t) = cos t + 0.3 sin 2t + 0.05 cos 5t sampled at 16 and 64 points per period (the
    phase off the samples): the extremes of its trigonometric interpolant are the signal's
    own to 1.6e-12 (a grid of 2·10⁶ points, itself good to ~5e-12), where the parabola through
    the best sample is off by 7.9e-3–1.5e-2 at 16 samples and 7.2e-5–1.3e-4 at 64."""
    from torchrom.periodic.fourier import band_limited_extreme, parabolic_extreme

    def signal(t):
        return np.cos(t + 0.3) + 0.3 * np.sin(2 * t) + 0.05 * np.cos(5 * t - 1.0)

    dense = signal(np.linspace(0, 2 * np.pi, 2_000_001))
    true = {1.0: dense.max(), -1.0: dense.min()}
    for P, parabola_off in ((16, 1e-3), (64, 5e-6)):
        y = torch.as_tensor(signal(2 * np.pi * np.arange(P) / P))[None, :, None]
        for sign in (1.0, -1.0):
            _, v = band_limited_extreme(y, sign)
            assert abs(float(v) - true[sign]) < 1e-9
            _, p = parabolic_extreme(y, sign)
            assert abs(float(p) - true[sign]) > parabola_off
