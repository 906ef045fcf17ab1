"""LCO metrics on signals with known amplitude and frequency."""

import math

import numpy as np
import torch

from torchrom.sim.lco import PeakTracker
from torchrom.sim.metrics import (
    amplitude_ratio,
    fitted_period,
    history_metrics,
    window_metrics,
    zero_crossings,
)


def test_history_metrics_of_an_offset_sine():
    """Zero crossings of y − centre, refined by linear interpolation, then a least-squares
    period: 1.37 Hz to 1e-6 at 200 samples per period (interpolation error O((ω dt)²) on each
    crossing time, mostly cancelling in the fit); amplitude to the sampling error (ω dt)²/8."""
    f, amp = 1.37, 0.8
    t = np.arange(0, 20, 1 / (200 * f))
    y = 0.3 + amp * np.sin(2 * math.pi * f * t + 0.4)
    m = history_metrics(t, y, cycles=8)
    assert abs(m["frequency_hz"] / f - 1) < 1e-6
    assert abs(m["amplitude"] / amp - 1) < (2 * math.pi / 200) ** 2 / 8 * 1.01


def test_zero_crossings_and_period_fit():
    t = np.linspace(0, 10, 10001)
    tc = zero_crossings(t, np.sin(2 * math.pi * t - 0.1))
    assert len(tc) == 10
    assert np.allclose(tc, (np.arange(10) + 0.1 / (2 * math.pi)), atol=1e-6)
    assert fitted_period(np.array([1.0, 3.0, 5.0, 7.0])) == 2.0
    assert math.isnan(fitted_period(np.array([1.0])))


def test_window_metrics_with_several_extrema_per_period():
    """y2 = cos ωt + 0.6 cos 3ωt has extra local extrema: its amplitude over the window is half
    its global peak-to-peak range, 1.6, not the span between neighbouring local extrema."""
    w, dt, T = 2 * math.pi, 1e-3, 12.0
    t = np.arange(0, T + dt / 2, dt)
    y = np.stack([np.cos(w * t), np.cos(w * t) + 0.6 * np.cos(3 * w * t), 0 * t], axis=1)
    yd = np.stack([-w * np.sin(w * t), -w * np.sin(w * t) - 1.8 * w * np.sin(3 * w * t), 0 * t],
                  axis=1)
    tr = PeakTracker(torch.tensor(y[:1]), torch.tensor(yd[:1]), ring=16)
    tr.update(torch.tensor(y[1:, None, :]), torch.tensor(yd[1:, None, :]), 0, dt)
    m = window_metrics(tr.values[0].numpy(), tr.times[0].numpy(), tr.count[0].numpy(), cycles=4)
    assert abs(m["amplitude"][0] - 1.0) < 1e-9
    assert abs(m["amplitude"][1] - 1.6) < 1e-9
    assert m["amplitude"][2] == 0.0  # an output that never moves
    assert abs(m["frequency_hz"] - 1.0) < 1e-8
    assert m["amplitude_change"] < 1e-9


def test_amplitude_ratio_handles_zero():
    r = amplitude_ratio([2.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    assert r[0] == 2.0 and np.isnan(r[1]) and np.isnan(r[2])


def test_window_metrics_amplitude_is_the_last_period_of_a_slow_approach():
    """A sine whose amplitude falls by ~0.03 % per cycle (an LCO accepted at rtol 1e-3 on a slow
    approach from above): the amplitude is that of the last period, within one cycle's change of
    the envelope at the newest extremum, not the window's oldest cycle (~4 cycles' change
    above, what half the range of the whole window gives)."""
    f, dt, T = 2.0, 1e-4, 10.0
    lam = 1.6e-3  # envelope 1 + 0.5 e^(−λt) (1/s)
    t = np.arange(0, T + dt / 2, dt)
    env = 1.0 + 0.5 * np.exp(-lam * t)
    denv = -0.5 * lam * np.exp(-lam * t)
    w = 2 * math.pi * f
    y = (env * np.sin(w * t))[:, None]
    yd = (denv * np.sin(w * t) + env * w * np.cos(w * t))[:, None]
    tr = PeakTracker(torch.tensor(y[:1]), torch.tensor(yd[:1]), ring=16)
    tr.update(torch.tensor(y[1:, None, :]), torch.tensor(yd[1:, None, :]), 0, dt)
    m = window_metrics(tr.values[0].numpy(), tr.times[0].numpy(), tr.count[0].numpy(), cycles=4)
    newest = tr.times[0, 0].max().item()
    a_end = 1.0 + 0.5 * math.exp(-lam * newest)
    per_cycle = 0.5 * math.exp(-lam * newest) * (math.exp(lam / f) - 1)  # over one cycle
    assert abs(m["amplitude"][0] - a_end) <= per_cycle


def test_window_metrics_centre_is_the_middle_of_the_band():
    """y = 0.3 + cos ωt + 0.2 cos 2ωt runs from −0.5 (ωt = π) to 1.5 (ωt = 0): the centre is
    the middle of that band, 0.5 (to rounding: the extrema fall on samples), not the time
    average 0.3 — the marching's mean of an orbit (study TimeMarching) is this centre."""
    w, dt, T = 2 * math.pi, 1e-3, 8.0
    t = np.arange(0, T + dt / 2, dt)
    y = (0.3 + np.cos(w * t) + 0.2 * np.cos(2 * w * t))[:, None]
    yd = (-w * np.sin(w * t) - 0.4 * w * np.sin(2 * w * t))[:, None]
    tr = PeakTracker(torch.tensor(y[:1]), torch.tensor(yd[:1]), ring=16)
    tr.update(torch.tensor(y[1:, None, :]), torch.tensor(yd[1:, None, :]), 0, dt)
    m = window_metrics(tr.values[0].numpy(), tr.times[0].numpy(), tr.count[0].numpy(), cycles=4)
    assert abs(m["centre"][0] - 0.5) < 1e-9 and abs(m["amplitude"][0] - 1.0) < 1e-9
