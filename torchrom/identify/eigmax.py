"""Batched maximisation of the smallest eigenvalue of small affine symmetric matrix families.

For each of B problems, maximise t − ρ‖x‖² subject to S(x) − t I ⪰ 0 with
S(x) = F0 + Σ_j x_j F_j (k × k, p parameters): a small semidefinite program (λ_min is concave in
x, so its optimum is global). Solved by a primal log-barrier path-following method (Nesterov &
Nemirovski 1994; Boyd & Vandenberghe, *Convex Optimization*, Sec. 11.3): maximise
ψ_μ = t − ρ‖x‖² + μ log det(S(x) − t I) by damped Newton steps for a decreasing μ, all problems
at once with batched Cholesky factorisations (no eigen-decomposition per step). At the end of
the path the central point is within k·μ_end of the optimum (duality gap of the barrier).

The optimum decomposition's subset stages (:mod:`.damping`) use it: thousands of 5 × 5 to
14 × 14 problems with 2–5 parameters each.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class BarrierOptions:
    """mu_start, mu_end: barrier weight at the start and end of the path (units of the matrix
    entries; the optimum is within k·mu_end); mu_factor: its reduction per level;
    newton_per_level: Newton steps per level (a full step from the previous centre is enough
    for a reduction of 10 on a self-concordant barrier; 4 leave margin); penalty: ρ."""

    mu_start: float = 0.1
    mu_end: float = 1e-10
    mu_factor: float = 0.05
    newton_per_level: int = 4
    penalty: float = 1e-6


@dataclass
class BarrierResult:
    x: torch.Tensor        # (B, p) the parameters
    t: torch.Tensor        # (B,) the barrier's lower bound on λ_min at x
    min_eigenvalue: torch.Tensor  # (B,) λ_min(S(x)), computed at the end
    newton_steps: int


def _slack(F0, F, x, t):
    """S(x) − t I, batched (the parameters enter through one batched matrix product)."""
    B, p, k = F.shape[0], F.shape[1], F0.shape[-1]
    S = F0 + torch.bmm(x[:, None, :], F.reshape(B, p, k * k)).reshape(B, k, k)
    return S - t[:, None, None] * torch.eye(k, dtype=F0.dtype)


def maximise_min_eigenvalue(F0: torch.Tensor, F: torch.Tensor,
                            options: BarrierOptions | None = None) -> BarrierResult:
    """Maximise λ_min(F0 + Σ_j x_j F_j) − ρ‖x‖² for each of B problems.

    Args:
        F0: (B, k, k) symmetric; F: (B, p, k, k) symmetric directions (zero ones allowed when
            ρ > 0).
    Returns:
        :class:`BarrierResult`. The steps are the damped Newton steps of self-concordance
        theory (step 1/(1 + δ) for a Newton decrement δ of ψ/μ above 1/4, full below), which
        stay strictly feasible without a line search.
    """
    opt = options or BarrierOptions()
    B, p, k = F.shape[0], F.shape[1], F0.shape[-1]
    dtype = F0.dtype
    eye = torch.eye(k, dtype=dtype)
    rho = opt.penalty
    x = torch.zeros(B, p, dtype=dtype)
    # strictly feasible start: one below the smallest eigenvalue
    t = torch.linalg.eigvalsh(F0)[:, 0] - 1.0
    mu = opt.mu_start
    steps = 0
    # directions (F_1..F_p, −I) of the p + 1 variables (x, t)
    G = torch.cat([F, -eye.expand(B, 1, k, k)], dim=1)
    q = p + 1
    Gcat = G.transpose(1, 2).reshape(B, k, q * k)
    ridge = torch.zeros(p + 1, dtype=dtype)
    ridge[:p] = 2.0 * rho
    L, info = torch.linalg.cholesky_ex(_slack(F0, F, x, t))
    while True:
        for _ in range(opt.newton_per_level):
            Y = torch.cholesky_inverse(L)                       # (S − tI)⁻¹
            # Y G_a for every direction a, as one batched product Y [G_1 | G_2 | ...]
            YG = torch.bmm(Y, Gcat).reshape(B, k, q, k).transpose(1, 2)   # (B, q, k, k)
            grad = mu * torch.diagonal(YG, dim1=-2, dim2=-1).sum(-1)
            grad[:, :p] -= 2.0 * rho * x
            grad[:, p] += 1.0
            # −Hessian: μ tr(Y G_a Y G_b) + 2ρ δ_ab (x only): positive definite
            YG = YG.contiguous()
            GY = YG.transpose(-1, -2).contiguous()              # (Y G_a)ᵀ = G_a Y
            H = mu * torch.bmm(YG.reshape(B, q, k * k), GY.reshape(B, q, k * k).transpose(1, 2)) \
                + torch.diag(ridge)
            d = torch.linalg.solve(H, grad[..., None])[..., 0]
            delta = ((grad * d).sum(-1) / mu).clamp_min(0.0).sqrt()  # decrement of ψ/μ
            alpha = torch.where(delta < 0.25, torch.ones_like(delta), 1.0 / (1.0 + delta))
            xn = x + alpha[:, None] * d[:, :p]
            tn = t + alpha * d[:, p]
            Ln, info = torch.linalg.cholesky_ex(_slack(F0, F, xn, tn))
            # the damped step stays inside the Dikin ellipsoid, hence feasible, in exact
            # arithmetic; a problem whose step rounding pushed out keeps its iterate
            ok = info == 0
            x = torch.where(ok[:, None], xn, x)
            t = torch.where(ok, tn, t)
            L = torch.where(ok[:, None, None], Ln, L)
            steps += 1
        if mu <= opt.mu_end:
            break
        mu = max(mu * opt.mu_factor, opt.mu_end)
    S = F0 + torch.bmm(x[:, None, :], F.reshape(B, p, k * k)).reshape(B, k, k)
    return BarrierResult(x, t, torch.linalg.eigvalsh(S)[:, 0], steps)
