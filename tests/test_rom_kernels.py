"""The compact monomial kernels (torchrom.rom.kernels.CompactForces) against dense einsums of the
ROM's own symmetric tensors (an independent code path), for both storages of the damping and
tangent coefficients: with ``symmetric``, upper triangles where every matrix is symmetric (a
Kelvin–Voigt Gram model: the tangent is the strain energy's Hessian, the damping the
dissipation's), full rows otherwise (random tensors with no potential), and full rows always
without it."""

from __future__ import annotations

import pytest
import torch

from torchrom.rom import NonlinearROM
from torchrom.rom.kernels import CompactForces

from .rom_fixtures import random_gram_model


def _random_rom(n=4, seed=1) -> NonlinearROM:
    """Tensors with the storage symmetries only: K2 (m, j, l) symmetric in j, l but not m, j,
    so the tangent 2K2(q,·) + 3K3(q,q,·) and the damping matrix are not symmetric."""
    g = torch.Generator().manual_seed(seed)
    kw = {"generator": g, "dtype": torch.float64}
    A = torch.randn(n, n, **kw)
    M = torch.eye(n, dtype=torch.float64) + 0.1 * A @ A.T
    K1 = torch.diag(torch.arange(1.0, n + 1, dtype=torch.float64) ** 2)
    K2 = torch.randn(n, n, n, **kw)
    K2 = 0.5 * (K2 + K2.transpose(1, 2))
    K3 = torch.randn(n, n, n, n, **kw)
    K3 = sum(K3.permute(0, *p) for p in ((1, 2, 3), (1, 3, 2), (2, 1, 3), (2, 3, 1),
                                          (3, 1, 2), (3, 2, 1))) / 6
    D3 = torch.randn(n, n, n, n, **kw)
    return NonlinearROM(M, K1, K2, K3, 0.1 * K1, torch.randn(n, n, n, **kw),
                        0.5 * (D3 + D3.transpose(1, 2)))


def _dense(rom: NonlinearROM, q, v):
    """(K2(q,q) + K3(q,q,q), 2K2(q,·) + 3K3(q,q,·), D2(q) + D3(q,q)) by einsum, (B, n[, n])."""
    force = (torch.einsum("mjl,bj,bl->bm", rom.K2, q, q)
             + torch.einsum("mjlp,bj,bl,bp->bm", rom.K3, q, q, q))
    # ∂/∂q_j of K2_mab q_a q_b + K3_mabc q_a q_b q_c (symmetric in the last indices)
    tangent = (2 * torch.einsum("mjl,bl->bmj", rom.K2, q)
               + 3 * torch.einsum("mjlp,bl,bp->bmj", rom.K3, q, q))
    damping = (torch.einsum("mln,bl->bmn", rom.D2, q)
               + torch.einsum("mlpn,bl,bp->bmn", rom.D3, q, q))
    return force, tangent, damping


@pytest.mark.parametrize("symmetric", [True, False])
def test_kernels_match_dense_tensors(symmetric):
    """Forces, tangent and damping matrices to 1e-12 of their size (rounding of sums of a few
    hundred terms), and the storage chosen by the symmetry of the coefficients."""
    rom = random_gram_model(5)[0] if symmetric else _random_rom()
    k: CompactForces = rom.kernels(symmetric=True)
    assert k.tangent_upper is symmetric and k.damping_upper is symmetric
    n2 = rom.n * (rom.n + 1) // 2
    assert k.Tc.shape[1] == (n2 if symmetric else rom.n ** 2)
    # without the request: full rows (harmonic balance's kernels)
    assert not rom.kernels().tangent_upper and rom.kernels().Tc.shape[1] == rom.n ** 2
    torch.manual_seed(0)
    q = 0.3 * torch.randn(6, rom.n, dtype=torch.float64)
    v = torch.randn(6, rom.n, dtype=torch.float64)
    force, tangent, damping = _dense(rom, q, v)

    def close(a, b):
        return float((a - b).abs().max()) <= 1e-12 * float(b.abs().max())

    f, T = k.stiffness_and_tangent(q)
    assert close(f, force) and close(T, tangent)
    assert close(k.stiffness_nl(q), force)
    assert close(k.stiffness_nl_by_tangent(q), force)  # Euler's theorem, no cubic monomials
    assert close(k.tangent_nl(q), tangent)
    assert close(k.damping_nl_matrix(q), damping)


def test_nearly_symmetric_coefficients_are_symmetrised_within_the_tolerance():
    """An asymmetry at rounding level (1e-15 of the largest coefficient, as identified ROMs
    carry) keeps the upper-triangle storage; one at 1e-6 does not."""
    rom = random_gram_model(4)[0]
    for eps, upper in ((1e-15, True), (1e-6, False)):
        K2 = rom.K2.clone()
        K2[0, 1, 2] += eps * float(rom.K2.abs().max())
        K2[0, 2, 1] = K2[0, 1, 2]  # keep the storage symmetry (last two indices)
        k = CompactForces.build(rom.M, rom.K1, K2, rom.K3, rom.D1, rom.D2, rom.D3,
                                symmetric=True)
        assert k.tangent_upper is upper
