"""Exact (intrusive) reference ROM of the built-in FE, to verify the non-intrusive identification.

The reduced internal force g(q) = Φᵀ f(Φq) of a St Venant–Kirchhoff FE is a cubic polynomial in q,
so its Taylor coefficients at q = 0 are the ROM stiffness tensors (symmetric storage, Eq. 14):

    K1 = ∂g/∂q,   K2_mnl = ½ ∂²g_m/∂q_n∂q_l,   K3_mnlp = ⅙ ∂³g_m/∂q_n∂q_l∂q_p.

They are computed by forward-mode automatic differentiation (``torch.func.jacfwd``, nested, with
``vmap`` over the basis directions) of the FE's differentiable internal force
``fe.internal_force_torch(u)`` — no fitting, no amplitude. Likewise the Kelvin–Voigt damping
tensors from the differentiable material force ``fe.material_force_torch(u, v)`` = K_mat(u) v:
D_T(q) = Φᵀ K_mat(Φq) Φ, D̄1 = D_T(0), D̄2[m, l, n] = ∂D_T[m, n]/∂q_l, D̄3[m, l, p, n] =
½ ∂²D_T[m, n]/∂q_l∂q_p. Delegated: automatic differentiation (torch.func).
"""

from __future__ import annotations

import numpy as np
import torch
from torch.func import jacfwd

from ..rom import NonlinearROM


def _reduced_force(fe, Phi: torch.Tensor):
    def g(q):
        return Phi.T @ fe.internal_force_torch(Phi @ q)

    return g


def intrusive_stiffness(fe, Phi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K1, K2, K3) of Φᵀ f(Φq) by nested forward-mode differentiation at q = 0."""
    P = torch.as_tensor(np.asarray(Phi, float))
    n = P.shape[1]
    g = _reduced_force(fe, P)
    q0 = torch.zeros(n, dtype=torch.float64)
    K1 = jacfwd(g)(q0)
    H = jacfwd(jacfwd(g))(q0)                  # H[m, a, b]
    T = jacfwd(jacfwd(jacfwd(g)))(q0)          # T[m, a, b, c]
    return K1.numpy(), (0.5 * H).numpy(), (T / 6.0).numpy()


def intrusive_damping(fe, Phi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(D̄1, D̄2, D̄3) of Φᵀ K_mat(Φq) Φ at γ = 1 by forward-mode differentiation at q = 0."""
    P = torch.as_tensor(np.asarray(Phi, float))
    n = P.shape[1]

    def DT(q):
        # columns K_mat(Φq) Φ e_n, projected: (m, n)
        cols = torch.func.vmap(lambda v: P.T @ fe.material_force_torch(P @ q, v),
                               in_dims=1, out_dims=1)(P)
        return cols

    q0 = torch.zeros(n, dtype=torch.float64)
    D1 = DT(q0)
    J = jacfwd(DT)(q0)                         # J[m, n, l]
    Hd = jacfwd(jacfwd(DT))(q0)                # Hd[m, n, l, p]
    D2 = torch.einsum("mnl->mln", J)
    D3 = 0.5 * torch.einsum("mnlp->mlpn", Hd)
    return D1.numpy(), D2.numpy(), D3.numpy()


def intrusive_rom(fe, Phi: np.ndarray, damping: bool = True, **kw) -> NonlinearROM:
    """The intrusive reference :class:`NonlinearROM` on the basis Φ (mass Φᵀ M Φ)."""
    K1, K2, K3 = intrusive_stiffness(fe, Phi)
    D = intrusive_damping(fe, Phi) if damping else (None, None, None)
    M = Phi.T @ np.asarray(fe.mass_matrix() @ Phi)
    return NonlinearROM(M, K1, K2, K3, *D, symmetrize=True, **kw)
