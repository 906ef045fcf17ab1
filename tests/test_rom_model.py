"""NonlinearROM: validation errors, batched forces and tangents, the two-mode exact system."""

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.rom import NonlinearROM

from .rom_fixtures import random_gram_model, touze_force, touze_two_mode


def test_touze_forces_and_dissipation():
    """REFERENCE Sec. 5: the ROM from exact tensors reproduces f and q̇ᵀD_T q̇ ≥ 0."""
    rom = touze_two_mode()
    g = torch.Generator().manual_seed(0)
    q = 0.8 * torch.randn(200, 2, generator=g, dtype=torch.float64)
    qd = torch.randn(200, 2, generator=g, dtype=torch.float64)
    f = rom.stiffness_force(q)
    f1, f2 = touze_force(q[:, 0], q[:, 1])
    # a cubic polynomial evaluated two ways: agreement to rounding (1e-13 of the force scale)
    assert torch.allclose(f, torch.stack([f1, f2], 1), rtol=1e-13, atol=1e-13)
    # Kelvin–Voigt dashpot ω_k² on ė_k, e_k = q_k + r/2: power = Σ ω_k² ė_k²
    rdot = 2 * (q * qd).sum(1)
    ed = qd + 0.5 * rdot[:, None]
    w2 = torch.tensor([1.13**2, 4.0], dtype=torch.float64)
    expected = (w2 * ed**2).sum(1)
    P = rom.dissipated_power(q, qd)
    assert torch.allclose(P, expected, rtol=1e-12)
    assert (P >= 0).all()


def test_force_matches_dense_einsum_and_flags():
    n = 5
    rom, _, _ = random_gram_model(n, seed=4)
    g = torch.Generator().manual_seed(2)
    B = 7
    q = torch.randn(B, n, generator=g, dtype=torch.float64)
    qd = torch.randn(B, n, generator=g, dtype=torch.float64)
    alpha = torch.rand(B, generator=g, dtype=torch.float64)
    gamma = torch.rand(B, generator=g, dtype=torch.float64)
    snl = torch.tensor([1, 0, 1, 0, 1, 1, 0], dtype=torch.bool)
    dnl = torch.tensor([1, 1, 0, 0, 1, 0, 1], dtype=torch.bool)
    f = rom.force(q, qd, alpha, gamma, snl, dnl)
    ein = torch.einsum
    fK2 = ein("mnl,bn,bl->bm", rom.K2, q, q)
    fK3 = ein("mnlp,bn,bl,bp->bm", rom.K3, q, q, q)
    fD2 = ein("mln,bl,bn->bm", rom.D2, q, qd)
    fD3 = ein("mlpn,bl,bp,bn->bm", rom.D3, q, q, qd)
    s, d = snl[:, None].double(), dnl[:, None].double()
    expect = (q @ rom.K1.T + s * (fK2 + fK3) + alpha[:, None] * (qd @ rom.M.T)
              + gamma[:, None] * (qd @ rom.D1.T + d * (fD2 + fD3)))
    assert torch.allclose(f, expect, rtol=1e-12, atol=1e-12)
    # single state in -> single state out
    f0 = rom.force(q[0], qd[0], float(alpha[0]), float(gamma[0]))
    assert f0.shape == (n,)


def test_tangents_match_autograd():
    n = 4
    rom, _, _ = random_gram_model(n, seed=8)
    g = torch.Generator().manual_seed(5)
    q = torch.randn(n, generator=g, dtype=torch.float64)
    qd = torch.randn(n, generator=g, dtype=torch.float64)
    a, gam = 0.3, 0.7
    Kt, Ct = rom.tangents(q, qd, a, gam)
    Jq = torch.autograd.functional.jacobian(lambda x: rom.force(x, qd, a, gam), q)
    Jv = torch.autograd.functional.jacobian(lambda v: rom.force(q, v, a, gam), qd)
    assert torch.allclose(Kt, Jq, rtol=1e-12, atol=1e-12)
    assert torch.allclose(Ct, Jv, rtol=1e-12, atol=1e-12)


def test_float32_kernels_agree():
    rom, _, _ = random_gram_model(6, seed=1)
    g = torch.Generator().manual_seed(9)
    q = 0.3 * torch.randn(16, 6, generator=g, dtype=torch.float64)
    qd = torch.randn(16, 6, generator=g, dtype=torch.float64)
    f64 = rom.force(q, qd, 0.1, 0.2)
    f32 = rom.force(q.float(), qd.float(), 0.1, 0.2)
    assert f32.dtype == torch.float32
    # float32 carries ~7 digits; sums of ~100 terms lose one more
    assert torch.allclose(f32.double(), f64, rtol=1e-5, atol=1e-5 * f64.abs().max())


def test_linear_frequencies():
    K = torch.diag(torch.tensor([4.0, 9.0], dtype=torch.float64)) * (2 * np.pi) ** 2
    rom = NonlinearROM(torch.eye(2, dtype=torch.float64), K)
    assert np.allclose(rom.linear_frequencies_hz(), [2.0, 3.0], rtol=1e-12)
    assert np.allclose(rom.frequencies_hz, [2.0, 3.0], rtol=1e-12)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"K2": torch.ones(2, 2, 3)}, r"K2: expected shape \(2, 2, 2\)"),
        ({"K3": torch.arange(16.0).reshape(2, 2, 2, 2)}, "K3: not symmetric in its last three"),
        ({"K1": torch.tensor([[1.0, 2.0], [0.0, 1.0]])}, "K1: not symmetric"),
        ({"D3": torch.arange(16.0).reshape(2, 2, 2, 2)}, "D3: not symmetric in its middle two"),
        ({"K1": torch.tensor([[1.0, float("nan")], [float("nan"), 1.0]])}, "K1: 2 entries"),
        ({"M": -torch.eye(2)}, "M: not positive definite"),
        ({"mode_kinds": ["linear"]}, "mode_kinds: expected 2"),
        ({"outputs": {"A_Tz": [1.0, 2.0, 3.0]}}, r"outputs\['A_Tz'\]"),
    ],
)
def test_validation_errors(kwargs, match):
    args = {"M": torch.eye(2), "K1": torch.eye(2)}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        NonlinearROM(**args)


def test_symmetrize_option_accepts_small_asymmetry():
    K2 = torch.zeros(2, 2, 2, dtype=torch.float64)
    K2[0, 0, 1] = 1.0
    with pytest.raises(InputError):
        NonlinearROM(torch.eye(2), torch.eye(2), K2=K2)
    rom = NonlinearROM(torch.eye(2), torch.eye(2), K2=K2, symmetrize=True)
    assert rom.K2[0, 1, 0] == 0.5


def test_content_hash_changes_with_tensors():
    rom, _, _ = random_gram_model(3, seed=0)
    other = rom.replace(K1=rom.K1 * 1.0000001)
    assert rom.content_hash() != other.content_hash()
    assert rom.content_hash() == rom.replace().content_hash()
