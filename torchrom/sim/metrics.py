"""LCO metrics: amplitude, frequency, amplitude ratios (hand-written, numpy on the host).

Two sources, the same definitions:

- :func:`window_metrics` works on the extrema a :class:`~torchrom.sim.lco.PeakTracker` kept for a
  finished case. The *converged window* is the last ``cycles`` + 1 maxima of the first decision
  output; the frequency is 1/T with T the slope of a least-squares line through the extremum
  times against their index over that window (maxima and minima fitted separately, slopes
  averaged) — the extremum times are the zero crossings of ẏ refined by interpolation. An
  output's amplitude is half its peak-to-peak range over the *last period* of the window (the
  extrema within 1.02 T of the newest one; the largest maximum minus the smallest minimum, so
  outputs with several local extrema per period are measured correctly). Not over the whole
  window: an LCO accepted on a slow approach still changes by up to rtol per cycle, and the
  range of ``cycles`` + 1 cycles would report its oldest, farthest cycle (up to ``cycles`` ×
  rtol off the orbit where the case ended; Goland wing at 10,000 ft, γ = 1e-3, rtol 1e-3:
  +0.26 % against fixed-step Newmark at 0.25 ms, +0.13 % over the last period); the last
  period is off by at most one cycle's change.
- :func:`history_metrics` works on a sampled time history y(t): zero crossings of y − (centre of
  its range) refined by linear interpolation, then the same least-squares fit for the period; the
  amplitude is half the peak-to-peak range over the last ``cycles`` periods.
"""

from __future__ import annotations

import numpy as np

#: the amplitude window of :func:`window_metrics`, in fitted periods before the newest extremum
LAST_PERIOD = 1.02


def ordered_extrema(values: np.ndarray, times: np.ndarray, count: int, ring: int):
    """Ring buffer (ring,) → (values, times) oldest → newest, at most ``ring`` of them."""
    k = int(min(count, ring))
    if k == 0:
        return values[:0], times[:0]
    slots = (np.arange(count - k, count)) % ring
    return values[slots], times[slots]


def fitted_period(times: np.ndarray) -> float:
    """Slope of the least-squares line t_j = t_0 + T j (NaN with fewer than two times)."""
    if len(times) < 2:
        return float("nan")
    j = np.arange(len(times), dtype=float)
    jc = j - j.mean()
    return float(np.dot(jc, times - times.mean()) / np.dot(jc, jc))


def window_metrics(values: np.ndarray, times: np.ndarray, count: np.ndarray, cycles: int,
                   primary: int = 0) -> dict[str, np.ndarray | float]:
    """Metrics of one case from its extrema: values/times (O, 2, ring), count (O, 2).

    Returns amplitude (O,), centre (O,) (the middle of each band, (largest + smallest) / 2 over
    the same window), frequency_hz (of output ``primary``), amplitude_change (relative
    change of the primary amplitude over its last cycle) and window_start (s).
    """
    O, _, ring = values.shape
    seq = [[ordered_extrema(values[o, k], times[o, k], count[o, k], ring) for k in (0, 1)]
           for o in range(O)]
    (pmax, tmax), (pmin, tmin) = seq[primary]
    w = cycles + 1
    t_start = -np.inf
    if len(tmax) and len(tmin):
        t_start = min(tmax[-min(w, len(tmax))], tmin[-min(w, len(tmin))])
    periods = [fitted_period(tx[-w:]) for tx in (tmax, tmin) if len(tx) >= 2]
    period = float(np.mean(periods)) if periods else float("nan")
    frequency = 1.0 / period if period > 0 else float("nan")
    # the amplitude over the last period (module docstring); 2 % more than T so that every
    # output's largest extremum of the period is inside whatever the phase of the cut
    t_amp = t_start
    if len(tmax) and len(tmin) and period > 0:
        t_amp = max(t_start, max(tmax[-1], tmin[-1]) - LAST_PERIOD * period)
    amplitude, centre = np.zeros(O), np.full(O, np.nan)
    for o in range(O):
        (vmax, tx), (vmin, tn) = seq[o]
        sel_max = vmax[tx >= t_amp]
        sel_min = vmin[tn >= t_amp]
        if len(sel_max) and len(sel_min):
            amplitude[o] = 0.5 * (sel_max.max() - sel_min.min())
            centre[o] = 0.5 * (sel_max.max() + sel_min.min())
        elif len(vmax) and len(vmin):
            amplitude[o] = 0.5 * (vmax[-1] - vmin[-1])
            centre[o] = 0.5 * (vmax[-1] + vmin[-1])
    change = float("nan")
    n = min(len(pmax), len(pmin))
    if n >= 2:
        a0 = 0.5 * (pmax[-1] - pmin[-1])
        a1 = 0.5 * (pmax[-2] - pmin[-2])
        change = abs(a0 - a1) / abs(a0) if a0 != 0 else float("nan")
    return {"amplitude": amplitude, "centre": centre, "frequency_hz": frequency,
            "amplitude_change": change,
            "window_start": float(t_start)}


def zero_crossings(t: np.ndarray, y: np.ndarray, level: float = 0.0) -> np.ndarray:
    """Times of upward crossings of ``level`` by linear interpolation between samples."""
    s = y - level
    i = np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]
    frac = s[i] / (s[i] - s[i + 1])
    return t[i] + frac * (t[i + 1] - t[i])


def history_metrics(t: np.ndarray, y: np.ndarray, cycles: int = 5) -> dict[str, float]:
    """Amplitude (half peak-to-peak) and frequency of the last ``cycles`` periods of y(t)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    half = len(y) // 2
    centre = 0.5 * (y[half:].max() + y[half:].min())
    tc = zero_crossings(t, y, centre)
    if len(tc) < 2:
        return {"amplitude": float("nan"), "frequency_hz": float("nan")}
    tc = tc[-(cycles + 1):]
    period = fitted_period(tc)
    window = t >= tc[0]
    amplitude = 0.5 * (y[window].max() - y[window].min())
    return {"amplitude": float(amplitude), "frequency_hz": 1.0 / period}


def amplitude_ratio(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """Ratio of two amplitude arrays; NaN where the denominator is zero or missing."""
    num = np.asarray(numerator, dtype=float)
    den = np.asarray(denominator, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den != 0, num / np.where(den != 0, den, 1.0), np.nan)
