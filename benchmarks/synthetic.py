"""A synthetic Goland-like aeroelastic ROM for benchmarks (hand-written, seeded).

21 basis functions: 9 "linear" (bending/torsion-like, the heavy Goland frequencies of the paper's
Table 2) and 12 "dual" (in-plane, 40–400 Hz). Stiffness and damping come from an energy (Gram)
form — strains E(q) = e q + h(q, q) with an identity material matrix — so K2/K3 are energy
consistent and D̄1..D̄3 are exact Kelvin–Voigt tensors (D̄1 = K1). The quadratic strains of the
linear modes lie mostly in the strain directions of the dual modes, as membrane stretching of a
bending plate does, so the dual modes are driven quasi-statically by the linear ones.

13 first-order lag states act on the 9 linear modes like a minimum-state rational function
approximation (Eqs. 49–50): per case, K_add = q A0, C_add = q A1, lag_D = q D0, lag_E = E0,
lag_R = R0 with the dynamic-pressure-like scale q. D0 E0 is negative semi-definite, so the lags
feed energy into the structure; above q ≈ 0.4 mode 1 loses its damping ("flutter") and the
Kelvin–Voigt cubic damping saturates the growth into an LCO.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from torchrom.rom import NonlinearROM
from torchrom.sim import CaseSystem

LINEAR_HZ = [1.690, 3.051, 9.172, 10.834, 11.258, 16.260, 22.845, 26.318, 29.183]
N_LINEAR, N_DUAL, N_LAG = 9, 12, 13


def synthetic_rom(seed: int = 0) -> NonlinearROM:
    rng = np.random.default_rng(seed)
    n = N_LINEAR + N_DUAL
    freqs = np.r_[LINEAR_HZ, np.geomspace(40.0, 400.0, N_DUAL)]
    w = 2 * math.pi * freqs
    r = 3 * n + 5
    U, _ = np.linalg.qr(rng.standard_normal((r, n)))  # orthonormal strain directions
    e = U * w  # K1 = eᵀe = diag(ω²)
    h = 0.3 * rng.standard_normal((r, n, n))
    lin = slice(0, N_LINEAR)
    # membrane coupling: linear-linear quadratic strains along the dual modes' strain directions
    coupling = rng.standard_normal((N_DUAL, N_LINEAR, N_LINEAR))
    h[:, lin, lin] += 40.0 * np.einsum("rd,dij->rij", U[:, N_LINEAR:], coupling)
    h = 0.5 * (h + h.transpose(0, 2, 1))
    K1 = e.T @ e
    G = np.einsum("am,anl->mnl", e, h)
    H = np.einsum("ams,anl->msnl", h, h)
    tip = np.zeros(n)
    tip[:N_LINEAR] = [1.0, 0.35, 0.2, 0.15, 0.02, 0.1, 0.08, 0.05, 0.04]
    return NonlinearROM.from_gram(
        np.eye(n), K1, G, H, mode_kinds=["linear"] * N_LINEAR + ["dual"] * N_DUAL,
        frequencies_hz=freqs, outputs={"A_Tz": tip},
        metadata={"model": "synthetic Goland-like benchmark ROM", "seed": seed})


def aero_like_matrices(seed: int = 0) -> dict[str, np.ndarray]:
    """Per-unit-q matrices A0, A1, D0, E0 and R0 on the first 9 modes, zero-padded to 21."""
    rng = np.random.default_rng(seed + 1)
    n, m, na = N_LINEAR + N_DUAL, N_LINEAR, N_LAG
    A0 = np.zeros((n, n))
    S = rng.standard_normal((m, m))
    A0[:m, :m] = 2.0 * (S + S.T)
    A0[0, 1], A0[1, 0] = 15.0, -15.0  # circulatory (non-symmetric) coupling of modes 1 and 2
    A1 = np.zeros((n, n))
    A1[:m, :m] = np.diag(np.linspace(0.05, 0.5, m))
    E0 = np.zeros((na, n))
    E0[:, :m] = rng.standard_normal((na, m)) / math.sqrt(na)
    E0[:, 0] *= 3.0  # mode 1 drives the lags most
    D0 = -2.4 * E0.T  # D0 E0 ⪯ 0: the lags pump energy in (flutter near q = 0.4)
    R0 = -np.diag(np.geomspace(0.8, 40.0, na))
    return {"A0": A0, "A1": A1, "D0": D0, "E0": E0, "R0": R0}


def synthetic_cases(rom: NonlinearROM, qbar: np.ndarray, *, gamma: float = 1e-3,
                    alpha: float = 0.02, device=None, dtype=torch.float64,
                    seed: int = 0) -> CaseSystem:
    """B cases at the dynamic-pressure scales ``qbar`` (B,)."""
    a = aero_like_matrices(seed)
    qb = torch.as_tensor(np.asarray(qbar, dtype=float)).view(-1, 1, 1)
    B = qb.shape[0]

    def t(x):
        return torch.as_tensor(x, dtype=torch.float64)

    return CaseSystem.build(
        rom, B, alpha=alpha, gamma=gamma, K_add=qb * t(a["A0"]), C_add=qb * t(a["A1"]),
        lag_D=qb * t(a["D0"]), lag_E=t(a["E0"]).expand(B, -1, -1),
        lag_R=t(a["R0"]).expand(B, -1, -1), device=device, dtype=dtype)
