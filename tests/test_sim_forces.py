"""The integrator's force kernel against the ROM's own batched forces (independent einsum path
in tests/test_rom_model.py) for every storage path: small/blocked stiffness, symmetric/full
damping, sparse analytic ROMs, float32."""

import pytest
import torch

from torchrom.rom import NonlinearROM
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.sim.forces import (
    BLOCKED_MIN_BATCH,
    BLOCKED_MIN_N,
    SYMMETRIC_MIN_N,
    NonlinearForces,
)

from .rom_fixtures import random_gram_model


def _nonlinear_reference(rom, q, v, s, g):
    """Eq. 54 minus its linear part, from NonlinearROM.force."""
    full = rom.force(q, v, 0.0, g, stiffness_nl=s, damping_nl=1.0)
    return full - q @ rom.K1.T - g[:, None] * (v @ rom.D1.T)


def _random_states(n, B=11, seed=3, dtype=torch.float64):
    g = torch.Generator().manual_seed(seed)
    q = torch.randn(B, n, generator=g, dtype=dtype)
    v = torch.randn(B, n, generator=g, dtype=dtype)
    s = torch.rand(B, generator=g, dtype=dtype)
    gam = torch.rand(B, generator=g, dtype=dtype)
    return q, v, s, gam


@pytest.mark.parametrize("batch", [11, BLOCKED_MIN_BATCH], ids=["gathered", "blocked"])
@pytest.mark.parametrize("n", [1, 2, SYMMETRIC_MIN_N, BLOCKED_MIN_N, 11])
def test_kelvin_voigt_rom_forces(n, batch):
    """Both cubic-stiffness paths (gathered monomials for small batches, block GEMMs from
    BLOCKED_MIN_BATCH cases on for n >= BLOCKED_MIN_N) against the einsum reference."""
    rom, _, _ = random_gram_model(n, seed=n)
    forces = NonlinearForces(rom)
    assert forces.blocked == (n >= BLOCKED_MIN_N)
    assert forces.symmetric_damping  # Kelvin–Voigt: the damping matrix is a Hessian
    q, v, s, g = _random_states(n, B=batch)
    got = forces(q, v, s[None], g[None])
    ref = _nonlinear_reference(rom, q, v, s, g)
    # two summation orders of the same polynomial: agreement to rounding of the force scale
    assert torch.allclose(got, ref, rtol=0, atol=1e-13 * ref.abs().max())


@pytest.mark.parametrize("n", [3, BLOCKED_MIN_N])
def test_nonsymmetric_damping_takes_the_full_path(n):
    """A damping tensor that is not a Hessian (random D̄2, D̄3) uses the full n² layout."""
    g = torch.Generator().manual_seed(7)
    rom0, _, _ = random_gram_model(n, seed=1)
    D2 = torch.randn(n, n, n, generator=g, dtype=torch.float64)
    D3 = torch.randn(n, n, n, n, generator=g, dtype=torch.float64)
    D3 = 0.5 * (D3 + D3.transpose(1, 2))
    rom = rom0.replace(D2=D2, D3=D3)
    forces = NonlinearForces(rom)
    assert not forces.symmetric_damping and forces.expand is None
    q, v, s, gam = _random_states(n)
    got = forces(q, v, s[None], gam[None])
    ref = _nonlinear_reference(rom, q, v, s, gam)
    assert torch.allclose(got, ref, rtol=0, atol=1e-13 * ref.abs().max())


def test_switches_and_sparse_analytic_rom():
    rom = van_der_pol_duffing([1.0, 2.0, 3.0], c1=-0.1, d3=[0.5, 0.0, 0.2], k3=[2.0, 0.0, 1.0])
    q, v, s, g = _random_states(3)
    both = NonlinearForces(rom)
    assert both.has_stiffness and both.has_damping and not both.has_k2
    ref = _nonlinear_reference(rom, q, v, s, g)
    assert torch.allclose(both(q, v, s[None], g[None]), ref, atol=1e-13)
    stiff = NonlinearForces(rom, damping=False)
    assert not stiff.has_damping
    ref_s = _nonlinear_reference(rom, q, v, s, torch.zeros_like(g))
    assert torch.allclose(stiff(q, v, s[None], None), ref_s, atol=1e-13)
    linear = NonlinearForces(NonlinearROM([[1.0]], [[4.0]]))
    assert not linear.active
    assert (linear(q[:, :1], v[:, :1], None, None) == 0).all()


