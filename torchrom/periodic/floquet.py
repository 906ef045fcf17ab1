"""Stability of periodic orbits: Floquet multipliers from the monodromy matrix (batched).

A perturbation x = [δq, δq̇, δξ] of an orbit obeys the linear T-periodic system
M_t δq̈ + C_t(t) δq̇ + K_t(t) δq + D δξ = 0, δξ̇ = E δq̇ + R δξ, with the tangents of
:mod:`.balance` along the orbit. The monodromy matrix Φ(T) maps x(0) to x(T); its eigenvalues
are the Floquet multipliers. One is 1 (the shift along the orbit, identified by its eigenvector's
alignment with ẋ(0)); the orbit is stable when every other |μ| < 1, and the largest of them, the
*critical* multiplier, leaves the unit circle at +1 (fold), −1 (period doubling) or as a complex
pair (torus). Φ is the product of the exponentials of A at the step midpoints (a second-order
Magnus integrator, exact for the stiff constant part), Richardson-extrapolated over two step
sizes (:func:`floquet`); the tangents are interpolated exactly from the 4H + 1 AFT samples. On a
wing ROM the stiff dual coordinates are first condensed onto the slow state (their quasi-static
response with its first corrections for their damping and their inertia, :func:`condensable`,
:func:`_condensed_matrices`), which then takes implicit-midpoint steps.

Written here (no library computes batched monodromy matrices of this model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..sim.system import CaseSystem
from .balance import HarmonicBalance
from .fourier import FourierBasis, basis_at, coefficients_from_samples
from .newton import single_thread
from .solve import dual_coordinates

Tensor = torch.Tensor

#: default steps per period of the monodromy product
FLOQUET_STEPS = 32
#: an orbit is stable when its critical multiplier is below 1 + this, or below 1 + the
#: monodromy's own accuracy (its trivial multiplier's distance from 1) where that is larger
STABILITY_TOL = 1e-6
#: a critical multiplier closer to 1 than this (or than ten times the monodromy's accuracy) is
#: recomputed with four times the steps: near a Hopf point or a fold it is 1 ± O(A²), within
#: the default product's error (1e-5 to 1e-4 on the Goland orbits), and its side of the unit
#: circle is the verdict
REFINE_BAND = 1e-3
#: the verdict is given only where the trivial multiplier is recovered to within this (else
#: unknown: the monodromy did not resolve the orbit, e.g. an orbit not converged in H)
TRIVIAL_TOL = 5e-2
#: the dual coordinates condense when the slowest is this many times above 2ω
CONDENSE_RATIO = 10.0


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
    """(Φ (B, ns, ns), ẋ(0) (B, ns)) of the orbits X (B, 2H+1, n), ω (B,) (module docstring):
    on the slow state [δl, δl̇, δξ] (ns = 2(n − nd) + na) when the dual coordinates condense
    (:func:`condensable`), else on the full state [q, q̇, ξ] (ns = 2n + na)."""
    (Phi,), xdot = _monodromies(system, X, omega, (steps,))
    return Phi, xdot


def _monodromies(system: CaseSystem, X: Tensor, omega: Tensor, step_counts: tuple[int, ...]
                 ) -> tuple[list[Tensor], Tensor]:
    """The monodromy matrices of :func:`monodromy` for several step counts (Richardson), the
    tangents along the orbit and the step matrices at every midpoint built once."""
    H = (X.shape[1] - 1) // 2
    hb = HarmonicBalance(system, H)
    duals = dual_coordinates(system)
    slow = condensable(system, omega, duals)
    # the condensed slow state takes twice the steps of the implicit midpoint rule (below)
    counts = [2 * s if slow else s for s in step_counts]
    # midpoint rules: the tangents at the step midpoints of every count, in one batch
    tau = torch.cat([2 * math.pi * (torch.arange(c, device=X.device, dtype=X.dtype) + 0.5) / c
                     for c in counts])
    tangents = _tangent_coefficients(hb, X, omega)
    if slow:
        A_all, xdot = _condensed_matrices(hb, X, omega, tau, duals, tangents)
    else:
        A_all, xdot = _full_matrices(hb, X, omega, tau, tangents)
    eye = torch.eye(A_all.shape[-1], device=X.device, dtype=X.dtype)
    out = []
    for A, n_steps in zip(A_all.split(counts, dim=1), counts):
        hA = ((2 * math.pi / omega) / n_steps)[:, None, None, None] * A
        with single_thread():
            if slow:
                # implicit midpoint rule (I − hA/2)⁻¹(I + hA/2): A-stable, second order like
                # the exponential one, one small solve instead of an exponential per step;
                # with no stiff coordinates left it needs only twice the steps for the
                # accuracy of the exponential rule at four times them (Goland orbits)
                steps_map = torch.linalg.solve(eye - 0.5 * hA, eye + 0.5 * hA)
            else:
                # Φ = Π exp(h A(t_j+½)): exact for the part of A that is constant over a step;
                # the error (second order, Magnus) comes from A's variation along the orbit
                steps_map = torch.linalg.matrix_exp(hA)
        Phi = eye.expand_as(A[:, 0]).clone()
        for j in range(n_steps):
            Phi = steps_map[:, j] @ Phi
        out.append(Phi)
    return out, xdot


def _tangent_coefficients(hb: HarmonicBalance, X: Tensor, omega: Tensor
                          ) -> tuple[Tensor, Tensor]:
    """Coefficients (B, 4H+1, n·n) of the tangents K_n(τ), C_n(τ) along the orbit: they are
    quadratic in (q, q̇), trigonometric polynomials of degree 2H, which the 4H + 1 AFT samples
    determine exactly (so they are interpolated to any phase without error)."""
    B, n, H = X.shape[0], hb.n, hb.H
    q, v = hb.samples(X, omega)
    _, Kn, Cn = hb.nonlinear_tangents(q, v)  # (B, N, n, n) at the 4H + 1 AFT samples
    return tuple(coefficients_from_samples(T.reshape(B, -1, n * n), 2 * H) for T in (Kn, Cn))


def _full_matrices(hb: HarmonicBalance, X: Tensor, omega: Tensor, tau: Tensor,
                   tangents: tuple[Tensor, Tensor]) -> tuple[Tensor, Tensor]:
    """A(τ_j) (B, S, ns, ns) on the state [q, q̇, ξ] and ẋ(0) (its lag part left zero: the
    structural part identifies the trivial multiplier)."""
    system = hb.system
    B, n, na, H = X.shape[0], hb.n, system.n_lag, hb.H
    S = tau.shape[0]
    fine = basis_at(tau, 2 * H)  # (S, 4H + 1)
    Kc, Cc = tangents  # _tangent_coefficients
    Kn, Cn = ((fine @ c).view(B, S, n, n) for c in (Kc, Cc))
    Minv = torch.linalg.inv(hb.Mt)
    A = X.new_zeros(B, S, 2 * n + na, 2 * n + na)
    A[..., :n, n:2 * n] = torch.eye(n, device=X.device, dtype=X.dtype)
    A[..., n:2 * n, :n] = -Minv[:, None] @ (hb.Kl[:, None] + Kn)
    A[..., n:2 * n, n:2 * n] = -Minv[:, None] @ (hb.C0[:, None] + Cn)
    if na:
        A[..., n:2 * n, 2 * n:] = (-Minv @ system.lag_D)[:, None]
        A[..., 2 * n:, n:2 * n] = system.lag_E[:, None]
        A[..., 2 * n:, 2 * n:] = system.lag_R[:, None]
    dq = omega[:, None] * (hb.basis.dE[0] @ X)
    ddq = omega[:, None] ** 2 * (hb.basis.dE[0] @ (hb.basis.D @ X))
    return A, torch.cat([dq, ddq, dq.new_zeros(B, na)], dim=1)


def condensable(system: CaseSystem, omega: Tensor, duals: Tensor) -> bool:
    """Whether the dual coordinates condense onto the slow ones: the model has dual modes,
    nothing but the structure's stiffness and damping couples them (no mass coupling, no lag
    force or inflow, no added mass, damping or stiffness on their rows or columns), and the
    slowest of them is at least :data:`CONDENSE_RATIO` times above 2ω, the tangents' main
    variation (they are quadratic in the motion), in every case: the quasi-static response
    then errs by about (2ω/ω_d)² ≤ 1 %."""
    if duals.numel() == 0 or duals.numel() == system.n:
        return False
    d = duals
    for name in ("M_add", "C_add", "K_add"):
        T = getattr(system, name)
        if T is not None and (bool(T[:, d].abs().amax() > 0) or bool(T[:, :, d].abs().amax() > 0)):
            return False
    if system.n_lag and (bool(system.lag_D[:, d].abs().amax() > 0)
                         or bool(system.lag_E[..., d].abs().amax() > 0)):
        return False
    k = system.rom.kernels(system.device, system.dtype)
    lin = torch.ones(system.n, dtype=torch.bool, device=system.device)
    lin[d] = False
    # mass coupling between dual and slow rows (beyond round-off of the modal mass matrix)
    if bool(k.M[d][:, lin].abs().amax() > 1e-12 * k.M.abs().amax()):
        return False
    Kd, Md = k.K1[d][:, d].diagonal(), k.M[d][:, d].diagonal()
    slowest = torch.sqrt((Kd / Md).clamp_min(0)).min()
    return bool((slowest >= CONDENSE_RATIO * 2 * omega.abs().max()).item())


def condensed_multiplier(system: CaseSystem, X: Tensor, omega: Tensor) -> np.ndarray:
    """(B,) the largest |μ| of the dual coordinates that the monodromy condenses (0 where it
    condenses none): their own free decay over one period, exp(Re λ · T), λ the eigenvalues of
    [[0, I], [−M⁻¹K̄, −M⁻¹C̄]] on the dual block with the orbit's mean tangents K̄, C̄ (they
    are at least :data:`CONDENSE_RATIO` × 2ω, so they see the tangents' average). The slow
    state's multipliers leave these out; lightly damped dual coordinates (γ = 0: only α M)
    sit close to the unit circle, and the continuous-time system's margin is theirs."""
    duals = dual_coordinates(system)
    B = X.shape[0]
    if not condensable(system, omega, duals):
        return np.zeros(B)
    X, omega = X.to(system.device, system.dtype), omega.to(system.device, system.dtype)
    hb = HarmonicBalance(system, (X.shape[1] - 1) // 2)
    _, Kn, Cn = hb.nonlinear_tangents(*hb.samples(X, omega))
    d = duals
    K = (hb.Kl + Kn.mean(dim=1))[:, d][:, :, d]
    C = (hb.C0 + Cn.mean(dim=1))[:, d][:, :, d]
    Minv = torch.linalg.inv(hb.Mt[:, d][:, :, d])
    nd = d.numel()
    A = X.new_zeros(B, 2 * nd, 2 * nd)
    A[:, :nd, nd:] = torch.eye(nd, dtype=X.dtype, device=X.device)
    A[:, nd:, :nd] = -Minv @ K
    A[:, nd:, nd:] = -Minv @ C
    growth = torch.linalg.eigvals(A).real.amax(dim=1)
    return torch.exp(growth * 2 * math.pi / omega).cpu().numpy()


def _condensed_matrices(hb: HarmonicBalance, X: Tensor, omega: Tensor, tau: Tensor,
                        duals: Tensor, tangents: tuple[Tensor, Tensor]
                        ) -> tuple[Tensor, Tensor]:
    """A(τ_j) (B, S, ns, ns) on the slow state y = [δl, δl̇, δξ] and ẏ(0) (lag part zero, as
    :func:`_full_matrices`), the dual coordinates condensed (module docstring, *Stiff dual
    coordinates*). Their rows, K_dd δd + M_dd δd̈ + C_dd δḋ + C_dl δl̇ + K_dl δl = 0, to first
    order in the damping (δḋ ≈ d/dt(S δl) inside the damping term) and in their inertia
    (δd̈ ≈ d²/dt²(S δl), the singular-perturbation correction of the quasi-static response):

        δd = S₁ δl + P δl̇ + Q (S δl̈ + 2ω S' δl̇ + ω² S'' δl),
        S = −K_dd⁻¹ K_dl,   S₁ = S − ω K_dd⁻¹ C_dd S',   P = −K_dd⁻¹ (C_dl + C_dd S),
        Q = −K_dd⁻¹ M_dd,

    (S' = dS/dτ from K_dd S' = −(K'_dd S + K'_dl), S'' from K_dd S'' = −(K''_dd S + 2K'_dd S'
    + K''_dl), exact: the tangents are trigonometric polynomials), so the slow rows read

        (M_ll + K_ld Q S) δl̈ + (C_ll + C_ld S + K_ld P + 2ω K_ld Q S') δl̇
            + (K_ll + K_ld S₁ + ω C_ld S' + ω² K_ld Q S'') δl + D_l δξ = 0.

    K_ld P is how the dual coordinates' (Kelvin–Voigt) damping reaches the slow motion, K_ld Q S
    their inertia carried by the slow motion; the neglected terms are of order (ω/ω_d)⁴ and
    (ω C_dd K_dd⁻¹)². Measured (issue 48) against the RK4 ODE monodromy of
    tests/ode_reference.py on the Goland 9L12D orbits: without the inertia terms the trivial
    multiplier was 0.08 off at 10,000 ft, γ = 0 (0.55–0.71 at 7,000–8,500 ft), whatever the
    steps (0.079 at 512), and the γ = 1e-3, 4,000 ft critical multiplier 0.369 against the
    ODE's 0.386; with them 1.3e-3 (H = 7; 1.9e-4 on the orbit at H = 27), 0.05 and 0.006,
    and 0.387. At 4,000 ft, γ = 0 the expansion does not hold (trivial multiplier 0.75 off:
    the orbit's tangents reach the slow modes' harmonics), and the verdict stays unknown."""
    system = hb.system
    B, n, na, H = X.shape[0], hb.n, system.n_lag, hb.H
    S_ = tau.shape[0]
    mask = torch.ones(n, dtype=torch.bool, device=X.device)
    mask[duals] = False
    lin = torch.nonzero(mask).reshape(-1)
    nl = lin.numel()
    Kc, Cc = tangents  # _tangent_coefficients
    D2 = FourierBasis.build(2 * H, device=X.device, dtype=X.dtype).D  # d/dτ on 4H+1 rows
    fine = basis_at(tau, 2 * H)
    Kn, dKn, ddKn, Cn = ((fine @ c).view(B, S_, n, n) for c in (Kc, D2 @ Kc, D2 @ (D2 @ Kc),
                                                                  Cc))
    K = hb.Kl[:, None] + Kn
    C = hb.C0[:, None] + Cn

    def part(T: Tensor, rows: Tensor, cols: Tensor) -> Tensor:
        return T[..., rows, :][..., cols]

    d = duals
    w = omega[:, None, None, None]
    lu = torch.linalg.lu_factor(part(K, d, d))

    def solve_dd(rhs: Tensor) -> Tensor:
        return torch.linalg.lu_solve(*lu, rhs)

    S = -solve_dd(part(K, d, lin))
    dS = -solve_dd(part(dKn, d, d) @ S + part(dKn, d, lin))
    ddS = -solve_dd(part(ddKn, d, d) @ S + 2 * part(dKn, d, d) @ dS + part(ddKn, d, lin))
    C_dd = part(C, d, d)
    S1 = S - w * solve_dd(C_dd @ dS)
    P = -solve_dd(part(C, d, lin) + C_dd @ S)
    K_ld, C_ld = part(K, lin, d), part(C, lin, d)
    KQ = -K_ld @ solve_dd(part(hb.Mt, d, d)[:, None].expand(-1, S_, -1, -1))  # K_ld Q
    Ct = part(C, lin, lin) + C_ld @ S + K_ld @ P + 2 * w * (KQ @ dS)
    Kt = part(K, lin, lin) + K_ld @ S1 + w * (C_ld @ dS) + w ** 2 * (KQ @ ddS)
    Minv = torch.linalg.inv(part(hb.Mt, lin, lin)[:, None] + KQ @ S)
    ns = 2 * nl + na
    A = X.new_zeros(B, S_, ns, ns)
    A[..., :nl, nl:2 * nl] = torch.eye(nl, device=X.device, dtype=X.dtype)
    A[..., nl:2 * nl, :nl] = -Minv @ Kt
    A[..., nl:2 * nl, nl:2 * nl] = -Minv @ Ct
    if na:
        A[..., nl:2 * nl, 2 * nl:] = -Minv @ system.lag_D[:, None][..., lin, :]
        A[..., 2 * nl:, nl:2 * nl] = system.lag_E[:, None][..., lin]
        A[..., 2 * nl:, 2 * nl:] = system.lag_R[:, None]
    dq = omega[:, None] * (hb.basis.dE[0] @ X)  # q̇(0), q̈(0) of the orbit
    ddq = omega[:, None] ** 2 * (hb.basis.dE[0] @ (hb.basis.D @ X))
    return A, torch.cat([dq[:, lin], ddq[:, lin], dq.new_zeros(B, na)], dim=1)


def floquet(system: CaseSystem, X: Tensor, omega: Tensor, steps: int = FLOQUET_STEPS,
            tol: float = STABILITY_TOL, refine: bool = True) -> FloquetResult:
    """Floquet multipliers and stability of the orbits X (B, 2H+1, n), ω (B,) rad/s.

    The multipliers are Richardson-extrapolated from ``steps`` and ``steps``/2 steps,
    (4Φ_S − Φ_{S/2})/3: the midpoint rule's global error expands in even powers of h, so this
    removes the h² term (on the Van der Pol orbit the multiplier is then 2e-5 from Liouville's
    formula at 32 steps). A multiplier counts as resolved when the extrapolated matrix has one
    within 1e-2 of it; the others keep the plain product's value. With ``refine``, orbits whose
    critical multiplier lies within :data:`REFINE_BAND` of the unit circle are computed again
    with four times the steps (module constants)."""
    out = _floquet(system, X, omega, steps, tol)
    near = np.abs(np.abs(out.critical) - 1) < np.maximum(REFINE_BAND, 10 * out.trivial_error)
    near &= out.trivial_error <= TRIVIAL_TOL
    if refine and near.any():
        idx = np.flatnonzero(near)
        t = torch.as_tensor(idx, device=X.device)
        fine = _floquet(system.select(t), X[t], omega[t], 4 * steps, tol)
        for name in ("multipliers", "trivial", "critical", "stable", "trivial_error"):
            getattr(out, name)[idx] = getattr(fine, name)
    return out


def _floquet(system: CaseSystem, X: Tensor, omega: Tensor, steps: int, tol: float
             ) -> FloquetResult:
    """:func:`floquet` at one number of steps."""
    (Phi, Phi_half), xdot = _monodromies(system, X, omega, (steps, steps // 2))
    mu_plain, vec = torch.linalg.eig(Phi)
    mu_rich = torch.linalg.eigvals((4.0 * Phi - Phi_half) / 3.0)
    dist = (mu_plain[:, :, None] - mu_rich[:, None, :]).abs()
    nearest = dist.argmin(dim=2)
    close = dist.gather(2, nearest[..., None])[..., 0] < 1e-2 * mu_plain.abs().clamp_min(1.0)
    mu = torch.where(close, mu_rich.gather(1, nearest), mu_plain)
    n2 = Phi.shape[-1] - system.n_lag  # the structural states
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
    verdict = (crit.abs().cpu().numpy() < 1 + np.maximum(tol, error))
    stable = np.array([bool(v) if e <= TRIVIAL_TOL else None for v, e in zip(verdict, error)],
                      dtype=object)
    return FloquetResult(mu.cpu().numpy(), trivial.cpu().numpy(), crit.cpu().numpy(), stable,
                         error)
