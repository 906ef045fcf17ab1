"""Harmonic balance residual and analytic Jacobian (torchrom.periodic.balance) and the ROM's
damping-force tangent kernel."""

from __future__ import annotations

import numpy as np
import torch

from torchrom.periodic.balance import HarmonicBalance
from torchrom.rom import NonlinearROM
from torchrom.sim import CaseSystem


def _random_rom(n=3, seed=0) -> NonlinearROM:
    g = torch.Generator().manual_seed(seed)
    A = torch.randn(n, n, generator=g, dtype=torch.float64)
    M = torch.eye(n, dtype=torch.float64) + 0.1 * (A @ A.T) / n
    K1 = torch.diag(torch.tensor([4.0, 9.0, 30.0], dtype=torch.float64)[:n])
    K2 = torch.randn(n, n, n, generator=g, dtype=torch.float64)
    K2 = 0.5 * (K2 + K2.transpose(1, 2))
    K3 = torch.randn(n, n, n, n, generator=g, dtype=torch.float64)
    K3 = sum(K3.permute(0, *p) for p in ((1, 2, 3), (1, 3, 2), (2, 1, 3), (2, 3, 1),
                                          (3, 1, 2), (3, 2, 1))) / 6
    D2 = torch.randn(n, n, n, generator=g, dtype=torch.float64)
    D3 = torch.randn(n, n, n, n, generator=g, dtype=torch.float64)
    D3 = 0.5 * (D3 + D3.transpose(1, 2))
    return NonlinearROM(M, K1, K2, K3, 0.1 * K1, D2, D3)


def _system(rom, B=2, na=2, seed=3):
    g = torch.Generator().manual_seed(seed)
    n = rom.n
    kw = {"generator": g, "dtype": torch.float64}
    return CaseSystem.build(rom, B, alpha=[0.1, 0.2][:B], gamma=[1.0, 0.5][:B],
                            stiffness_nl=[1.0, 0.7][:B], damping_nl=[1.0, 0.3][:B],
                            M_add=0.1 * torch.eye(n, dtype=torch.float64).expand(B, n, n),
                            C_add=0.05 * torch.randn(B, n, n, **kw),
                            K_add=0.5 * torch.randn(B, n, n, **kw),
                            lag_D=torch.randn(B, n, na, **kw), lag_E=torch.randn(B, na, n, **kw),
                            lag_R=-torch.eye(na, dtype=torch.float64) - torch.rand(B, na, na, **kw),
                            load=torch.randn(B, n, **kw))


def test_damping_force_tangent_matches_the_full_tensor_derivative():
    """The compact kernel's ∂(D_nl(q) q̇)/∂q against NonlinearROM.tangents (full D2/D3
    einsums, an independent code path): tangents minus the stiffness part."""
    rom = _random_rom()
    torch.manual_seed(0)
    q = torch.randn(5, rom.n, dtype=torch.float64)
    v = torch.randn(5, rom.n, dtype=torch.float64)
    k = rom.kernels()
    Kt, _ = rom.tangents(q, v, gamma=1.0, stiffness_nl=0.0)
    expected = Kt - k.K1
    assert torch.allclose(k.damping_force_tangent(q, v), expected, atol=1e-12, rtol=1e-12)


def test_jacobian_matches_central_differences():
    """∂R/∂X, ∂R/∂ω and ∂R/∂c against central differences (step 1e-6: truncation ~1e-12,
    rounding ~1e-10 of the entries; tolerance 1e-7 of the largest entry)."""
    rom = _random_rom()
    system = _system(rom)
    hb = HarmonicBalance(system, 3)
    torch.manual_seed(2)
    X = 0.3 * torch.randn(2, hb.nh, rom.n, dtype=torch.float64)
    w = torch.tensor([6.0, 7.0], dtype=torch.float64)
    c = torch.tensor([0.1, -0.2], dtype=torch.float64)
    R, J, R_w, R_c = hb.jacobian(X, w, c)
    assert torch.allclose(R, hb.residual(X, w, c))
    eps = 1e-6
    J_fd = torch.zeros_like(J)
    for j in range(hb.nh * rom.n):
        d = torch.zeros(2, hb.nh * rom.n, dtype=torch.float64)
        d[:, j] = eps
        d = d.view_as(X)
        J_fd[:, :, j] = ((hb.residual(X + d, w, c) - hb.residual(X - d, w, c)) / (2 * eps)
                         ).reshape(2, -1)
    scale = J.abs().max()
    assert (J - J_fd).abs().max() <= 1e-7 * scale
    Rw_fd = (hb.residual(X, w + eps, c) - hb.residual(X, w - eps, c)) / (2 * eps)
    Rc_fd = (hb.residual(X, w, c + eps) - hb.residual(X, w, c - eps)) / (2 * eps)
    assert (R_w - Rw_fd).abs().max() <= 1e-7 * scale
    assert (R_c - Rc_fd).abs().max() <= 1e-7 * scale


def test_linear_blocks_equal_the_state_space_transfer():
    """Z_k(ω) q̂ of a linear case equals the force the first-order system needs for the
    harmonic motion q̂ e^{ikωt} (lag states solved from ξ̇ = E q̇ + R ξ), i.e. the lag states
    drop out exactly per harmonic."""
    rom = _random_rom()
    system = _system(rom, B=1)
    hb = HarmonicBalance(system, 2)
    w = torch.tensor([5.0], dtype=torch.float64)
    Z = hb.linear_blocks(w).Z[0, 1]  # k = 2
    s = 2j * 5.0
    M = (system.rom.M + system.M_add[0]).numpy()
    C = (0.1 * system.rom.M + 1.0 * system.rom.D1 + system.C_add[0]).numpy()
    K = (system.rom.K1 + system.K_add[0]).numpy()
    D, E, R = (t[0].numpy() for t in (system.lag_D, system.lag_E, system.lag_R))
    expected = s**2 * M + s * C + K + D @ np.linalg.solve(s * np.eye(2) - R, E * s)
    assert np.allclose(Z.numpy(), expected, rtol=1e-12, atol=1e-12)


def test_residual_options_give_the_same_residual():
    """The residual with the stiffness force by Euler's theorem (the Fourier certificate's)
    equals the monomial one to rounding (1e-13 of the largest entry: sums of a few hundred
    terms), and with the linear blocks passed in (computed without their ω-derivative) equals
    the plain residual exactly; the blocks' Z does not depend on that option."""
    rom = _random_rom()
    system = _system(rom)
    torch.manual_seed(4)
    hb = HarmonicBalance(system, 4)
    X = 0.3 * torch.randn(2, hb.nh, rom.n, dtype=torch.float64)
    w = torch.tensor([6.0, 7.0], dtype=torch.float64)
    R = hb.residual(X, w)
    euler = HarmonicBalance(system, 4, stiffness_by_tangent=True).residual(X, w)
    assert (euler - R).abs().max() <= 1e-13 * R.abs().max()
    blocks = hb.linear_blocks(w, derivative=False)
    assert blocks.dZ_domega is None
    assert torch.equal(blocks.Z, hb.linear_blocks(w).Z)
    assert torch.equal(hb.residual(X, w, blocks=blocks), R)
