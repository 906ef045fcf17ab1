"""Test ROMs with known structure, shared by the ROM and simulator tests.

- :func:`random_gram_model`: a random Kelvin–Voigt "strain" model E(q) = e q + h(q, q) with a
  positive definite material matrix C, so that W = ½ EᵀCE and R = ½ ĖᵀCĖ are known exactly and
  forces can be checked by automatic differentiation, independently of the convention formulas.
- :func:`touze_two_mode`: REFERENCE Sec. 5 (Touzé; NLvib example 06), exact polynomial forces.
"""

from __future__ import annotations

import torch

from torchrom.rom import NonlinearROM, analytic


def random_gram_model(n: int, r: int | None = None, seed: int = 0):
    """Return (rom, strain) where strain(q) -> (r,) and C is the (r, r) material matrix."""
    g = torch.Generator().manual_seed(seed)
    r = r or 3 * n + 5
    e = torch.randn(r, n, generator=g, dtype=torch.float64)
    h = torch.randn(r, n, n, generator=g, dtype=torch.float64)
    h = 0.5 * (h + h.transpose(1, 2))
    A = torch.randn(r, r, generator=g, dtype=torch.float64)
    C = A @ A.T / r + 0.1 * torch.eye(r, dtype=torch.float64)
    K1 = e.T @ C @ e
    G = torch.einsum("am,ab,bnl->mnl", e, C, h)
    H = torch.einsum("ams,ab,bnl->msnl", h, C, h)
    Mm = torch.randn(n, n, generator=g, dtype=torch.float64)
    M = Mm @ Mm.T / n + torch.eye(n, dtype=torch.float64)
    rom = NonlinearROM.from_gram(M, K1, G, H)

    def strain(q):
        return e @ q + torch.einsum("anl,n,l->a", h, q, q)

    return rom, strain, C


def touze_two_mode(eta: float = 0.0, w1: float = 1.13, w2: float = 2.0) -> NonlinearROM:
    """REFERENCE Sec. 5 (built into :mod:`torchrom.rom.analytic`); η is the per-case γ."""
    del eta  # the ROM stores γ = 1 tensors
    return analytic.touze_two_mode(w1, w2)


def touze_force(q1, q2, w1: float = 1.13, w2: float = 2.0):
    """REFERENCE Sec. 5 internal forces, written out as printed there."""
    a, b = w1**2, w2**2
    f1 = a * q1 + 1.5 * a * q1**2 + b * q1 * q2 + 0.5 * a * q2**2 + 0.5 * (a + b) * (
        q1**3 + q1 * q2**2)
    f2 = b * q2 + 0.5 * b * q1**2 + a * q1 * q2 + 1.5 * b * q2**2 + 0.5 * (a + b) * (
        q1**2 * q2 + q2**3)
    return f1, f2
