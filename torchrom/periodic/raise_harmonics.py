"""Harmonic-balance rows re-solved at more harmonics, for the Fourier certificate to try again.

A row the Fourier certificate (:mod:`.fourier_certificate`) refuses is often one whose
truncated orbit is too far from the continuous-time orbit (its tail above H is not small). Its
orbit, resized to H' = 2H + 1 harmonics (:func:`~.fourier.resize_harmonics`, capped), is
re-solved by Newton on the balance equations at H' (:func:`~.solve.refine_harmonics`, the
frequency free, the phase on the decision output), and its stability computed again at H'
(:func:`~.floquet.floquet`: the continuous-time monodromy of the new orbit). A re-solve is kept
only where Newton converged and the decision output's amplitude moved by at most
:data:`MAX_AMPLITUDE_CHANGE` (a larger move is another orbit, not the same one resolved).

Measured on the Goland γ = 0 rows of ``bench_lco --quick`` (LCO 1.93–1.97 Hz; lightly damped
modes near harmonics 5, 8, 32 and 59 of it): the re-solved amplitudes approach the shooting
reference (8,500 ft: 2.0e-3 at H = 9, 3.3e-4 at 19, 6.6e-5 at 29) but the Fourier
certificate's chord steps do not contract there (κ = 0.29–4.3 at H = 29, above 1/4): the raise
is off by default (:attr:`~.certify.Certificate.max_harmonics`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..sim.result import SimulationResult
from ..sim.system import CaseSystem
from .floquet import floquet
from .fourier import resize_harmonics
from .solve import HBOptions, orbit_amplitude, refine_harmonics

#: largest relative change of the decision output's amplitude of a kept re-solve (the H ≤ 9
#: Goland γ = 0 orbits were measured 0.1–4 % off the continuous-time orbit)
MAX_AMPLITUDE_CHANGE = 0.1


def raised_harmonics(H: np.ndarray, cap: int) -> np.ndarray:
    """The next number of harmonics of orbits at H: 2H + 1, at most ``cap`` (H itself where
    it is already there)."""
    return np.minimum(2 * np.asarray(H, dtype=int) + 1, max(int(cap), 0)).clip(min=H)


def raise_rows(system: CaseSystem, result: SimulationResult, idx: np.ndarray, rows: np.ndarray,
               decision: int, cap: int, options: HBOptions | None = None
               ) -> tuple[SimulationResult, np.ndarray]:
    """(result, raised): ``result`` with its harmonic-balance rows ``idx`` re-solved at
    :func:`raised_harmonics` (module docstring; amplitudes of every output row of ``rows``
    (O, n), frequency, orbit coefficients, ``harmonics``, the Floquet columns and the state at
    τ = 0 replaced), and the rows of ``idx`` whose re-solve was kept; ``options``: the
    Newton settings of the re-solve (None: harmonic balance's defaults)."""
    options = HBOptions() if options is None else options
    X, w = result.orbits
    extra = dict(result.extra)
    H = np.asarray(extra["harmonics"], dtype=int)
    target = raised_harmonics(H[idx], cap)
    up = target > H[idx]
    if not up.any():
        return result, idx[:0]
    width = max(X.shape[1], 2 * int(target.max()) + 1)
    X = np.concatenate([X, np.zeros((X.shape[0], width - X.shape[1], X.shape[2]))], axis=1)
    w = np.array(w, dtype=float, copy=True)
    amp = np.array(result.amplitude, dtype=float, copy=True)
    q = np.array(result.q, dtype=float, copy=True)
    for name in ("harmonics", "stable", "floquet_multiplier", "floquet_error"):
        extra[name] = np.array(extra[name], copy=True)
    C = torch.as_tensor(np.asarray(rows, dtype=float))
    kept = []
    for h in np.unique(target[up]):
        cases = idx[up & (target == h)]
        t = torch.as_tensor(cases)
        sub = system.select(t).to(dtype=torch.float64)
        Xh, wh, conv, _, _ = refine_harmonics(
            sub, torch.as_tensor(X[cases]), torch.as_tensor(w[cases]), C[decision], int(h),
            options, torch.arange(cases.size))
        a = orbit_amplitude(Xh @ C.T, np.full(cases.size, "lco", dtype=object))
        with np.errstate(divide="ignore", invalid="ignore"):
            change = np.abs(a[:, decision] / amp[cases, decision] - 1.0)
        ok = conv.cpu().numpy() & (change <= MAX_AMPLITUDE_CHANGE)
        if not ok.any():
            continue
        g, tg = cases[ok], torch.as_tensor(np.flatnonzero(ok))
        fl = floquet(sub.select(tg), Xh[tg], wh[tg])
        X[g] = resize_harmonics(Xh[tg], (width - 1) // 2).cpu().numpy()
        w[g] = wh[tg].cpu().numpy()
        amp[g] = a[ok]
        q[g] = (Xh[tg, 0] + Xh[tg, 1::2].sum(1)).cpu().numpy()  # the orbit at τ = 0
        extra["harmonics"][g] = h
        extra["stable"][g] = fl.stable
        extra["floquet_multiplier"][g] = fl.critical_modulus
        extra["floquet_error"][g] = fl.trivial_error
        kept.append(g)
    kept = np.sort(np.concatenate(kept)) if kept else idx[:0]
    freq = np.array(result.frequency_hz, dtype=float, copy=True)
    freq[kept] = w[kept] / (2 * np.pi)
    return dataclasses.replace(result, amplitude=amp, frequency_hz=freq, q=q, orbits=(X, w),
                               extra=extra), kept