@pytest.mark.parametrize("n", [1, 3, 5])
@pytest.mark.parametrize("stiffness,damping", [(True, True), (True, False), (False, True)])
def test_small_rom_kernel(n, stiffness, damping):
    """The one-GEMM monomial kernel of small ROMs (the integrator's iterations) against the
    general kernel, with either term switched off; nonsymmetric damping included."""
    rom, _, _ = random_gram_model(n, seed=n)
    gen = torch.Generator().manual_seed(4)
    rom = rom.replace(D2=torch.randn(n, n, n, generator=gen, dtype=torch.float64))
    forces = NonlinearForces(rom, stiffness=stiffness, damping=damping)
    assert forces.small is not None
    q, v, s, g = _random_states(n)
    qT, vT = q.T.contiguous(), v.T.contiguous()
    s = s[None] if stiffness else None
    g = g[None] if damping else None
    ref = forces.evaluate_T(qT, vT, s, g)
    got = forces.evaluate_small(torch.cat([vT, qT]), *forces.small_scales(s, g))
    assert torch.allclose(got, ref, rtol=0, atol=1e-13 * ref.abs().max())


def test_small_kernel_keeps_only_the_rom_monomials():
    """A sparse analytic ROM gathers only its nonzero monomials; a large ROM has no small
    kernel (more monomials than SMALL_MAX_MONOMIALS)."""
    rom = van_der_pol_duffing([1.0, 2.0, 3.0], c1=-0.1, d3=[0.5, 0.0, 0.2], k3=[2.0, 0.0, 1.0])
    W, _ = NonlinearForces(rom).small
    assert W.shape == (3, 4)  # k3 q1³, k3 q3³, d3 q1² q̇1, d3 q3² q̇3
    big, _, _ = random_gram_model(BLOCKED_MIN_N + 1, seed=1)
    assert NonlinearForces(big).small is None


def test_float32_kernel():
    rom, _, _ = random_gram_model(BLOCKED_MIN_N + 1, seed=2)
    q, v, s, g = _random_states(rom.n)
    ref = _nonlinear_reference(rom, q, v, s, g)
    f32 = NonlinearForces(rom, dtype=torch.float32)
    got = f32(q.float(), v.float(), s[None].float(), g[None].float())
    assert got.dtype == torch.float32
    # float32 rounding of sums of ~2000 monomial terms: 1e-5 of the force scale
    assert torch.allclose(got.double(), ref, rtol=0, atol=1e-5 * ref.abs().max())


@pytest.mark.parametrize("n,nonsymmetric", [(3, False), (BLOCKED_MIN_N + 1, False),
                                            (BLOCKED_MIN_N, True)])
def test_jacobian_rows_against_rom_tangents(n, nonsymmetric):
    """The Jacobian pieces of the refreshed iteration matrix: the nonlinear tangent stiffness
    (at q̇ = 0, ∂f/∂q of NonlinearROM.tangents minus K1) and the nonlinear damping matrix
    (∂f/∂q̇ at γ = 1 minus D̄1), in the per-case product layout A[k, m] = matrix[m, k]."""
    rom, _, _ = random_gram_model(n, seed=5)
    if nonsymmetric:
        g = torch.Generator().manual_seed(2)
        rom = rom.replace(D2=torch.randn(n, n, n, generator=g, dtype=torch.float64))
    forces = NonlinearForces(rom)
    q, v, s, gam = _random_states(n)
    f, K, D = forces.evaluate_T(q.T.contiguous(), v.T.contiguous(), s[None], gam[None],
                                jacobian=True)
    assert torch.allclose(f.T, forces(q, v, s[None], gam[None]), rtol=0, atol=1e-14 * f.abs().max())
    ones = torch.ones(len(q), dtype=torch.float64)
    Kt, _ = rom.tangents(q, torch.zeros_like(v), 0.0, ones)
    _, Ct = rom.tangents(q, v, 0.0, ones)
    Kref = Kt - rom.K1
    Dref = Ct - rom.D1
    # Gram-form ROMs are conservative: the tangent is symmetric and the symmetric part exact
    assert torch.allclose(K.permute(2, 1, 0), Kref, rtol=0, atol=1e-12 * Kref.abs().max())
    assert torch.allclose(D.permute(2, 1, 0), Dref, rtol=0, atol=1e-12 * Dref.abs().max())
