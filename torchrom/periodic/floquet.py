"""Stability of periodic orbits: Floquet multipliers from the monodromy matrix (batched).

A perturbation x = [δq, δq̇, δξ] of an orbit obeys the linear T-periodic system x' = A(t) x,

    M_t δq̈ + C_t(t) δq̇ + K_t(t) δq + D δξ = 0,      δξ̇ = E δq̇ + R δξ,

with the tangents of :mod:`.balance` along the orbit: K_t = K_l + K_n(q, q̇), C_t = C_0 + C_n(q).
The monodromy matrix Φ(T) maps x(0) to x(T); its eigenvalues are the Floquet multipliers μ.
One of them is 1 (a shift along the orbit: the eigenvector is ẋ(0)); the orbit is
asymptotically stable when every other |μ| < 1. The *critical* multiplier is the largest of the
others: it leaves the unit circle at +1 (fold), −1 (period doubling) or as a complex pair
(torus / Neimark–Sacker bifurcation).

Φ is the product of the exponentials of A at the step midpoints over ``steps`` steps per period
(the exponential midpoint rule, a second-order Magnus integrator): it is exact for the part of A
that is constant over a step, so the stiff dual coordinates — hundreds of radians per period,
which a trapezoidal or Runge–Kutta step of the same size propagates with arbitrary phase errors
that leak into the slow multipliers — cost no more steps than the flutter mode; the error comes
from A's variation along the orbit. The tangents at the midpoints are interpolated exactly from
the 4H + 1 AFT samples (they are trigonometric polynomials of degree 2H). The multipliers that
both step sizes resolve are Richardson-extrapolated (:func:`floquet`). The trivial multiplier is
identified by its eigenvector's alignment with ẋ(0) (not merely by being closest to 1: near a
fold a second multiplier approaches 1 too).
Hand-written (no library computes batched monodromy matrices of this model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..sim.system import CaseSystem
from .balance import HarmonicBalance
from .fourier import basis_at, coefficients_from_samples
from .newton import single_thread

Tensor = torch.Tensor

#: default steps per period of the monodromy product
FLOQUET_STEPS = 32
#: an orbit is stable when its critical multiplier is below 1 + this
STABILITY_TOL = 1e-6
#: the verdict is given only where the trivial multiplier is recovered to within this (else
#: unknown: the monodromy did not resolve the orbit, e.g. nearly undamped stiff dual modes)
TRIVIAL_TOL = 5e-2


@dataclass
class FloquetResult:
    """Per case: the multipliers (B, 2n + na) complex, the index of the trivial one, the
    critical multiplier (complex, the largest |μ| of the others), stability (True, False, or
    None where the trivial multiplier is off by more than :data:`TRIVIAL_TOL`) and that
    error |μ_trivial − 1| (the accuracy of the monodromy matrix on this orbit)."""

    multipliers: np.ndarray
    trivial: np.ndarray
    critical: np.ndarray
    stable: np.ndarray
    trivial_error: np.ndarray | None = None

    @property
    def critical_modulus(self) -> np.ndarray:
        return np.abs(self.critical)


def monodromy(system: CaseSystem, X: Tensor, omega: Tensor,
              steps: int = FLOQUET_STEPS) -> tuple[Tensor, Tensor]:
    """(Φ (B, ns, ns), ẋ(0) (B, ns)) of the orbits X (B, 2H+1, n), ω (B,) (module docstring);
    state [q, q̇, ξ], ns = 2n + na."""
    H = (X.shape[1] - 1) // 2
    hb = HarmonicBalance(system, H)
    B, n, na = system.batch_size, system.n, system.n_lag
    ns = 2 * n + na
    q, v = hb.samples(X, omega)
    _, Kn, Cn = hb.nonlinear_tangents(q, v)  # (B, N, n, n) at the 4H + 1 AFT samples
    # the tangents are quadratic in (q, q̇): trigonometric polynomials of degree 2H, which the
    # 4H + 1 samples determine exactly, so they are interpolated to the steps
    # exponential midpoint rule: the tangents at the step midpoints
    tau = 2 * math.pi * (torch.arange(steps, device=X.device, dtype=X.dtype) + 0.5) / steps
    fine = basis_at(tau, 2 * H)  # (S, 4H + 1)
    Kn, Cn = ((fine @ coefficients_from_samples(T.reshape(B, -1, n * n), 2 * H)).view(
        B, steps, n, n) for T in (Kn, Cn))
    Minv = torch.linalg.inv(hb.Mt)
    MK = Minv[:, None] @ (hb.Kl[:, None] + Kn)  # (B, S, n, n)
    MC = Minv[:, None] @ (hb.C0[:, None] + Cn)
    dev, dt = X.device, X.dtype
    eye = torch.eye(ns, device=dev, dtype=dt).expand(B, ns, ns)
    base = torch.zeros(B, ns, ns, device=dev, dtype=dt)
    base[:, :n, n:2 * n] = torch.eye(n, device=dev, dtype=dt)
    if na:
        base[:, n:2 * n, 2 * n:] = -Minv @ system.lag_D
        base[:, 2 * n:, n:2 * n] = system.lag_E
        base[:, 2 * n:, 2 * n:] = system.lag_R
    h = (2 * math.pi / omega) / steps  # (B,)

    def A(j: int) -> Tensor:
        a = base.clone()
        a[:, n:2 * n, :n] = -MK[:, j % steps]
        a[:, n:2 * n, n:2 * n] = -MC[:, j % steps]
        return a

    # Φ = Π exp(h A(t_j+½)): exact for the part of A that is constant over a step, so the stiff
    # dual coordinates (hundreds of radians per period) are propagated exactly; the error
    # (second order, Magnus) comes from A's variation along the orbit only
    with single_thread():
        steps_exp = torch.linalg.matrix_exp(
            h[:, None, None, None] * torch.stack([A(j) for j in range(steps)], dim=1))
    Phi = eye.clone()
    for j in range(steps):
        Phi = steps_exp[:, j] @ Phi
    # ẋ(0) = [q̇(0), q̈(0), ξ̇(0)]: the orbit's own tangent (ξ̇ from the trivial multiplier's
    # eigenvector is not needed to identify it: the structural part suffices)
    dq = omega[:, None] * (hb.basis.dE[0] @ X)
    ddq = omega[:, None] ** 2 * (hb.basis.dE[0] @ (hb.basis.D @ X))
    xdot = torch.cat([dq, ddq, dq.new_zeros(B, na)], dim=1)
    return Phi, xdot


def floquet(system: CaseSystem, X: Tensor, omega: Tensor, steps: int = FLOQUET_STEPS,
            tol: float = STABILITY_TOL) -> FloquetResult:
    """Floquet multipliers and stability of the orbits X (B, 2H+1, n), ω (B,) rad/s.

    The multipliers are Richardson-extrapolated from ``steps`` and ``steps``/2 steps,
    (4Φ_S − Φ_{S/2})/3: the midpoint rule's global error expands in even powers of h, so this
    removes the h² term (on the Van der Pol orbit the multiplier is then 2e-5 from Liouville's
    formula at 32 steps). A multiplier counts as resolved when the extrapolated matrix has one
    within 1e-2 of it; the others keep the plain product's value."""
    Phi, xdot = monodromy(system, X, omega, steps)
    Phi_half, _ = monodromy(system, X, omega, steps // 2)
    mu_plain, vec = torch.linalg.eig(Phi)
    mu_rich = torch.linalg.eigvals((4.0 * Phi - Phi_half) / 3.0)
    dist = (mu_plain[:, :, None] - mu_rich[:, None, :]).abs()
    nearest = dist.argmin(dim=2)
    close = dist.gather(2, nearest[..., None])[..., 0] < 1e-2 * mu_plain.abs().clamp_min(1.0)
    mu = torch.where(close, mu_rich.gather(1, nearest), mu_plain)
    n2 = 2 * system.n
    v = vec[:, :n2, :]  # structural part of each eigenvector
    xd = xdot[:, :n2].to(v.dtype)
    align = (v.conj() * xd[:, :, None]).sum(1).abs() / (
        v.abs().pow(2).sum(1).sqrt() * xd.abs().pow(2).sum(1).sqrt()[:, None]).clamp_min(1e-300)
    near_one = (mu - 1).abs() < 0.1
    score = torch.where(near_one, align, align - 10.0)
    trivial = score.argmax(dim=1)
    mod_other = mu.abs().clone()
    rows = torch.arange(mu.shape[0])
    mod_other[rows, trivial] = -1.0
    crit = mu[rows, mod_other.argmax(dim=1)]
    error = (mu[rows, trivial] - 1).abs().cpu().numpy()
    verdict = (crit.abs() < 1 + tol).cpu().numpy()
    stable = np.array([bool(v) if e <= TRIVIAL_TOL else None for v, e in zip(verdict, error)],
                      dtype=object)
    return FloquetResult(mu.cpu().numpy(), trivial.cpu().numpy(), crit.cpu().numpy(), stable,
                         error)
