"""Branches of periodic orbits: pseudo-arclength continuation in a case parameter, started at
the Hopf (flutter) point, with folds and branch points detected (batched over branches).

For B branches (e.g. one per γ), each a case whose parameter p varies (altitude, γ, α, …):

1. **Hopf point.** The real part σ(p) of the critical root of the linearised case
   (:func:`~.solve.critical_modes`) is scanned over [lo, hi] and its sign change refined by
   the Illinois (modified regula falsi) method: p*, ω*, and the flutter mode φ.
2. **First points.** The orbit family leaves the Hopf point with amplitude ∝ √|p − p*|, so the
   first two points fix the output amplitude (A1, 2A1) and solve for (X, ω, p), starting from
   the flutter mode: no guess of the side the branch leaves to (super- or subcritical).
3. **Pseudo-arclength.** In scaled variables z = (X / X_s, ω / ω*, (p − p*) / p_s) (X_s: the
   coefficients' norm per ``amplitude_scale`` of the output amplitude; p_s = hi − lo) the
   predictor steps along the secant of the last two points by ds, and Newton solves the HB
   equations (:mod:`.balance`) with the condition t·(z − z_pred) = 0; ∂R/∂p is a forward
   difference of the residual (the parameter enters through the atmosphere, the matched α, …).
   The step grows ×1.5 after an easy correction (≤ 4 iterations), halves after a failure.
4. **Events.** A fold (limit point) is where dp/ds changes sign along the branch; a branch
   point where the sign of the determinant of the augmented Jacobian changes without a fold.
   Both are flagged on the point after the event (and the fold interpolated in the table).
5. **Stop** when p leaves [lo, hi], the amplitude exceeds ``max_amplitude``, after
   ``max_points`` points, or when the step falls below ``min_step``.

Stability of every point follows from :mod:`.floquet`. Written here (the continuation
algorithm is the standard one of AUTO/MATCONT/COCO/NLvib; no library does it batched in torch).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import InputError
from ..sim.system import CaseSystem
from .balance import HarmonicBalance
from .floquet import floquet
from .fourier import n_coefficients
from .newton import NewtonOptions, newton
from .solve import (
    amplitude_condition,
    amplitude_powers,
    critical_modes,
    dual_coordinates,
    orbit_from_mode,
)

Tensor = torch.Tensor

#: builder(p (k,), branches (k,)) -> CaseSystem of the k cases (branch b at parameter p)
Builder = Callable[[np.ndarray, np.ndarray], CaseSystem]


@dataclass(frozen=True)
class BranchOptions:
    """Continuation settings (module docstring).

    Attributes:
        bounds: (lo, hi) of the parameter.
        harmonics: H along the branch.
        amplitude_scale: output amplitude scale A_s of the arclength (output units).
        first_amplitude: A1 of the first point (default 1e-2 A_s).
        step, min_step, max_step: arclength steps in the scaled variables.
        max_points: points per branch (beyond the Hopf point).
        max_amplitude: stop beyond this output amplitude.
        scan: points of the Hopf scan over [lo, hi].
        stability: compute Floquet multipliers of every point.
        newton: Newton settings of the corrector.
    """

    bounds: tuple[float, float]
    harmonics: int = 5
    amplitude_scale: float = 1.0
    first_amplitude: float | None = None
    step: float = 0.1
    min_step: float = 1e-3
    max_step: float = 0.25
    max_points: int = 60
    max_amplitude: float = math.inf
    scan: int = 17
    stability: bool = True
    newton: NewtonOptions = field(default_factory=lambda: NewtonOptions(max_iterations=12))

    def __post_init__(self):
        lo, hi = self.bounds
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InputError(f"branch bounds: expected finite LO < HI, got {self.bounds}")
        for name in ("amplitude_scale", "step", "min_step", "max_step"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v > 0 and math.isfinite(v)):
                raise InputError(f"branch {name}: expected a positive number, got {v!r}")
        if not self.min_step <= self.step <= self.max_step:
            raise InputError("branch: expected min_step <= step <= max_step")
        if int(self.max_points) < 2 or int(self.scan) < 2 or int(self.harmonics) < 1:
            raise InputError("branch: max_points and scan must be >= 2, harmonics >= 1")


@dataclass
class BranchPoint:
    """One computed point of one branch."""

    branch: int
    index: int
    parameter: float
    X: Tensor  # (2H+1, n)
    omega: float
    iterations: int
    residual: float
    kind: str = "regular"  # hopf | regular | fold | branch_point | end
    #: for a fold: the refined limit point (parameter, output amplitude r·a_1, its orbit
    #: (2H+1, n), ω), else None
    fold: tuple[float, float, Tensor, float] | None = None


@dataclass
class Branches:
    """The points of B branches (lists per branch), with their Floquet results."""

    points: list[list[BranchPoint]]
    hopf: list[dict]
    stable: list[np.ndarray] = field(default_factory=list)
    critical_multiplier: list[np.ndarray] = field(default_factory=list)
    #: |μ_trivial − 1| of each point's monodromy (its accuracy; what the Fourier certificate
    #: compares the stability margin with)
    floquet_error: list[np.ndarray] = field(default_factory=list)


class _ParameterEquations:
    """evaluate(X, ω, p, active) for :func:`~.newton.newton` with the case parameter as μ.

    A Newton iterate may carry p far outside the continuation's bounds (a corrector that
    diverges), where the cases may not even exist (an altitude below the atmosphere's range):
    beyond ``domain`` the equations are evaluated at the nearest allowed p and returned as
    NaN, which fails that case's corrector (its step is then halved) instead of the run."""

    def __init__(self, builder: Builder, H: int, p_scale: float,
                 domain: tuple[float, float] = (-math.inf, math.inf)):
        self.builder, self.H = builder, H
        self.dp = 1e-7 * p_scale
        self.domain = domain

    def _hb(self, p: Tensor, active: Tensor) -> tuple[HarmonicBalance, Tensor]:
        lo, hi = self.domain
        outside = (p < lo) | (p > hi)
        pc = p.clamp(lo, hi)
        return HarmonicBalance(self.builder(pc.cpu().numpy(), active.cpu().numpy()),
                               self.H), outside

    @staticmethod
    def _nan(T: Tensor, outside: Tensor) -> Tensor:
        if not bool(outside.any()):
            return T
        return torch.where(outside.view(-1, *([1] * (T.dim() - 1))),
                           torch.full_like(T, math.nan), T)

    def __call__(self, X, omega, p, active):
        hb, outside = self._hb(p, active)
        R, J, R_w, _ = hb.jacobian(X, omega)
        R2 = self._hb(p + self.dp, active)[0].residual(X, omega)
        return (self._nan(R, outside), self._nan(J, outside), self._nan(R_w, outside),
                self._nan((R2 - R) / self.dp, outside))

    def residual(self, X, omega, p, active):
        hb, outside = self._hb(p, active)
        return self._nan(hb.residual(X, omega), outside)


def hopf_points(builder: Builder, B: int, bounds: tuple[float, float], scan: int = 17,
                iterations: int = 40) -> dict:
    """Per branch: the parameter p* in ``bounds`` where the critical root's real part changes
    sign (the first change from ``lo``), ω* there, and whether σ > 0 below p* (``unstable_
    below``). NaN where σ keeps its sign over the bounds."""
    lo, hi = bounds
    grid = np.linspace(lo, hi, scan)
    idx = np.repeat(np.arange(B), scan)
    lam, _ = critical_modes(builder(np.tile(grid, B), idx))
    sig = lam.real.cpu().numpy().reshape(B, scan)
    p_star = np.full(B, math.nan)
    below = np.zeros(B, dtype=bool)
    a, b = np.full(B, math.nan), np.full(B, math.nan)
    fa, fb = np.full(B, math.nan), np.full(B, math.nan)
    for i in range(B):
        change = np.flatnonzero(np.sign(sig[i, :-1]) * np.sign(sig[i, 1:]) < 0)
        if change.size:
            j = change[0]
            a[i], b[i], fa[i], fb[i] = grid[j], grid[j + 1], sig[i, j], sig[i, j + 1]
            below[i] = sig[i, j] > 0
    todo = np.flatnonzero(np.isfinite(a))
    side = np.zeros(B)
    best = 0.5 * (a + b)
    for _ in range(iterations):
        if todo.size == 0:
            break
        c = (a[todo] * fb[todo] - b[todo] * fa[todo]) / (fb[todo] - fa[todo])
        lam_c, _ = critical_modes(builder(c, todo))
        fc = lam_c.real.cpu().numpy()
        best[todo] = c
        small = np.abs(fc) <= 1e-13 * np.maximum(np.abs(lam_c.imag.cpu().numpy()), 1.0)
        left = np.sign(fc) == np.sign(fa[todo])
        for k, i in enumerate(todo):  # Illinois: halve the stale end's value
            if left[k]:
                a[i], fa[i] = c[k], fc[k]
                if side[i] == -1:
                    fb[i] *= 0.5
                side[i] = -1
            else:
                b[i], fb[i] = c[k], fc[k]
                if side[i] == 1:
                    fa[i] *= 0.5
                side[i] = 1
        todo = todo[(np.abs(b[todo] - a[todo]) > 1e-12 * max(abs(hi - lo), 1.0)) & ~small]
    ok = np.isfinite(a)
    p_star[ok] = best[ok]
    omega = np.full(B, math.nan)
    phi = None
    if ok.any():
        lam_s, phi_s = critical_modes(builder(p_star[ok], np.flatnonzero(ok)))
        omega[ok] = lam_s.imag.cpu().numpy()
        phi = phi_s
    return {"parameter": p_star, "omega": omega, "unstable_below": below, "mode": phi,
            "found": ok}


def follow_branches(builder: Builder, B: int, output_row, options: BranchOptions) -> Branches:
    """The branches of periodic orbits of B cases from their Hopf points (module docstring)."""
    lo, hi = options.bounds
    p_scale = hi - lo
    H = int(options.harmonics)
    hop = hopf_points(builder, B, options.bounds, int(options.scan))
    branches = [[] for _ in range(B)]
    hopf_rows = [{"branch": b, "parameter": float(hop["parameter"][b]),
                  "frequency_hz": float(hop["omega"][b] / (2 * math.pi)),
                  "unstable_below": bool(hop["unstable_below"][b]), "found": bool(hop["found"][b])}
                 for b in range(B)]
    live = np.flatnonzero(hop["found"])
    if live.size == 0:
        return Branches(branches, hopf_rows)
    sys0 = builder(hop["parameter"][live], live)
    dev, dt = sys0.device, sys0.dtype
    n = sys0.n
    nh = n_coefficients(H)
    r = torch.as_tensor(np.asarray(output_row, dtype=float), dtype=dt, device=dev)
    slaved = dual_coordinates(sys0)
    power = amplitude_powers(sys0).to(dt)
    Bl = live.size
    # all per-branch state is indexed 0..Bl-1 (branch live[k]); the builder gets branch ids

    def build(p, act):  # active positions -> branch ids
        return builder(np.asarray(p), live[np.asarray(act)])

    # the correctors may not leave the bounds by more than their width
    eq = _ParameterEquations(build, H, p_scale, (lo - (hi - lo), hi + (hi - lo)))
    A1 = float(options.first_amplitude or 1e-2 * options.amplitude_scale)
    amps = torch.tensor([A1, 2 * A1], dtype=dt, device=dev)
    phi = hop["mode"].to(dev)
    X = orbit_from_mode(phi, r, torch.full((Bl,), A1, dtype=dt, device=dev), nh).to(dt)
    omega = torch.as_tensor(hop["omega"][live], dtype=dt, device=dev)
    p = torch.as_tensor(hop["parameter"][live], dtype=dt, device=dev)
    for b in range(Bl):
        branches[live[b]].append(BranchPoint(int(live[b]), 0, float(p[b]), torch.zeros(
            nh, n, dtype=dt), float(omega[b]), 0, 0.0, "hopf"))
    history: list[tuple[Tensor, Tensor, Tensor]] = []
    alive = torch.ones(Bl, dtype=torch.bool, device=dev)
    act_all = torch.arange(Bl, device=dev)
    for k, A in enumerate(amps):
        if k:
            X = X * (A / amps[k - 1]) ** power
        Aa = torch.full((Bl,), float(A), dtype=dt, device=dev)
        w, d = amplitude_condition(r, nh, Aa)
        res = newton(eq, X, omega, p, r, w, d, Aa, options.newton, act_all[alive],
                     residual_fn=eq.residual, slaved=slaved)
        alive &= res.converged
        X, omega, p = res.X, res.omega, res.mu
        history.append((X.clone(), omega.clone(), p.clone()))
        for b in np.flatnonzero(alive.cpu().numpy()):
            branches[live[b]].append(BranchPoint(int(live[b]), k + 1, float(p[b]), X[b].clone(),
                                                 float(omega[b]), int(res.iterations[b]),
                                                 float(res.residual[b])))
    # the arclength's coefficient unit: what one amplitude_scale of the output amounts to in
    # the coefficients (their norm per unit of output amplitude, from the second point)
    X1 = history[1][0]
    scale_X = (options.amplitude_scale * X1.reshape(Bl, -1).norm(dim=1)
               / (X1[:, 1] @ r).abs().clamp_min(1e-300))[:, None]
    omega_s = torch.as_tensor(hop["omega"][live], dtype=dt, device=dev)

    def scaled(Xc, wc, pc):
        return torch.cat([Xc.reshape(Xc.shape[0], -1) / scale_X, (wc / omega_s)[:, None],
                          (pc / p_scale)[:, None]], dim=1)

    ds = torch.full((Bl,), options.step, dtype=dt, device=dev)
    (X0, w0, p0), (X1, w1, p1) = history
    z_prev, z_cur = scaled(X0, w0, p0), scaled(X1, w1, p1)
    cur = (X1.clone(), w1.clone(), p1.clone())
    det_prev = torch.zeros(Bl, dtype=dt, device=dev)
    dp_prev = (p1 - p0)
    count = torch.full((Bl,), 3, dtype=torch.long, device=dev)
    for _ in range(int(options.max_points) * 3):
        if not bool(alive.any()):
            break
        act = act_all[alive]
        t = z_cur - z_prev
        t = t / t.norm(dim=1, keepdim=True).clamp_min(1e-300)
        z_pred = z_cur + ds[:, None] * t
        Xp = (z_pred[:, : nh * n] * scale_X).view(Bl, nh, n)
        wp = z_pred[:, -2] * omega_s
        pp = z_pred[:, -1] * p_scale
        # the condition t·(z − z_pred) = 0 in unscaled unknowns [X, ω, p]
        wrow = torch.cat([t[:, : nh * n] / scale_X, (t[:, -2] / omega_s)[:, None],
                          (t[:, -1] / p_scale)[:, None]], dim=1)
        zp_unscaled = torch.cat([Xp.reshape(Bl, -1), wp[:, None], pp[:, None]], dim=1)
        dcond = (wrow * zp_unscaled).sum(1)
        res = newton(eq, Xp, wp, pp, r, wrow, dcond, Xp.abs().amax(dim=(1, 2)),
                     options.newton, act, residual_fn=eq.residual, slaved=slaved)
        conv = res.converged & alive
        amp = (res.X[:, 1] @ r).abs()
        easy = conv & (res.iterations <= 4)
        hard = conv & (res.iterations > 8)
        failed = alive & ~conv
        ds = torch.where(easy, torch.clamp(ds * 1.5, max=options.max_step), ds)
        ds = torch.where(hard | failed, ds * 0.5, ds)
        inside = (res.mu >= lo) & (res.mu <= hi)
        crossed = conv & ~inside
        if bool(crossed.any()):  # end exactly on the bound the branch crossed
            bound = torch.where(res.mu < lo, torch.full_like(res.mu, lo),
                                torch.full_like(res.mu, hi))
            f = ((bound - cur[2]) / (res.mu - cur[2])).clamp(0.0, 1.0)
            Xb = cur[0] + f[:, None, None] * (res.X - cur[0])
            wb = cur[1] + f * (res.omega - cur[1])
            w_fix = torch.zeros_like(wrow)
            w_fix[:, -1] = 1.0
            at = newton(eq, Xb, wb, bound, r, w_fix, bound, Xb.abs().amax(dim=(1, 2)),
                        options.newton, act_all[crossed], residual_fn=eq.residual,
                        slaved=slaved)
            ok = crossed & at.converged
            res.X[ok], res.omega[ok], res.mu[ok] = at.X[ok], at.omega[ok], at.mu[ok]
            res.iterations[ok] += at.iterations[ok]
            res.residual[ok] = at.residual[ok]
            inside = inside | ok
        for b in np.flatnonzero((conv & inside).cpu().numpy()):
            pb = float(res.mu[b])
            dpb = res.mu[b] - cur[2][b]
            kind = "regular"
            sign = float(torch.sign(res.det_sign[b])) if res.det_sign is not None else 0.0
            if float(dpb) * float(dp_prev[b]) < 0:
                kind = "fold"
            elif det_prev[b] != 0 and sign != 0 and sign != float(det_prev[b]):
                kind = "branch_point"
            det_prev[b] = sign
            dp_prev[b] = dpb
            branches[live[b]].append(BranchPoint(int(live[b]), int(count[b]), pb,
                                                 res.X[b].clone(), float(res.omega[b]),
                                                 int(res.iterations[b]), float(res.residual[b]),
                                                 kind))
            count[b] += 1
        z_new = scaled(res.X, res.omega, res.mu)
        z_prev = torch.where(conv[:, None], z_cur, z_prev)
        z_cur = torch.where(conv[:, None], z_new, z_cur)
        cur = (torch.where(conv[:, None, None], res.X, cur[0]),
               torch.where(conv, res.omega, cur[1]), torch.where(conv, res.mu, cur[2]))
        out = conv & (crossed | (res.mu < lo) | (res.mu > hi) | (amp > options.max_amplitude)
                      | (count >= options.max_points + 3))
        alive &= ~out & (ds >= options.min_step)
    for b in range(B):
        if len(branches[b]) > 1:
            branches[b][-1].kind = "end" if branches[b][-1].kind == "regular" else \
                branches[b][-1].kind
    for b in range(B):
        for j, pt in enumerate(branches[b]):
            if pt.kind == "fold" and j >= 2:
                refine_fold(builder, b, branches[b][j - 2: j + 1], r, H, options, slaved)
    out = Branches(branches, hopf_rows)
    if options.stability:
        for b in range(B):
            pts = [pt for pt in branches[b] if pt.kind != "hopf"]
            if not pts:
                out.stable.append(np.zeros(0, dtype=bool))
                out.critical_multiplier.append(np.zeros(0))
                out.floquet_error.append(np.zeros(0))
                continue
            sysb = builder(np.array([pt.parameter for pt in pts]), np.full(len(pts), b))
            Xb = torch.stack([pt.X for pt in pts])
            wb = torch.as_tensor([pt.omega for pt in pts], dtype=dt, device=dev)
            fl = floquet(sysb, Xb, wb)
            out.stable.append(fl.stable)
            out.critical_multiplier.append(fl.critical_modulus)
            out.floquet_error.append(fl.trivial_error)
    return out


def refine_fold(builder: Builder, branch: int, around: list[BranchPoint], r: Tensor, H: int,
                options: BranchOptions, slaved: Tensor, iterations: int = 8) -> None:
    """Locate the limit point between three branch points around a fold (the extremum of p
    along the branch) and store it on the last one (``fold``): parabolic steps on p(A), each
    p(A) from an amplitude-fixed solve (A, the output's first-harmonic amplitude, stays
    monotonic through a fold in p)."""
    def amp(pt):
        return float((pt.X[1] @ r).abs())

    pts = sorted(around, key=amp)
    A = [amp(pt) for pt in pts]
    P = [pt.parameter for pt in pts]
    Xs = {a: pt for a, pt in zip(A, pts)}
    nh = n_coefficients(H)
    p_scale = options.bounds[1] - options.bounds[0]
    lo, hi = options.bounds
    eq = _ParameterEquations(lambda p, act: builder(p, np.full(len(p), branch)), H, p_scale,
                             (lo - (hi - lo), hi + (hi - lo)))
    dt = pts[0].X.dtype
    for _ in range(iterations):
        (a0, a1, a2), (p0, p1, p2) = A[-3:] if len(A) > 3 else A, P[-3:] if len(P) > 3 else P
        den = (a1 - a0) * (p1 - p2) - (a1 - a2) * (p1 - p0)
        if den == 0:
            break
        a_new = a1 - 0.5 * ((a1 - a0) ** 2 * (p1 - p2) - (a1 - a2) ** 2 * (p1 - p0)) / den
        if not (min(A) < a_new < max(A)):
            break
        near = min(Xs, key=lambda a: abs(a - a_new))
        start = Xs[near]
        Aa = torch.tensor([a_new], dtype=dt)
        w, d = amplitude_condition(r, nh, Aa)
        res = newton(eq, (start.X * (a_new / near))[None], torch.tensor([start.omega], dtype=dt),
                     torch.tensor([start.parameter], dtype=dt), r, w, d, Aa, options.newton,
                     residual_fn=eq.residual, slaved=slaved)
        if not bool(res.converged[0]):
            break
        pn = float(res.mu[0])
        # keep the three points around the extremum of p (largest p for a fold to the right,
        # smallest to the left: the middle point holds it)
        pts3 = sorted(zip(A + [a_new], P + [pn]), key=lambda t: t[0])
        k = int(np.argmax([t[1] for t in pts3])) if P[1] >= max(P[0], P[2]) else int(
            np.argmin([t[1] for t in pts3]))
        k = min(max(k, 1), len(pts3) - 2)
        A = [t[0] for t in pts3[k - 1: k + 2]]
        P = [t[1] for t in pts3[k - 1: k + 2]]
        Xs[a_new] = BranchPoint(branch, -1, pn, res.X[0], float(res.omega[0]), 0, 0.0)
        if abs(A[2] - A[0]) <= 1e-6 * max(abs(A[1]), 1e-300):
            break
    best = Xs.get(A[1])
    if best is None:
        best = min(Xs.values(), key=lambda pt: abs(amp(pt) - A[1]))
    around[-1].fold = (float(P[1]), float(A[1]), best.X, float(best.omega))
