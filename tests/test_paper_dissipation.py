"""torchrom.paper.dissipation: the cycle-mean dissipation ratio and the scaled eigenvalue."""

import math

import numpy as np
import pytest
import torch

from torchrom.paper.dissipation import dissipation_ratio, scaled_min_eigenvalue
from torchrom.rom import NonlinearROM


def test_dissipation_ratio_single_mode_closed_form():
    """One mode, D(q) = k + h q² (D̄1 = k, D̄3 = h): on q = a sin ωt over whole periods
    ⟨h q² q̇²⟩ / ⟨k q̇²⟩ = (h a⁴ω²/8) / (k a²ω²/2) = h a² / (4k). 2,000 samples per period of
    a trapezoid-free mean over exactly 3 periods: the discrete means are exact for these
    trigonometric polynomials up to rounding (1e-12)."""
    k, h, a, w = 4.0, 3.0, 0.7, 2 * math.pi * 1.3
    rom = NonlinearROM(torch.eye(1), torch.tensor([[k]]), D3=torch.full((1, 1, 1, 1), h))
    t = np.arange(6000) * (3 / 1.3) / 6000
    q = (a * np.sin(w * t))[:, None]
    qd = (a * w * np.cos(w * t))[:, None]
    assert dissipation_ratio(rom, q, qd) == pytest.approx(h * a * a / (4 * k), rel=1e-12)


def test_dissipation_ratio_zero_without_nonlinear_damping():
    rom = NonlinearROM(torch.eye(2), torch.diag(torch.tensor([1.0, 9.0])))
    rng = np.random.default_rng(0)
    q, qd = rng.normal(size=(50, 2)), rng.normal(size=(50, 2))
    assert dissipation_ratio(rom, q, qd) == 0.0


def test_scaled_min_eigenvalue_sign():
    """A Gram-matrix energy form (PSD by construction) gives λ_min ≥ 0 (rounding: −1e-12); the
    same ROM with the pair block of H flipped is indefinite."""
    rng = np.random.default_rng(1)
    n = 2
    # strains of 6 "elements": e (6, n) linear, h (6, n, n) quadratic; K_E = Σ [e; h]ᵀ[e; h]
    e = rng.normal(size=(6, n))
    hq = rng.normal(size=(6, n, n))
    hq = 0.5 * (hq + hq.transpose(0, 2, 1))
    K1 = e.T @ e
    G = np.einsum("em,eij->mij", e, hq)
    H = np.einsum("eij,ekl->ijkl", hq, hq)
    rom = NonlinearROM.from_gram(torch.eye(n), torch.as_tensor(K1), torch.as_tensor(G),
                                 torch.as_tensor(H))
    assert scaled_min_eigenvalue(rom) >= -1e-12
    bad = NonlinearROM.from_gram(torch.eye(n), torch.as_tensor(K1), torch.as_tensor(G),
                                 torch.as_tensor(-H))
    assert scaled_min_eigenvalue(bad) < -1e-3
