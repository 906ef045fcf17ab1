"""Derivatives of an LCO with respect to a case parameter by the implicit-function theorem.

At a converged orbit the harmonic balance equations and the phase condition,
F(X, ω; p) = [R(X, ω; p); r·b_1] = 0, define X(p), ω(p). Differentiating,

    [∂R/∂X  ∂R/∂ω] [dX/dp]     [∂R/∂p]
    [ r·b_1    0  ] [dω/dp] = − [  0   ],

one linear solve per case with the Jacobian of :mod:`.balance`; ∂R/∂p is a central difference
of the residual between the systems at p ± δp (the parameter may enter anywhere: γ in the
damping, the α matched to it, the altitude through the atmosphere). The amplitude
A = ½ (max y − min y) of the output y = r·q then changes by
dA/dp = ½ (y'(τ_max) − y'(τ_min)) with y' = r·dq/dp at the two extremes (the extremes' own
shift does not change A to first order).
"""

from __future__ import annotations

import math

import torch

from ..sim.system import CaseSystem
from .balance import HarmonicBalance
from .fourier import basis_at, parabolic_extreme, synthesis_matrix
from .newton import equilibrated_solve

Tensor = torch.Tensor


def orbit_derivative(system: CaseSystem, plus: CaseSystem, minus: CaseSystem, dp: Tensor,
                     X: Tensor, omega: Tensor, r: Tensor) -> tuple[Tensor, Tensor]:
    """(dX/dp (B, 2H+1, n), dω/dp (B,)) of converged orbits X, ω of ``system``; ``plus`` and
    ``minus`` are the same cases at p ± dp (dp (B,))."""
    B, nh, n = X.shape
    H = (nh - 1) // 2
    R, J, R_w, _ = HarmonicBalance(system, H).jacobian(X, omega)
    R_p = (HarmonicBalance(plus, H).residual(X, omega)
           - HarmonicBalance(minus, H).residual(X, omega)) / (2 * dp[:, None, None])
    m = nh * n
    A = X.new_zeros(B, m + 1, m + 1)
    A[:, :m, :m] = J
    A[:, :m, m] = R_w.reshape(B, -1)
    A[:, m, 2 * n: 3 * n] = r
    rhs = torch.cat([-R_p.reshape(B, -1), X.new_zeros(B, 1)], dim=1)
    sol, _, _ = equilibrated_solve(A, rhs)
    return sol[:, :m].view(B, nh, n), sol[:, m]


def amplitude_derivative(system: CaseSystem, plus: CaseSystem, minus: CaseSystem, dp: Tensor,
                         X: Tensor, omega: Tensor, r: Tensor,
                         n_points: int = 512) -> tuple[Tensor, Tensor]:
    """(dA/dp, dω/dp) (B,) of the half peak-to-peak amplitude of y = r·q (module docstring)."""
    dX, dw = orbit_derivative(system, plus, minus, dp, X, omega, r)
    H = (X.shape[1] - 1) // 2
    Y, dY = X @ r, dX @ r  # (B, 2H+1)
    tau_max, tau_min = extreme_phases(Y, n_points)
    dA = 0.5 * ((basis_at(tau_max, H) * dY).sum(1) - (basis_at(tau_min, H) * dY).sum(1))
    return dA, dw


def extreme_phases(Y: Tensor, n_points: int = 512) -> tuple[Tensor, Tensor]:
    """(τ_max, τ_min) (B,) of y(τ) with coefficients Y (B, 2H+1): the best of ``n_points``
    samples refined by a parabola (error ~Δτ³ on a smooth orbit)."""
    H = (Y.shape[1] - 1) // 2
    E = synthesis_matrix(H, n_points, Y.device, Y.dtype)
    y = (E @ Y[..., None])[..., 0]
    step = 2 * math.pi / y.shape[1]
    return parabolic_extreme(y, 1.0)[0] * step, parabolic_extreme(y, -1.0)[0] * step
