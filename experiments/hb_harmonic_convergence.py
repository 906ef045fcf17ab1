"""Why harmonic balance needs H ≈ 17–25 on the updated Goland wing's γ = 0 LCOs.

On the built-in model (the updated wing, 9L12D, its cache), at 7,000 and 4,000 ft with γ = 0
(matched α):

1. HB with H fixed (cold start at H, ``start_harmonics = harmonics = max_harmonics = H``) for
   H = 5, 7, 9: amplitude of point A, frequency, truncation residual, and the magnitudes of the
   harmonics of the generalized coordinate of the in-plane mode 5;
2. Newmark (the paper's setting, dt = 1 ms, and dt = 0.25 ms with six Newton iterations) from
   the H = 5 orbit for 30 s: the same quantities over its last ten periods;
3. HB at H = 15 … 25 from the Newmark run's Fourier coefficients (torchrom.periodic.seed).

Writes ``experiments/results/hb_harmonic_convergence.md`` (~3 min on one core):

    PYTHONPATH=$PWD python experiments/hb_harmonic_convergence.py

Glue over torchrom.periodic and torchrom.sim.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
import torch

from torchrom.cache_dir import cache_folder
from torchrom.paper.pipeline import goland_pipeline
from torchrom.periodic import HBOptions, solve_orbits
from torchrom.periodic.fourier import resize_harmonics
from torchrom.periodic.solve import (
    orbit_amplitude,
    orbit_state,
    refine_harmonics,
    truncation_residual,
)
from torchrom.sim import HistoryRequest, LCOCriteria, Newmark
from torchrom.sim.newmark import output_matrix
from torchrom.study.cases import case_system

MODE = 5  # the in-plane mode (1-based)


def _mags(X: torch.Tensor, j: int) -> list[float]:
    H = (X.shape[0] - 1) // 2
    return [float(torch.hypot(X[2 * k - 1, j], X[2 * k, j])) for k in range(1, H + 1)]


def _frequency(t, y, f_guess):
    """Hz from the zero up-crossings of y over its last ten periods."""
    last = t >= t[-1] - 10 / f_guess
    tl, yl = t[last], y[last] - y[last].mean()
    up = np.flatnonzero((yl[:-1] < 0) & (yl[1:] >= 0))
    tz = tl[up] - yl[up] * (tl[up + 1] - tl[up]) / (yl[up + 1] - yl[up])
    return (tz.size - 1) / (tz[-1] - tz[0])


def _coefficients(t, Q, rr, f, H):
    """Fourier coefficients (2H+1, n) over the whole periods at the end of (t, Q), phase as
    HB's (the output's first harmonic a cosine)."""
    fit = t >= t[-1] - 10 / f
    tf, Qf = t[fit], Q[fit]
    y1 = np.mean((Qf @ rr) * np.exp(-2j * np.pi * f * tf))
    tau = 2 * np.pi * f * tf + np.angle(y1)
    X = np.zeros((2 * H + 1, Q.shape[1]))
    X[0] = Qf.mean(0)
    for k in range(1, H + 1):
        X[2 * k - 1] = 2 * np.mean(Qf * np.cos(k * tau)[:, None], 0)
        X[2 * k] = 2 * np.mean(Qf * np.sin(k * tau)[:, None], 0)
    return torch.as_tensor(X)


def study(model, altitude: float) -> list[str]:
    system, _ = case_system(model, [{"altitude_ft": altitude, "alpha": "matched", "gamma": 0.0}])
    n = system.n
    _, C = output_matrix(system.rom, ["A_Tz"])
    r = torch.as_tensor(C[0])
    lines = [f"## {altitude:,.0f} ft, γ = 0", "",
             "| solution | A (ft) | f (Hz) | truncation | Newton its | mode-5 harmonics k = 1…9 |",
             "|---|---|---|---|---|---|"]

    def row(name, X, w, trunc, its):
        amp = float(orbit_amplitude(X[None] @ r[:, None], np.array(["lco"], dtype=object),
                                    512)[0, 0])
        mags = " ".join(f"{m:.3f}" for m in _mags(resize_harmonics(X[None], 9)[0], MODE - 1))
        lines.append(f"| {name} | {amp:.4f} | {w / (2 * np.pi):.4f} | {trunc} | {its} | "
                     f"{mags} |")

    start = None
    for H in (5, 7, 9):
        opts = HBOptions(start_harmonics=H, harmonics=H, max_harmonics=H)
        orb = solve_orbits(system, C[0], opts)
        if orb.status[0] != "lco":
            lines.append(f"| HB H = {H}, cold | {orb.status[0]} | | | {orb.iterations[0]} | |")
            continue
        X = resize_harmonics(orb.X, H)[0]
        row(f"HB H = {H}, cold", X, float(orb.omega[0]),
            f"{float(truncation_residual(system, X[None], orb.omega)[0]):.1e}",
            int(orb.iterations[0]))
        if H == 5:
            start = (orb.X, orb.omega)
    q0, v0, xi0 = orbit_state(system, *start)
    names = [f"q{i + 1}" for i in range(n)]
    seed = None
    for dt, its in ((1e-3, 2), (2.5e-4, 6)):
        every = max(1, round(1e-3 / dt))
        # no error flag (tol 1): a flagged case would stop; the two runs check each other
        res = Newmark(dt=dt, iterations=its, refresh_every=1, tol=1.0).run(
            system, q0, v0, xi0, t_end=30.0, outputs=(names, np.eye(n)),
            lco=LCOCriteria(stop=False), history=HistoryRequest((0,), every))
        h = res.histories[0]
        t, Q = np.asarray(h.t), np.asarray(h.y)
        f = _frequency(t, Q @ C[0], float(start[1][0]) / (2 * np.pi))
        X = _coefficients(t, Q, C[0], f, 25)
        last = t >= t[-1] - 10 / f
        y = Q[last] @ C[0]
        lines.append(f"| Newmark dt = {dt * 1e3:g} ms, {its} iterations, 30 s | "
                     f"{0.5 * (y.max() - y.min()):.4f} | {f:.4f} | – | – | "
                     + " ".join(f"{m:.3f}" for m in _mags(resize_harmonics(X[None], 9)[0],
                                                          MODE - 1)) + " |")
        if seed is None:
            seed = (X, 2 * np.pi * f)
    X0, w0 = seed
    opts = HBOptions()
    opts = dataclasses.replace(opts, newton=dataclasses.replace(opts.newton, max_iterations=40))
    for H in (9, 11, 13, 15, 17, 19, 21, 25):
        Xn, wn, conv, its, _ = refine_harmonics(
            system, resize_harmonics(X0[None], H), torch.tensor([w0], dtype=torch.float64),
            r, H, opts, torch.arange(1))
        if not bool(conv[0]):
            lines.append(f"| HB H = {H} from Newmark | not converged | | | {int(its[0])} | |")
            continue
        row(f"HB H = {H} from Newmark", Xn[0], float(wn[0]),
            f"{float(truncation_residual(system, Xn, wn)[0]):.1e}", int(its[0]))
    return lines + [""]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="experiments/results/hb_harmonic_convergence.md")
    args = ap.parse_args()
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    model = goland_pipeline(folder=cache_folder("goland"), log=lambda s: None).model
    lines = ["# Harmonic balance on the updated wing's γ = 0 LCOs: convergence in H", "",
             "Written by `experiments/hb_harmonic_convergence.py` (see its docstring). A: half "
             "peak-to-peak of point A; mode-5 harmonics: magnitudes of the in-plane mode's "
             "generalized coordinate (its 5th and 6th harmonics straddle the mode, 11.38 Hz ≈ "
             "5.8 f).", ""]
    for altitude in (7000.0, 4000.0):
        lines += study(model, altitude)
        print(f"{altitude:,.0f} ft done ({time.perf_counter() - t0:.0f} s)", flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
