"""Periodic orbits (LCOs) of B cases from scratch: critical mode, amplitude-fixed cold start,
adaptive number of harmonics.

q = 0 is always a solution of the harmonic balance equations, so a plain Newton start from a
small motion falls back onto it, and a start far out diverges. The cold start therefore follows
the orbit family by *amplitude*, as the Hopf normal form suggests:

1. the critical root λ = σ + iω of the linearised case (largest real part among the
   oscillatory roots, :func:`critical_modes`) and its mode shape φ give the orbit at a small
   output amplitude A0 (y = r·q = A0 cos τ);
2. at a fixed amplitude A the equations are solved for (X, ω, c), where c is a fictitious
   mass-proportional damping (1/s) that makes the orbit exist (c ≈ 2σ at small A);
3. c(A) is followed with a secant in A² (near the Hopf point c ≈ c0 + c2 A²) until it vanishes;
   the amplitude steps are limited (at most ×3 per stage);
4. the final Newton frees A and fixes c = 0: the physical LCO.

A case whose root does not grow (σ ≤ 0) decays from a small start (status ``decay``, amplitude
0 — what time marching from a small start finds; coexisting subcritical orbits are found by
continuation, :mod:`.continuation`); one whose amplitude passes ``max_amplitude`` before c
vanishes is ``diverged``.

The number of harmonics is adaptive per case: the cold start runs at ``start_harmonics``,
then H grows by 2 until the amplitude changes by at most ``amplitude_rtol`` from the previous H
and the truncation residual (harmonics H+1…3H of the nonlinear force, which the equations at
H cannot balance, relative to the largest linear force) is at most ``residual_tol``.

Along a neighbour chain (:func:`solve_orbits`) a case is solved at its neighbour's H from the
secant extrapolation of the two neighbours before it; the orbit at H − 2 that measures its
amplitude change is extrapolated the same way from theirs (each orbit keeps the lower one it
was checked with) and solved only loosely, so a warm case costs about two Newton iterations
at H and one at H − 2; a case that fails the test is raised as after a cold start.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import InputError
from ..sim.aeroelastic import linear_state_matrices
from ..sim.system import CaseSystem, static_equilibrium
from .balance import HarmonicBalance
from .fourier import (
    FourierBasis,
    coefficients_from_samples,
    harmonic_magnitudes,
    n_coefficients,
    parabolic_extreme,
    resize_harmonics,
    synthesis_matrix,
)
from .newton import NewtonOptions, newton

Tensor = torch.Tensor

#: a root is oscillatory above this frequency (Hz)
MIN_FREQUENCY_HZ = 1e-3
#: Newton tolerance of the intermediate amplitude stages (only the final solve is tight)
STAGE_TOL = 1e-6
#: largest growth of A² from one stage to the next (×10 in amplitude)
MAX_STAGE_GROWTH = 100.0
#: the cold start's last stage: the next amplitude within this fraction, or |c| below this
#: fraction of its small-amplitude value
FINAL_STAGE_RTOL = 0.05
#: failed stages retried (each with half the amplitude step) before a case is unconverged
MAX_RETRIES = 6
#: a warm start whose orbit shrank below this fraction of its neighbour's fell onto q = 0
COLLAPSE_RATIO = 1e-3
#: the H − 2 orbit of the adaptive check is solved to this fraction of ``amplitude_rtol``
LOW_H_TOL = 0.1
#: Newton iterations of a warm start (the check's H − 2 solve is one) before it counts as failed
WARM_ITERATIONS = 10


@dataclass(frozen=True)
class HBOptions:
    """Harmonic balance settings (see the module docstring).

    Attributes:
        start_harmonics: H of the cold start (cheap; raised afterwards).
        harmonics: the smallest H of an accepted orbit.
        max_harmonics: the largest H tried.
        amplitude_rtol: accepted when the amplitude changed by at most this fraction from H − 2.
        residual_tol: ... and the truncation residual is at most this.
        start_amplitude: output amplitude of the first cold-start stage (output units; None:
            1e-3 of ``amplitude_scale``).
        amplitude_scale: a typical LCO amplitude (output units) for the default start.
        max_amplitude: an orbit larger than this is reported ``diverged``.
        max_stages: amplitude stages of the cold start before giving up (``unconverged``).
        newton: the Newton settings.
        metric_points: samples per period for amplitudes (half peak-to-peak).
    """

    start_harmonics: int = 3
    harmonics: int = 5
    max_harmonics: int = 9
    amplitude_rtol: float = 2e-3
    residual_tol: float = 1e-3
    start_amplitude: float | None = None
    amplitude_scale: float = 1.0
    max_amplitude: float = math.inf
    max_stages: int = 40
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    metric_points: int = 512

    def __post_init__(self):
        for name in ("start_harmonics", "harmonics", "max_harmonics"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(f"hb.{name}: expected an integer >= 1, got {v!r}")
        if not self.start_harmonics <= self.harmonics <= self.max_harmonics:
            raise InputError(f"hb: expected start_harmonics <= harmonics <= max_harmonics, got "
                             f"{self.start_harmonics}, {self.harmonics}, {self.max_harmonics}")
        for name in ("amplitude_rtol", "residual_tol", "amplitude_scale", "max_amplitude"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
                raise InputError(f"hb.{name}: expected a positive number, got {v!r}")
        if self.start_amplitude is not None and not (
                isinstance(self.start_amplitude, (int, float)) and self.start_amplitude > 0
                and math.isfinite(self.start_amplitude)):
            raise InputError(f"hb.start_amplitude: expected a positive number, got "
                             f"{self.start_amplitude!r}")


@dataclass
class PeriodicOrbits:
    """B periodic orbits (one per case) and how they were obtained.

    Attributes:
        X: (B, 2H_max+1, n) Fourier coefficients (zero-padded beyond each case's H).
        omega: (B,) angular frequency (rad/s); NaN where there is no orbit.
        harmonics: (B,) H of each orbit (0 where there is none).
        status: (B,) 'lco', 'decay', 'diverged', 'unconverged' or 'failed'.
        residual: (B,) scaled residual of the last Newton iteration.
        truncation: (B,) truncation residual at the final H.
        amplitude_change: (B,) relative amplitude change from H − 2 to H.
        iterations: (B,) Newton iterations in all.
        critical_root: (B,) complex critical root of the linearised case (1/s); NaN for an
            LCO reached from a neighbour's orbit (not computed).
    """

    X: Tensor
    omega: Tensor
    harmonics: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    truncation: np.ndarray
    amplitude_change: np.ndarray
    iterations: np.ndarray
    critical_root: np.ndarray

    @property
    def frequency_hz(self) -> np.ndarray:
        return self.omega.cpu().numpy() / (2 * math.pi)

    def output_coefficients(self, rows: Tensor) -> Tensor:
        """(B, 2H+1, O) coefficients of the outputs y = rows @ q (rows (O, n))."""
        return self.X @ rows.to(self.X).T

    def amplitude(self, rows: Tensor, n_points: int = 512) -> np.ndarray:
        """(B, O) half peak-to-peak amplitude of each output (0 for ``decay``, NaN where there
        is no orbit)."""
        return orbit_amplitude(self.output_coefficients(rows), self.status, n_points)

    def distortion(self, rows: Tensor) -> np.ndarray:
        """(B, O) total harmonic distortion sqrt(Σ_{k≥2} |y_k|²) / |y_1| of each output."""
        mags = harmonic_magnitudes(self.output_coefficients(rows).transpose(1, 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            return (mags[..., 2:].norm(dim=-1) / mags[..., 1]).cpu().numpy()


def orbit_state(system: CaseSystem, X: Tensor, omega: Tensor
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, q̇, ξ) at τ = 0 of the orbits X (B, 2H+1, n), ω (B,): the initial state that puts a
    time integration on the orbit (the lag states from their harmonics, ξ_k = (ikω − R)⁻¹ E
    ikω q_k)."""
    H = (X.shape[1] - 1) // 2
    k = torch.arange(1, H + 1, dtype=X.dtype, device=X.device)
    q = X[:, 0] + X[:, 1::2].sum(1)
    v = omega[:, None] * (k[None, :, None] * X[:, 2::2]).sum(1)
    B, na = X.shape[0], system.n_lag
    xi = np.zeros((B, na))
    if na:
        Q = torch.complex(X[:, 1::2], -X[:, 2::2])  # (B, H, n)
        s = 1j * (omega[:, None] * k[None]).to(torch.complex128)
        A = s[:, :, None, None] * torch.eye(na, dtype=torch.complex128) - system.lag_R[
            :, None].to(torch.complex128)
        Xi = torch.linalg.solve(A, (system.lag_E[:, None].to(torch.complex128)
                                    @ Q.to(torch.complex128)[..., None]) * s[:, :, None, None])
        xi = Xi[..., 0].real.sum(1).cpu().numpy()
    return q.cpu().numpy(), v.cpu().numpy(), xi


def orbit_amplitude(Y: Tensor, status, n_points: int = 512) -> np.ndarray:
    """(B, O) half peak-to-peak of outputs with coefficients Y (B, 2H+1, O), from a fine grid
    refined by a parabola through each extreme sample (relative error ~1e-9 for n_points =
    512 on a near-harmonic orbit); 0 for 'decay', NaN for statuses without an orbit."""
    H = (Y.shape[1] - 1) // 2
    E = synthesis_matrix(H, n_points, Y.device, Y.dtype)
    y = E @ Y  # (B, P, O)
    amp = 0.5 * (parabolic_extreme(y, 1.0)[1] - parabolic_extreme(y, -1.0)[1])
    out = amp.cpu().numpy()
    status = np.asarray(status)
    out[status == "decay"] = 0.0
    out[~np.isin(status, ("lco", "decay"))] = np.nan
    return out


# -- the linearised cases ------------------------------------------------------------------------
def critical_modes(system: CaseSystem, about: Tensor | None = None) -> tuple[Tensor, Tensor]:
    """(λ (B,) complex, φ (B, n) complex): the oscillatory root of each case linearised about
    its static state (``about``, when the caller has it) with the largest real part (1/s) and
    its mode shape (structural part of the eigenvector)."""
    A = linear_state_matrices(system.to(dtype=torch.float64), about)
    lam, vec = torch.linalg.eig(A)
    osc = lam.imag > 2 * math.pi * MIN_FREQUENCY_HZ
    score = torch.where(osc, lam.real, torch.full_like(lam.real, -math.inf))
    j = score.argmax(dim=1)
    if not bool(osc.any(dim=1).all()):
        bad = int(torch.nonzero(~osc.any(dim=1))[0])
        raise InputError(f"harmonic balance: case {bad}: the linearised system has no "
                         f"oscillatory root")
    B = A.shape[0]
    idx = torch.arange(B)
    return lam[idx, j], vec[idx, : system.n, j]


def amplitude_powers(system: CaseSystem) -> Tensor:
    """(n,) how each coordinate scales with the orbit's amplitude near the Hopf point: 2 for
    dual modes (their quasi-static response to the linear modes is quadratic, Eqs. 47–48),
    1 otherwise."""
    kinds = list(getattr(system.rom, "mode_kinds", None) or [])
    p = [2.0 if k == "dual" else 1.0 for k in kinds] if len(kinds) == system.n else [1.0] * system.n
    return torch.tensor(p, device=system.device)


def dual_coordinates(system: CaseSystem) -> Tensor:
    """Indices of the dual modes (the stiff coordinates Newton slaves, :mod:`.newton`)."""
    kinds = list(getattr(system.rom, "mode_kinds", None) or [])
    return torch.as_tensor([i for i, k in enumerate(kinds) if k == "dual"], dtype=torch.long,
                           device=system.device)


def orbit_from_mode(phi: Tensor, r: Tensor, amplitude: Tensor, nh: int) -> Tensor:
    """Coefficients (B, nh, n) of q = Re(Q e^{iτ}) with Q ∝ φ scaled so that y = r·q =
    amplitude · cos τ."""
    c = phi @ r.to(phi.dtype)
    c = torch.where(c.abs() > 0, c, torch.ones_like(c))
    Q = phi * (amplitude.to(phi.real.dtype) / c)[:, None]
    X = torch.zeros(phi.shape[0], nh, phi.shape[1], dtype=phi.real.dtype, device=phi.device)
    X[:, 1] = Q.real
    X[:, 2] = -Q.imag
    return X


# -- linear conditions ---------------------------------------------------------------------------
def amplitude_condition(r: Tensor, nh: int, amplitude: Tensor) -> tuple[Tensor, Tensor]:
    """w, d of the condition r·a_1 = amplitude (with the phase condition: y = A cos τ + …)."""
    n = r.shape[0]
    B = amplitude.shape[0]
    w = r.new_zeros(B, nh * n + 2)
    w[:, n: 2 * n] = r
    return w, amplitude.clone()


def fixed_parameter_condition(B: int, nh: int, n: int, value: Tensor) -> tuple[Tensor, Tensor]:
    """w, d of the condition μ = value."""
    w = value.new_zeros(B, nh * n + 2)
    w[:, -1] = 1.0
    return w, value.clone()


class _Evaluator:
    """evaluate(X, ω, c, active) for :func:`~.newton.newton`, with the fictitious damping as μ;
    the HB equations of the active subset are rebuilt only when that subset changes."""

    def __init__(self, system: CaseSystem, H: int):
        self.system, self.H = system, H
        self._key, self._hb = None, None

    def hb(self, active: Tensor) -> HarmonicBalance:
        key = (int(active.numel()), tuple(active.tolist()))
        if key != self._key:
            sub = self.system if key[0] == self.system.batch_size and bool(
                (active == torch.arange(key[0], device=active.device)).all()
            ) else self.system.select(active)
            self._hb, self._key = HarmonicBalance(sub, self.H), key
        return self._hb

    def __call__(self, X, omega, c, active):
        return self.hb(active).jacobian(X, omega, c)

    def residual(self, X, omega, c, active):
        return self.hb(active).residual(X, omega, c)

    def newton(self, X, omega, mu, r, w, d, scale, options, active):
        """:func:`~.newton.newton` on these equations, the dual modes slaved."""
        return newton(self, X, omega, mu, r, w, d, scale, options, active,
                      residual_fn=self.residual, slaved=self.slaved)

    @property
    def slaved(self) -> Tensor:
        return dual_coordinates(self.system)


def truncation_residual(system: CaseSystem, X: Tensor, omega: Tensor) -> Tensor:
    """(B,) the size of what the equations at H cannot balance: the harmonics k = H+1..3H of
    the nonlinear force on the orbit, each turned into the displacement it would cause
    (divided by max(K_ii, (kω)² M_ii), the larger of the coordinate's static stiffness and its
    inertia at that harmonic: stiff dual coordinates carry large forces but tiny motions),
    largest value relative to the orbit's largest coefficient."""
    nh = X.shape[1]
    H = (nh - 1) // 2
    hb = HarmonicBalance(system, H, n_samples=6 * H + 2)
    q, v = hb.samples(X, omega)
    F = coefficients_from_samples(hb.nonlinear_force(q, v), 3 * H)[:, nh:]  # k = H+1..3H
    k = torch.arange(H + 1, 3 * H + 1, device=X.device, dtype=X.dtype).repeat_interleave(2)
    Kd = hb.Kl.diagonal(dim1=1, dim2=2).abs()  # (B, n)
    Md = hb.Mt.diagonal(dim1=1, dim2=2).abs()
    stiff = torch.maximum(Kd[:, None, :], (k[None, :, None] * omega[:, None, None]) ** 2
                          * Md[:, None, :])
    disp = (F.abs() / stiff.clamp_min(torch.finfo(X.dtype).tiny)).amax(dim=(1, 2))
    return disp / X.abs().amax(dim=(1, 2)).clamp_min(torch.finfo(X.dtype).tiny)


# -- the solver ------------------------------------------------------------------------------------
def cold_start(system: CaseSystem, r: Tensor, options: HBOptions,
               H: int | None = None, initial: tuple[Tensor, Tensor] | None = None) -> dict:
    """Stages 1–4 of the module docstring at H = ``start_harmonics``: a dict with X, omega,
    status (np array), iterations, residual and the critical roots.

    Every case keeps its last converged stage; a stage (or the final solve) that fails is
    retried from there with half the amplitude step, up to ``MAX_RETRIES`` times.

    ``initial``: (X (B, 2H+1, n), ω (B,)) orbits to start from instead of the critical modes:
    the first stage then solves at their amplitudes, with c from 0."""
    H = options.start_harmonics if H is None else H
    B, n, nh = system.batch_size, system.n, n_coefficients(H)
    dt, dev = system.dtype, system.device
    r = r.to(device=dev, dtype=dt)
    # the static state under a constant load (a wing at an angle of attack): the orbits'
    # mean starts there and only the motion about it scales with the amplitude
    offset = torch.zeros(B, nh, n, dtype=dt, device=dev)
    q_eq = None
    if system.load is not None:
        q_eq = torch.nan_to_num(static_equilibrium(system))
        offset[:, 0] = q_eq.to(dt)
    lam, phi = critical_modes(system, q_eq)
    lam, phi = lam.to(dev), phi.to(dev)
    sigma = lam.real.to(dt)
    A0 = float(options.start_amplitude or 1e-2 * options.amplitude_scale)
    A = torch.full((B,), A0, dtype=dt, device=dev)  # amplitude of the last converged stage
    c = 2.0 * sigma  # the fictitious damping that cancels the growth rate σ (≈ −c/2 shift)
    c0 = c.abs().clamp_min(torch.finfo(dt).tiny)
    status = np.full(B, "running", dtype=object)
    status[(sigma <= 0).cpu().numpy()] = "decay"
    if initial is None:
        X = orbit_from_mode(phi, r, A, nh).to(dt) + offset
        omega = lam.imag.to(dt).clone()
    else:
        X, omega = resize_harmonics(initial[0], H).to(dt), initial[1].to(dt).clone()
        A = (X[:, 1] @ r).abs()
        c = torch.zeros_like(c)
    iterations = torch.zeros(B, dtype=torch.long, device=dev)
    residual = torch.full((B,), math.nan, dtype=dt, device=dev)
    retries = torch.zeros(B, dtype=torch.long, device=dev)
    evaluate = _Evaluator(system, H)
    nan = torch.full((B,), math.nan, dtype=dt, device=dev)
    x_prev, c_prev = nan.clone(), nan.clone()
    # the converged stage before the last (orbit, ω, c, amplitude; A NaN until there is one)
    X_before, om_before, c_before, A_before = X.clone(), omega.clone(), c.clone(), nan.clone()
    A_try = A.clone()  # amplitude of the next stage
    final = torch.zeros(B, dtype=torch.bool, device=dev)
    first = torch.ones(B, dtype=torch.bool, device=dev)
    power = amplitude_powers(system).to(dt)
    loose = dataclasses.replace(options.newton, tol=STAGE_TOL)
    zero = torch.zeros(B, dtype=dt, device=dev)

    for _stage in range(options.max_stages):
        act = torch.as_tensor(np.flatnonzero(status == "running"), device=dev, dtype=torch.long)
        if act.numel() == 0:
            break
        # start every case from its last converged orbit scaled to the amplitude tried
        # (linear coordinates ∝ A, dual ones ∝ A²: their quasi-static response); with two
        # converged stages, the scaled shape X/A^p, ω and c are extrapolated (a secant
        # predictor: far fewer Newton iterations on the large, strongly nonlinear stages)
        shape = (X - offset) / A[:, None, None] ** power
        two = torch.isfinite(A_before) & (A_before != A)
        Ab = torch.where(two, A_before, A)
        f = torch.where(two, (A_try - A) / (A - Ab), torch.zeros_like(A))
        shape_b = torch.where(two[:, None, None], (X_before - offset) / Ab[:, None, None]
                              ** power, shape)
        start = ((shape + f[:, None, None] * (shape - shape_b)) * A_try[:, None, None] ** power
                 + offset)
        om_start = omega + f * (omega - torch.where(two, om_before, omega))
        c_start = c + torch.where(two, (c - c_before) * (A_try**2 - A**2) / (A**2 - Ab**2),
                                  torch.zeros_like(c))
        fin = act[final[act]]
        stg = act[~final[act]]
        X_new, om_new, c_new = start.clone(), om_start.clone(), c_start.clone()
        conv = torch.zeros(B, dtype=torch.bool, device=dev)
        for idx, is_final in ((stg, False), (fin, True)):
            if idx.numel() == 0:
                continue
            if is_final:  # c = 0, amplitude free: the physical orbit
                w, d = fixed_parameter_condition(B, nh, n, zero)
                res = evaluate.newton(start, om_start, c, r, w, d, A_try, options.newton, idx)
            else:  # amplitude fixed, c free
                w, d = amplitude_condition(r, nh, A_try)
                res = evaluate.newton(start, om_start, c_start, r, w, d, A_try, loose, idx)
            iterations += res.iterations
            X_new[idx], om_new[idx], c_new[idx] = res.X[idx], res.omega[idx], res.mu[idx]
            residual[idx] = res.residual[idx]
            conv[idx] = res.converged[idx]
            if is_final:  # a final solve that fell onto q = 0 (always a solution) failed
                conv[idx] &= (X_new[idx, 1] @ r).abs() > COLLAPSE_RATIO * A_try[idx]
        ok_fin = act[final[act] & conv[act]]
        idx = ok_fin.cpu().numpy()
        X[ok_fin], omega[ok_fin] = X_new[ok_fin], om_new[ok_fin]
        status[idx] = "lco"
        # failures: retry with half the step from the last converged stage
        failed = act[~conv[act]]
        retries[failed] += 1
        final[failed] = False
        A_try[failed] = torch.where(first[failed], A_try[failed] * 0.5,
                                    A[failed] + 0.5 * (A_try[failed] - A[failed]))
        status[failed[retries[failed] > MAX_RETRIES].cpu().numpy()] = "unconverged"
        good = act[~final[act] & conv[act]]
        if good.numel() == 0:
            continue
        # the stage before (for the predictor): the last converged one, not the first guess
        was = good[~first[good]]
        X_before[was], om_before[was], c_before[was], A_before[was] = (
            X[was], omega[was], c[was], A[was])
        X[good], omega[good], c[good] = X_new[good], om_new[good], c_new[good]
        A[good] = A_try[good]
        first[good] = False
        # the next amplitude: c(A) ≈ c0 + c2 A² near the Hopf point, so a secant of c in
        # x = A² (regula falsi once the sign changed), steps limited to ×10 in A
        x, cc = A[good] ** 2, c[good]
        xp, cp = x_prev[good], c_prev[good]
        have_prev = torch.isfinite(xp)
        root = x - cc * (x - xp) / (cc - cp)
        root = torch.where(torch.isfinite(root), root, x)
        lo, hi = torch.minimum(x, xp), torch.maximum(x, xp)
        toward = torch.where(cc > 0, torch.clamp(root, min=x, max=MAX_STAGE_GROWTH * x),
                             torch.clamp(root, min=x / MAX_STAGE_GROWTH, max=x))
        blind = torch.where(cc > 0, MAX_STAGE_GROWTH * x, x / MAX_STAGE_GROWTH)
        x_new = torch.where(have_prev & ((cc > 0) == (root > x)), toward, blind)
        x_new = torch.where(have_prev & (cc * cp < 0), torch.clamp(root, min=lo, max=hi), x_new)
        x_prev[good], c_prev[good] = x, cc
        a_new = torch.sqrt(x_new)
        A_try[good] = a_new
        close = ((a_new - A[good]).abs() <= FINAL_STAGE_RTOL * A[good]) | (
            cc.abs() <= FINAL_STAGE_RTOL * c0[good])
        final[good[close]] = True
        status[good[(a_new > options.max_amplitude) & ~close].cpu().numpy()] = "diverged"
        # c < 0 all the way down to the smallest orbits although the rest state is unstable:
        # the stages lost the family (a decaying case never gets here)
        status[good[(a_new < A0 / MAX_STAGE_GROWTH) & ~close].cpu().numpy()] = "unconverged"
    status[status == "running"] = "unconverged"
    amp = (X[:, 1] @ r).abs()
    status[(status == "lco") & (amp > options.max_amplitude).cpu().numpy()] = "diverged"
    return {"X": X, "omega": omega, "status": status, "iterations": iterations,
            "residual": residual, "critical_root": lam.cpu().numpy()}


def refine_harmonics(system: CaseSystem, X: Tensor, omega: Tensor, r: Tensor, H: int,
                     options: HBOptions, active: Tensor) -> tuple[Tensor, Tensor, Tensor,
                                                                 Tensor, Tensor]:
    """The orbits of ``active`` cases re-solved at H harmonics from X (any H'): (X, ω,
    converged, iterations, residual) with X (B, 2H+1, n)."""
    B, n = X.shape[0], X.shape[2]
    nh = n_coefficients(H)
    Xh = resize_harmonics(X, H)
    w, d = fixed_parameter_condition(B, nh, n, torch.zeros(B, dtype=X.dtype, device=X.device))
    scale = Xh.abs().amax(dim=(1, 2))
    res = _Evaluator(system, H).newton(Xh, omega, torch.zeros_like(omega), r, w, d, scale,
                                       options.newton, active)
    return res.X, res.omega, res.converged, res.iterations, res.residual


@dataclass
class _Orbits:
    """Working arrays of a batch (numpy per-case fields, torch coefficients at H_max). The
    orbit at H − 2 that measured each accepted orbit's amplitude change rides along
    (``X_low``, ``omega_low``; NaN frequency where there is none): the next case of a chain
    starts its own H − 2 solve from it."""

    X: Tensor
    omega: Tensor
    H: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    amplitude_change: np.ndarray
    iterations: np.ndarray
    X_low: Tensor | None = None
    omega_low: Tensor | None = None
    truncation: np.ndarray | None = None

    def __post_init__(self):
        if self.X_low is None:
            self.X_low = torch.zeros_like(self.X)
            self.omega_low = torch.full_like(self.omega, math.nan)
        if self.truncation is None:  # the truncation residual at the current H (NaN: unknown)
            self.truncation = np.full(len(self.status), math.nan)

    @classmethod
    def empty(cls, B: int, nh: int, n: int, like: Tensor) -> _Orbits:
        return cls(like.new_zeros(B, nh, n), like.new_full((B,), math.nan),
                   np.zeros(B, dtype=int), np.full(B, "failed", dtype=object),
                   np.full(B, math.nan), np.full(B, math.nan), np.zeros(B, dtype=int))

    def widen(self, H: int) -> None:
        """Coefficients zero-padded to H harmonics (if fewer)."""
        if n_coefficients(H) > self.X.shape[1]:
            self.X = resize_harmonics(self.X, H)
            self.X_low = resize_harmonics(self.X_low, H)

    def put(self, idx: np.ndarray, other: _Orbits) -> None:
        t = torch.as_tensor(idx, dtype=torch.long, device=self.X.device)
        H = (self.X.shape[1] - 1) // 2
        self.X[t] = resize_harmonics(other.X, H)
        self.X_low[t] = resize_harmonics(other.X_low, H)
        self.omega[t] = other.omega
        self.omega_low[t] = other.omega_low
        for name in ("H", "status", "residual", "amplitude_change", "iterations",
                     "truncation"):
            getattr(self, name)[idx] = getattr(other, name)


def _adapt_harmonics(system: CaseSystem, r: Tensor, orb: _Orbits, H: int,
                     options: HBOptions) -> _Orbits:
    """Raise H (by 2) for the 'lco' cases of ``orb`` (all at H) until accepted: the amplitude
    changed by at most ``amplitude_rtol`` from the previous H and the truncation residual is
    at most ``residual_tol`` (the first raise is always made: an amplitude change needs two
    H). Convergence in H is not always monotone (a harmonic near a structural resonance), so
    the change is the error estimate of the smaller H and the larger H's orbit is kept."""
    rows = r[None, :]

    def amp_of(Xc: Tensor) -> np.ndarray:
        return orbit_amplitude(Xc @ rows.T, np.full(Xc.shape[0], "lco", dtype=object),
                               options.metric_points)[:, 0]

    X, omega = orb.X, orb.omega
    prev_amp = amp_of(X)
    todo = np.flatnonzero(orb.status == "lco")
    while todo.size and H < options.max_harmonics:
        H_new = min(H + 2, options.max_harmonics)
        act = torch.as_tensor(todo, device=X.device)
        Xn, wn, conv, its, res = refine_harmonics(system, X, omega, r, H_new, options, act)
        orb.iterations[todo] += its[act].cpu().numpy()
        conv = conv[act].cpu().numpy()
        orb.status[todo[~conv]] = "unconverged"
        ok = todo[conv]
        X = resize_harmonics(X, H_new)
        okt = torch.as_tensor(ok, dtype=torch.long, device=X.device)
        X_low = resize_harmonics(orb.X_low, H_new)
        X_low[okt], orb.omega_low[okt] = X[okt], omega[okt]  # the orbit at H, now the low one
        orb.X_low = X_low
        X[okt], omega[okt] = Xn[okt], wn[okt]
        orb.residual[ok] = res[okt].cpu().numpy()
        orb.H[ok] = H_new
        orb.truncation[ok] = math.nan
        amp = amp_of(X)
        change = np.abs(amp - prev_amp) / np.maximum(np.abs(amp), 1e-300)
        orb.amplitude_change[ok] = change[ok]
        prev_amp = amp
        H = H_new
        if H < options.harmonics or ok.size == 0:
            todo = ok
            continue
        trunc = truncation_residual(system.select(okt), X[okt], omega[okt]).cpu().numpy()
        orb.truncation[ok] = trunc
        accept = (change[ok] <= options.amplitude_rtol) & (trunc <= options.residual_tol)
        todo = ok[~accept]
    orb.X, orb.omega = X, omega
    orb.X_low = resize_harmonics(orb.X_low, (X.shape[1] - 1) // 2)
    return orb


def _solve_cold(system: CaseSystem, r: Tensor, options: HBOptions) -> tuple[_Orbits, np.ndarray]:
    """Cold start and adaptive H for every case of ``system``; also the critical roots."""
    st = cold_start(system, r, options)
    B = system.batch_size
    orb = _Orbits(st["X"], st["omega"],
                  np.where(st["status"] == "lco", options.start_harmonics, 0),
                  st["status"], st["residual"].cpu().numpy(), np.full(B, math.nan),
                  st["iterations"].cpu().numpy())
    return _adapt_harmonics(system, r, orb, options.start_harmonics, options), \
        st["critical_root"]


def _warm_newton(system: CaseSystem, r: Tensor, X: Tensor, omega: Tensor, H: int,
                 options: HBOptions, act: Tensor):
    """Newton (c = 0) from (X, ω) for the cases ``act``; a correction that falls onto q = 0
    (always a solution) counts as failed. A warm start that has not converged within
    :data:`WARM_ITERATIONS` is not going to: the homotopy or a cold start takes over."""
    options = dataclasses.replace(options, newton=dataclasses.replace(
        options.newton, max_iterations=min(options.newton.max_iterations, WARM_ITERATIONS)))
    Xn, wn, conv, its, res = refine_harmonics(system, X, omega, r, H, options, act)
    amp0 = (resize_harmonics(X, H)[:, 1] @ r).abs()
    conv = conv & ((Xn[:, 1] @ r).abs() > COLLAPSE_RATIO * amp0)
    return Xn, wn, conv, its, res


def _solve_warm(system: CaseSystem, r: Tensor, X: Tensor, omega: Tensor, H: int,
                options: HBOptions, neighbours: CaseSystem | None = None,
                low: tuple[Tensor, Tensor] | None = None) -> _Orbits:
    """Every case of ``system`` from a neighbour's orbit (X, ω truncated to H harmonics):
    Newton with c = 0, then the adaptive H check as for a cold start. Where that fails and the
    neighbours' own cases are given, the cases are reached along the straight path from the
    neighbours' (:meth:`CaseSystem.blend`) in 2, then 4 sub-steps (a homotopy); failures
    left start cold (:func:`solve_orbits`). ``low``: starts of the check's H − 2 orbits
    (:func:`_check_harmonics`)."""
    B = system.batch_size
    act = torch.arange(B, device=X.device)
    Xn, wn, conv, its, res = _warm_newton(system, r, X, omega, H, options, act)
    its = its.clone()
    for parts in (2, 4) if neighbours is not None else ():
        failed = torch.nonzero(~conv).reshape(-1)
        if failed.numel() == 0:
            break
        Xs, ws = resize_harmonics(X, H)[failed], omega[failed]
        sub, nb = system.select(failed), neighbours.select(failed)
        ok = torch.ones(len(failed), dtype=torch.bool, device=X.device)
        sub_act = torch.arange(len(failed), device=X.device)
        for k in range(1, parts + 1):
            step = nb.blend(sub, k / parts)
            Xk, wk, ck, itk, rk = _warm_newton(step, r, Xs, ws, H, options, sub_act[ok])
            its[failed] += itk
            ok &= ck
            Xs = torch.where(ok[:, None, None], Xk, Xs)
            ws = torch.where(ok, wk, ws)
            if not bool(ok.any()):
                break
        good = failed[ok]
        Xn[good], wn[good], res[good] = Xs[ok], ws[ok], rk[ok]
        conv[good] = True
    its = its.cpu().numpy()
    status = np.where(conv.cpu().numpy(), "lco", "unconverged").astype(object)
    amp = (Xn[:, 1] @ r).abs().cpu().numpy()
    status[(status == "lco") & (amp > options.max_amplitude)] = "diverged"
    orb = _Orbits(Xn, wn, np.where(status == "lco", H, 0), status, res.cpu().numpy(),
                  np.full(B, math.nan), its)
    return _check_harmonics(system, r, orb, H, options, low)


def _check_harmonics(system: CaseSystem, r: Tensor, orb: _Orbits, H: int,
                     options: HBOptions, low: tuple[Tensor, Tensor] | None = None) -> _Orbits:
    """The adaptive-H test of :func:`_adapt_harmonics` for orbits already solved at H (a warm
    start at the neighbour's H): the H − 2 orbit is solved only to :data:`LOW_H_TOL` of the
    amplitude tolerance (it measures the change, nothing more), from ``low`` (X (B, ·, n), ω
    (B,): the neighbours' H − 2 orbits extrapolated, NaN ω where there is none) or else from
    the truncated H orbit (farther: the dual coordinates move by percents when the top
    harmonics are cut). Accepted orbits keep H; the others are raised by
    :func:`_adapt_harmonics`."""
    lco = np.flatnonzero(orb.status == "lco")
    if lco.size == 0 or H - 2 < 1 or H < options.harmonics:
        return _adapt_harmonics(system, r, orb, H, options)
    act = torch.as_tensor(lco, device=orb.X.device)
    X0, w0 = resize_harmonics(orb.X, H - 2), orb.omega.clone()
    if low is not None:
        given = torch.isfinite(low[1])
        X0 = torch.where(given[:, None, None], resize_harmonics(low[0], H - 2), X0)
        w0 = torch.where(given, low[1], w0)
    # solved like a warm start (iteration cap, collapse onto q = 0 counted as failure)
    loose = dataclasses.replace(options, newton=dataclasses.replace(
        options.newton, tol=LOW_H_TOL * options.amplitude_rtol))
    X_low, w_low, conv, its, _ = _warm_newton(system, r, X0, w0, H - 2, loose, act)
    orb.iterations[lco] += its[act].cpu().numpy()
    retry = act[~conv[act]]
    if low is not None and retry.numel():  # a predictor that missed: from the truncated orbit
        Xr, wr, cr, itr, _ = _warm_newton(system, r, resize_harmonics(orb.X, H - 2), orb.omega,
                                          H - 2, loose, retry)
        X_low[retry], w_low[retry], conv[retry] = Xr[retry], wr[retry], cr[retry]
        orb.iterations[retry.cpu().numpy()] += itr[retry].cpu().numpy()
    orb.X_low = resize_harmonics(orb.X_low, H)
    orb.X_low[act], orb.omega_low[act] = resize_harmonics(X_low[act], H), w_low[act]
    rows = r[None, :]
    amps = orbit_amplitude(torch.cat([resize_harmonics(X_low[act], H), orb.X[act]]) @ rows.T,
                           np.full(2 * lco.size, "lco", dtype=object),
                           options.metric_points)[:, 0]
    amp_low, amp = amps[: lco.size], amps[lco.size:]
    # no lower orbit, no measured change (NaN, and the case is raised)
    change = np.where(conv[act].cpu().numpy(),
                      np.abs(amp - amp_low) / np.maximum(np.abs(amp), 1e-300), np.nan)
    orb.amplitude_change[lco] = change
    trunc = truncation_residual(system.select(act), orb.X[act], orb.omega[act]).cpu().numpy()
    orb.truncation[lco] = trunc
    accept = (change <= options.amplitude_rtol) & (trunc <= options.residual_tol)
    if accept.all():
        return orb
    redo = lco[~accept]
    sub = _subset(orb, np.isin(np.arange(len(orb.status)), redo))
    raised = _adapt_harmonics(system.select(torch.as_tensor(redo)), r, sub, H, options)
    orb.widen((raised.X.shape[1] - 1) // 2)
    orb.put(redo, raised)
    return orb


def solve_orbits(system: CaseSystem, output_row, options: HBOptions = HBOptions(),
                 chains: list[list[int]] | None = None, positions=None) -> PeriodicOrbits:
    """The LCO of each case of ``system`` (module docstring), its output y = output_row · q
    fixing the phase (y has no sin τ term) and measuring the amplitude.

    ``chains``: optional neighbour chains (lists of case indices, together a partition of the
    cases, e.g. the cases of one curve ordered by altitude): the first case of every chain
    starts cold, each later one from the orbit of the one before it (natural-parameter
    continuation, a few Newton iterations instead of a cold start); a case whose neighbour has
    no orbit, or whose warm start fails, starts cold. The chains advance together (batched).
    ``positions``: (B,) the chain parameter of each case (e.g. its altitude): with two
    neighbours the start is their secant extrapolation instead of the last orbit."""
    r = torch.as_tensor(np.asarray(output_row, dtype=float), dtype=system.dtype,
                        device=system.device)
    if r.shape != (system.n,) or not bool(torch.isfinite(r).all()) or not bool((r != 0).any()):
        raise InputError(f"harmonic balance: output_row: expected {system.n} finite numbers, "
                         f"not all zero")
    B, n = system.batch_size, system.n
    from ..bounds import check_harmonic_balance

    check_harmonic_balance("harmonic balance: max_harmonics", n, options.max_harmonics, B,
                           device=system.device, itemsize=r.element_size())
    # no chains: every case starts cold
    chains = [[i] for i in range(B)] if chains is None else [list(c) for c in chains if c]
    flat = sorted(i for c in chains for i in c)
    if flat != list(range(B)):
        raise InputError(f"harmonic balance: chains: expected a partition of the {B} cases")
    nh_max = n_coefficients(options.max_harmonics)
    out = _Orbits.empty(B, nh_max, n, r)
    roots = np.full(B, complex(math.nan, math.nan))
    cold_roots_needed = np.ones(B, dtype=bool)
    spent = np.zeros(B, dtype=int)  # iterations of failed warm starts
    pos = None if positions is None else np.asarray(positions, dtype=float).reshape(-1)
    for j in range(max(len(c) for c in chains)):
        here = np.array([c[j] for c in chains if len(c) > j])
        prev = np.array([c[j - 1] if j else -1 for c in chains if len(c) > j])
        prev2 = np.array([c[j - 2] if j > 1 else -1 for c in chains if len(c) > j])
        warm = (prev >= 0)
        if warm.any():
            warm &= np.isin(out.status[np.maximum(prev, 0)], ("lco",))
        cold = here[~warm]
        if warm.any():
            idx, pidx, p2 = here[warm], prev[warm], prev2[warm]
            sub = system.select(torch.as_tensor(idx))
            # every warm case at its neighbour's H (the largest in the group); the check of
            # :func:`_check_harmonics` may accept it, lower nothing, or raise it
            H = max(options.start_harmonics, int(out.H[pidx].max()))
            # the predictors at H and at H − 2 (for the check's lower orbit)
            X0, w0 = _at_level(out, pidx, H)
            L0, wl0 = _at_level(out, pidx, H - 2)
            if pos is not None:  # secant predictor through the two neighbours
                two = (p2 >= 0)
                two[two] &= out.status[p2[two]] == "lco"
                if two.any():
                    t2 = torch.as_tensor(np.flatnonzero(two))
                    a, b = pidx[two], p2[two]
                    f = torch.as_tensor((pos[idx[two]] - pos[a]) / (pos[a] - pos[b]),
                                        dtype=X0.dtype)
                    f = torch.where(torch.isfinite(f), f, torch.zeros_like(f))
                    for level, (Xs, ws) in ((H, (X0, w0)), (H - 2, (L0, wl0))):
                        Xa, wa_ = _at_level(out, a, level)
                        Xb, wb_ = _at_level(out, b, level)
                        Xs[t2] = Xa + f[:, None, None] * (Xa - Xb)
                        ws[t2] = wa_ + f * (wa_ - wb_)
            w_orb = _solve_warm(sub, r, X0, w0, H, options,
                                neighbours=system.select(torch.as_tensor(pidx)), low=(L0, wl0))
            failed = w_orb.status != "lco"
            out.put(idx[~failed], _subset(w_orb, ~failed))
            cold = np.concatenate([cold, idx[failed]])
            spent[idx[failed]] += w_orb.iterations[failed]
        if cold.size:
            sub = system.select(torch.as_tensor(cold))
            c_orb, c_roots = _solve_cold(sub, r, options)
            c_orb.iterations = c_orb.iterations + spent[cold]
            out.put(cold, c_orb)
            roots[cold] = c_roots
            cold_roots_needed[cold] = False
    # the linear roots of the cases without an orbit (an LCO reached from its neighbour
    # keeps NaN: nothing downstream needs its root, and the eigenvalues cost ~1 ms a case)
    cold_roots_needed &= out.status != "lco"
    if cold_roots_needed.any():
        need = np.flatnonzero(cold_roots_needed)
        lam, _ = critical_modes(system.select(torch.as_tensor(need)))
        roots[need] = lam.cpu().numpy()
    # no orbit: zero coefficients (the static state's mean for a decay under a load); no
    # frequency but for decay (the linear root's)
    has = torch.as_tensor(out.status == "lco")
    out.X[~has] = 0.0
    if system.load is not None and (out.status == "decay").any():
        rest = torch.as_tensor(np.flatnonzero(out.status == "decay"))
        out.X[rest, 0] = static_equilibrium(system.select(rest)).to(out.X)
    decay = np.flatnonzero(out.status == "decay")
    omega = out.omega.clone()
    omega[torch.as_tensor(decay, dtype=torch.long)] = torch.as_tensor(
        roots[decay].imag, dtype=omega.dtype)
    omega[torch.as_tensor(~np.isin(out.status, ("lco", "decay")))] = math.nan
    # the truncation residual where the adaptive test did not leave it (a case at max H)
    trunc = np.where(out.status == "lco", out.truncation, math.nan)
    lco = np.flatnonzero((out.status == "lco") & np.isnan(trunc))
    for h in np.unique(out.H[lco]):
        idx = lco[out.H[lco] == h]
        t = torch.as_tensor(idx)
        trunc[idx] = truncation_residual(system.select(t), resize_harmonics(out.X[t], int(h)),
                                         out.omega[t]).cpu().numpy()
    return PeriodicOrbits(X=out.X, omega=omega, harmonics=out.H, status=out.status,
                          residual=out.residual, truncation=trunc,
                          amplitude_change=out.amplitude_change, iterations=out.iterations,
                          critical_root=roots)


def _at_level(orb: _Orbits, idx: np.ndarray, H: int) -> tuple[Tensor, Tensor]:
    """(X (len(idx), 2H+1, n), ω) of the cases ``idx`` of ``orb`` at H harmonics: the lower
    orbit where that is at H, else the orbit (truncated or zero-padded to H)."""
    t = torch.as_tensor(np.asarray(idx), dtype=torch.long, device=orb.X.device)
    low_h = torch.as_tensor(orb.H[np.asarray(idx)] - 2 == H, device=orb.X.device)
    low_h &= torch.isfinite(orb.omega_low[t])
    X = torch.where(low_h[:, None, None], resize_harmonics(orb.X_low[t], H),
                    resize_harmonics(orb.X[t], H))
    return X, torch.where(low_h, orb.omega_low[t], orb.omega[t])


def _subset(orb: _Orbits, mask: np.ndarray) -> _Orbits:
    t = torch.as_tensor(np.flatnonzero(mask), dtype=torch.long, device=orb.X.device)
    return _Orbits(orb.X[t], orb.omega[t], orb.H[mask], orb.status[mask], orb.residual[mask],
                   orb.amplitude_change[mask], orb.iterations[mask], orb.X_low[t],
                   orb.omega_low[t], orb.truncation[mask])


__all__ = ["HBOptions", "PeriodicOrbits", "solve_orbits", "critical_modes", "cold_start",
           "orbit_amplitude", "FourierBasis"]
