"""Orbits harmonic balance cannot reach from below: seeded by a short time integration.

Raising H from a low-H orbit (:mod:`.solve`) fails where the orbit's harmonic content converges
slowly and the truncated problems have no solution near the true orbit (the Goland wing's nearly
undamped LCOs, whose 5th and 6th harmonics straddle the in-plane mode;
``experiments/hb_harmonic_convergence.py``). For the cases that end unresolved — unconverged, or
not accepted in H — the orbit is seeded instead:

1. a start: an orbit at H = 5 (along the sweep's neighbour chains), else the case's own orbit;
2. Newmark (:class:`torchrom.sim.Newmark`) from it for :data:`SEED_PERIODS` periods at
   :data:`SEED_STEPS_PER_PERIOD` steps per period, which supplies the high harmonics;
3. the frequency from the output's zero up-crossings and the Fourier coefficients of every
   coordinate over the last :data:`SEED_FIT_PERIODS` periods, in :mod:`.solve`'s phase;
4. Newton at each H of :data:`SEED_HARMONICS` in turn until the amplitude change and the
   truncation residual meet :class:`~.solve.HBOptions`' tolerances (:func:`seeded_orbits`).

Unstable orbits do not attract a time integration; a seed that runs away is reported as such
(the case keeps its previous status).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import torch

from ..sim.lco import LCOCriteria
from ..sim.newmark import HistoryRequest, Newmark
from ..sim.system import CaseSystem
from .fourier import resize_harmonics
from .solve import (
    HBOptions,
    PeriodicOrbits,
    orbit_amplitude,
    orbit_state,
    refine_harmonics,
    solve_orbits,
    truncation_residual,
)

Tensor = torch.Tensor

#: periods of the seeding time integration (from an orbit near the LCO): on the 16 seeded cases
#: of the paper's LCO sweep (``torchrom paper --method hb``) 5, 6, 10 and 20 periods gave the
#: same orbits (same H, amplitudes within 1e-11 relative), 20 periods cost 10.5 s and 6 3.2 s
SEED_PERIODS = 6
#: periods at its end whose Fourier coefficients seed the HB solve
SEED_FIT_PERIODS = 4
#: time steps per period of the fastest case: ~1 ms on Goland, where the paper setting's two
#: Newton iterations per step converge (at 2 ms the stiff dual coordinates made Newmark run
#: away from some starts); the seed only has to lie in the basin of the HB solution
SEED_STEPS_PER_PERIOD = 512
#: the harmonic ladder of a seeded orbit (each H from the previous converged one)
SEED_HARMONICS = (15, 17, 19, 21, 23, 25)
#: Newton iterations at each H of the ladder: from a seed in the basin Newton converges in 3–9
#: (the paper's LCO sweep); a case that has not converged by then does not converge at that H
#: (none did between 10 and the default 25 iterations there) and goes on to the next H, while
#: its batch waited for its 25 iterations before
SEED_NEWTON_ITERATIONS = 12
#: H of the cold start that provides a seed for a case without an orbit
SEED_START_HARMONICS = 5


@dataclass
class SeededOrbits(PeriodicOrbits):
    """:class:`~.solve.PeriodicOrbits` of the seeded cases (status 'lco' where Newton converged
    at some H of the ladder, the amplitude change between the last two converged H; no
    critical root), and whether each was accepted (both tolerances met)."""

    accepted: np.ndarray | None = None


def unresolved(status: np.ndarray, amplitude_change: np.ndarray, truncation: np.ndarray,
               options: HBOptions) -> np.ndarray:
    """Cases harmonic balance left unresolved: unconverged, or an LCO whose amplitude change
    from H − 2 or truncation residual misses the tolerances (or was never measured)."""
    return (status == "unconverged") | ((status == "lco")
                                        & ~_accepted(amplitude_change, truncation, options))


def _accepted(amplitude_change: np.ndarray, truncation: np.ndarray, options: HBOptions
              ) -> np.ndarray:
    """Both tolerances of the adaptive-H test met (NaN: not measured, not accepted)."""
    with np.errstate(invalid="ignore"):
        return (amplitude_change <= options.amplitude_rtol) & (
            truncation <= options.residual_tol)


def _time_seed(system: CaseSystem, X: Tensor, omega: Tensor, r: Tensor, H: int
               ) -> tuple[Tensor, Tensor, np.ndarray]:
    """(X_seed (k, 2H+1, n), ω (k,), ok (k,)) from Newmark started on the orbits X, ω."""
    k, n = X.shape[0], system.n
    q0, v0, xi0 = orbit_state(system, X, omega)
    w = omega.cpu().numpy()
    dt = 2 * math.pi / float(w.max()) / SEED_STEPS_PER_PERIOD
    t_end = SEED_PERIODS * 2 * math.pi / float(w.min())
    names = [f"q{i + 1}" for i in range(n)]
    # the paper's iteration (two Newton iterations, refreshed every step); no error flag
    # (tol 1): a flagged case would stop, and Newton polishes the seed anyway
    res = Newmark(dt=dt, iterations=2, refresh_every=1, tol=1.0).run(
        system, q0, v0, xi0, t_end=t_end, outputs=(names, np.eye(n)),
        lco=LCOCriteria(stop=False, cycles=SEED_FIT_PERIODS),
        history=HistoryRequest(tuple(range(k)), 1))
    Xs = X.new_zeros(k, 2 * H + 1, n)
    ws = omega.clone()
    ok = np.zeros(k, dtype=bool)
    rr = r.cpu().numpy()
    for i in range(k):
        hist = res.histories.get(i)
        if hist is None or not np.isfinite(hist.y).all():
            continue
        t, Q = np.asarray(hist.t), np.asarray(hist.y)
        if t[-1] < 0.9 * t_end:  # stopped early (diverged or flagged): no seed
            continue
        y = Q @ rr
        T = 2 * math.pi / w[i]
        last = t >= t[-1] - (SEED_FIT_PERIODS + 1) * T
        yc = y[last] - y[last].mean()
        tl = t[last]
        up = np.flatnonzero((yc[:-1] < 0) & (yc[1:] >= 0))
        if up.size < SEED_FIT_PERIODS + 1:
            continue
        tz = tl[up] - yc[up] * (tl[up + 1] - tl[up]) / (yc[up + 1] - yc[up])
        f = (up.size - 1) / (tz[-1] - tz[0])  # Hz, over whole periods
        fit = (t >= tz[-1] - SEED_FIT_PERIODS / f) & (t <= tz[-1])
        tf, Qf = t[fit], Q[fit]
        # trapezoidal weights: the window spans whole periods, so the rule is spectrally exact
        wts = np.gradient(tf)
        wts /= wts.sum()
        # phase: the output's first harmonic a pure cosine (no sin τ term, as in .solve)
        y1 = np.sum(wts * (Qf @ rr) * np.exp(-2j * math.pi * f * tf))
        tau = 2 * math.pi * f * tf + np.angle(y1)
        coef = np.zeros((2 * H + 1, n))
        coef[0] = wts @ Qf
        for h in range(1, H + 1):
            coef[2 * h - 1] = 2 * (wts * np.cos(h * tau)) @ Qf
            coef[2 * h] = 2 * (wts * np.sin(h * tau)) @ Qf
        Xs[i] = torch.as_tensor(coef, dtype=X.dtype, device=X.device)
        ws[i] = 2 * math.pi * f
        ok[i] = True
    return Xs, ws, ok


def seeded_orbits(system: CaseSystem, r: Tensor, X: Tensor | None, omega: Tensor | None,
                  has_orbit: np.ndarray, options: HBOptions,
                  chains: list[list[int]] | None = None, positions=None) -> SeededOrbits:
    """Seed and solve the orbits of every case of ``system`` (module docstring): each starts
    from an orbit at H = :data:`SEED_START_HARMONICS` (along ``chains``/``positions`` as
    :func:`~.solve.solve_orbits`, else cold), or where that fails from its own orbit ``X``,
    ``ω`` (any H; used where ``has_orbit``)."""
    k, n = system.batch_size, system.n
    Hmax = SEED_HARMONICS[-1]
    out = SeededOrbits(
        X=r.new_zeros(k, 2 * Hmax + 1, n), omega=r.new_full((k,), math.nan),
        harmonics=np.zeros(k, dtype=int), status=np.full(k, "unconverged", dtype=object),
        residual=np.full(k, math.nan), truncation=np.full(k, math.nan),
        amplitude_change=np.full(k, math.nan), iterations=np.zeros(k, dtype=int),
        critical_root=np.full(k, complex(math.nan, math.nan)),
        accepted=np.zeros(k, dtype=bool))
    X0 = r.new_zeros(k, 2 * SEED_START_HARMONICS + 1, n)
    w0 = r.new_full((k,), math.nan)
    # every case from an orbit at H = 5 (close to the orbit on Goland: 0.3-0.7 %), which
    # the Newmark run then brings into the basin of the high-H solution; the case's own orbit
    # only where that start fails (an orbit not accepted in H may be a spurious one of the
    # truncated problem, percents away)
    opts = dataclasses.replace(options, start_harmonics=SEED_START_HARMONICS,
                               harmonics=SEED_START_HARMONICS,
                               max_harmonics=SEED_START_HARMONICS)
    orb = solve_orbits(system, r, opts, chains=chains, positions=positions)
    got = orb.status == "lco"
    out.iterations += orb.iterations
    g = torch.as_tensor(got)
    X0[g] = resize_harmonics(orb.X, SEED_START_HARMONICS)[g]
    w0[g] = orb.omega[g]
    start = got.copy()
    own = np.flatnonzero(~got & np.asarray(has_orbit, dtype=bool))
    if own.size:
        o = torch.as_tensor(own)
        X0[o] = resize_harmonics(X[o], SEED_START_HARMONICS)
        w0[o] = omega[o]
        start[own] = True
    idx = np.flatnonzero(start)
    if idx.size == 0:
        return out
    t = torch.as_tensor(idx)
    sub = system.select(t)
    Xs, ws, ok = _time_seed(sub, X0[t], w0[t], r, Hmax)
    idx, Xs, ws = idx[ok], Xs[torch.as_tensor(ok)], ws[torch.as_tensor(ok)]
    if idx.size == 0:
        return out
    sub = system.select(torch.as_tensor(idx))
    m = idx.size
    rows = r[None, :]
    # the last converged orbit of each case, its seed until one has converged
    X_cur, w_cur = Xs.clone(), ws.clone()
    have = np.zeros(m, dtype=bool)  # converged at some H of the ladder
    prev_amp = np.full(m, math.nan)
    todo = np.arange(m)
    ladder = dataclasses.replace(options, newton=dataclasses.replace(
        options.newton, max_iterations=min(options.newton.max_iterations,
                                           SEED_NEWTON_ITERATIONS)))
    for H in SEED_HARMONICS:
        act = torch.as_tensor(todo)
        Xn, wn, conv, its, res = refine_harmonics(sub, X_cur, w_cur, r, H, ladder, act)
        out.iterations[idx[todo]] += its[act].cpu().numpy()
        conv_t = conv[act].cpu().numpy()
        done = todo[conv_t]
        if done.size:
            d = torch.as_tensor(done)
            X_cur[d] = resize_harmonics(Xn[d], Hmax)
            w_cur[d] = wn[d]
            amp = orbit_amplitude(resize_harmonics(Xn[d], H) @ rows.T,
                                  np.full(done.size, "lco", dtype=object),
                                  options.metric_points)[:, 0]
            trunc = truncation_residual(sub.select(d), Xn[d], wn[d]).cpu().numpy()
            change = np.abs(amp - prev_amp[done]) / np.maximum(np.abs(amp), 1e-300)
            prev_amp[done] = amp
            have[done] = True
            g = idx[done]
            out.harmonics[g] = H
            out.status[g] = "lco"
            out.residual[g] = res[d].cpu().numpy()
            out.truncation[g] = trunc
            out.amplitude_change[g] = change
            acc = _accepted(change, trunc, options)
            out.accepted[g] = acc
            todo = np.setdiff1d(todo, done[acc])
        if todo.size == 0:
            break
    out.X[torch.as_tensor(idx)] = X_cur
    out.omega[torch.as_tensor(idx)] = torch.where(torch.as_tensor(have), w_cur,
                                                  torch.full_like(w_cur, math.nan))
    return out


def _sub_chains(cases: np.ndarray, chains: list[list[int]] | None, positions
                ) -> tuple[list[list[int]] | None, np.ndarray | None]:
    """``chains`` and ``positions`` of the whole batch restricted to ``cases`` (indices into it),
    renumbered as positions in ``cases``; (None, None) without chains."""
    if chains is None:
        return None, None
    where = {int(c): j for j, c in enumerate(cases)}
    sub = [[where[i] for i in chain if i in where] for chain in chains]
    pos = None if positions is None else np.asarray(positions, dtype=float)[cases]
    return [c for c in sub if c], pos


#: which cases :func:`seed_unresolved` seeds: "unconverged" (the cases harmonic balance did
#: not converge at all: cheap, a sweep's failures only), "unresolved" (also the LCOs not
#: accepted in H: the amplitude change from H − 2 or the truncation residual above the
#: tolerances — more cases, each seed costs a few periods of time integration), "off"
SEED_MODES = ("unconverged", "unresolved", "off")


def seed_unresolved(system: CaseSystem, r: Tensor, orb: PeriodicOrbits, options: HBOptions,
                    which: str = "unresolved", chains: list[list[int]] | None = None,
                    positions=None) -> tuple[PeriodicOrbits, np.ndarray]:
    """``orb`` with its cases of kind ``which`` (:data:`SEED_MODES`) re-solved by
    :func:`seeded_orbits` where that converges (kept as they were elsewhere), and which cases
    now hold a seeded orbit. Only with adaptive H (``max_harmonics > harmonics``): an H fixed
    by the user is kept."""
    seeded = np.zeros(len(orb.status), dtype=bool)
    if which == "off" or options.max_harmonics <= options.harmonics:
        return orb, seeded
    if which == "unconverged":
        bad = np.flatnonzero(orb.status == "unconverged")
    else:
        bad = np.flatnonzero(unresolved(orb.status, orb.amplitude_change, orb.truncation,
                                        options))
    if bad.size == 0:
        return orb, seeded
    t = torch.as_tensor(bad)
    sub_chains, sub_pos = _sub_chains(bad, chains, positions)
    s = seeded_orbits(system.select(t), r, orb.X[t], orb.omega[t], orb.status[bad] == "lco",
                      options, sub_chains, sub_pos)
    orb.iterations[bad] += s.iterations
    # a seeded orbit replaces the case's own where it converged and is accepted, or where the
    # case had none (then it is the best there is; its amplitude change says how good)
    take = (s.status == "lco") & (s.accepted | (orb.status[bad] != "lco"))
    seeded[bad[take]] = True
    return merge_seeded(orb, bad, s, take), seeded


def merge_seeded(orb: PeriodicOrbits, cases: np.ndarray, s: SeededOrbits, take: np.ndarray
                 ) -> PeriodicOrbits:
    """``orb`` with the seeded orbits ``s`` of its ``cases`` (indices into it, one per row of
    ``s``) taken where ``take``: coefficients (at the larger H of the two), frequency, H,
    status, residual, truncation and amplitude change."""
    if not take.any():
        return orb
    g = torch.as_tensor(cases[take])
    H = (max(orb.X.shape[1], s.X.shape[1]) - 1) // 2
    X = resize_harmonics(orb.X, H)
    X[g] = resize_harmonics(s.X[torch.as_tensor(take)], H)
    omega = orb.omega.clone()
    omega[g] = s.omega[torch.as_tensor(take)]
    orb = dataclasses.replace(orb, X=X, omega=omega)
    for name in ("harmonics", "status", "residual", "truncation", "amplitude_change"):
        getattr(orb, name)[cases[take]] = getattr(s, name)[take]
    return orb
