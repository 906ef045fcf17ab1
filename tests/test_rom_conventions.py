"""Convention converters (paper Eqs. 16–28) and the energy form: exact round trips and
independent checks by automatic differentiation of W = ½EᵀCE and R = ½ĖᵀCĖ."""

import itertools

import pytest
import torch

from torchrom.errors import InputError
from torchrom.rom import conventions as cv
from torchrom.rom.monomials import monomial_index

from .rom_fixtures import random_gram_model

# Round trips involve a handful of additions/divisions per entry: 1e-14 relative is rounding.
RT = 1e-14


def rel(a, b):
    return float((a - b).abs().max() / max(b.abs().max(), 1e-300))


def test_monomial_counts():
    idx = monomial_index(21)
    assert idx.n_pairs == 231 and idx.n_triples == 1771
    assert idx.pair_mult.sum() == 21 * 21
    assert idx.triple_mult.sum() == 21**3


@pytest.mark.parametrize("n", [1, 2, 4])
def test_combined_round_trip(n):
    rom, _, _ = random_gram_model(n, seed=n)
    comb = cv.to_combined(rom.K2, rom.K3, rom.D3)
    back = cv.from_combined(comb["K2"], comb["K3"], comb["D3"])
    assert rel(back["K2"], rom.K2) < RT
    assert rel(back["K3"], rom.K3) < RT
    assert rel(back["D3"], rom.D3) < RT
    # Eq. 25 by hand for one entry with l > n: K̃2_mnl = K2_mnl + K2_mln
    if n >= 2:
        assert torch.isclose(comb["K2"][0, 0, 1], rom.K2[0, 0, 1] + rom.K2[0, 1, 0])
        assert comb["K2"][0, 1, 0] == 0.0


def test_combined_k3_is_sum_over_distinct_permutations():
    rom, _, _ = random_gram_model(3, seed=7)
    K3t = cv.to_combined(K3=rom.K3)["K3"]
    for (n, l, p) in [(0, 1, 2), (0, 0, 2), (1, 1, 1)]:
        perms = set(itertools.permutations((n, l, p)))
        expect = sum(rom.K3[(0, *pp)] for pp in perms)
        assert torch.isclose(K3t[0, n, l, p], expect, rtol=1e-13)


def test_combined_rejects_out_of_order_entries():
    K2 = torch.zeros(2, 2, 2, dtype=torch.float64)
    K2[0, 1, 0] = 1.0
    with pytest.raises(InputError, match="Eq. 25"):
        cv.from_combined(K2=K2)


def test_compact_round_trip():
    rom, _, _ = random_gram_model(3, seed=3)
    c = cv.compact_from_symmetric(rom.K2, rom.K3, rom.D3)
    back = cv.symmetric_from_compact(c["K2c"], c["K3c"], c["D3c"])
    for k in ("K2", "K3", "D3"):
        assert rel(back[k], getattr(rom, k)) < RT


def test_gram_recovery_from_damping_is_exact():
    rom, _, _ = random_gram_model(4, seed=11)
    G, H = rom.gram()
    D1, D2, D3 = cv.damping_from_gram(rom.K1, G, H)
    assert rel(D2, rom.D2) < 1e-13 and rel(D3, rom.D3) < 1e-13


def test_gram_formulas_against_autograd():
    """Forces of the energy form by autograd of W and R, independent of the index formulas."""
    n = 3
    rom, strain, C = random_gram_model(n, seed=5)
    g = torch.Generator().manual_seed(1)
    for _ in range(3):
        q = torch.randn(n, generator=g, dtype=torch.float64, requires_grad=True)
        qd = torch.randn(n, generator=g, dtype=torch.float64, requires_grad=True)
        E = strain(q)
        W = 0.5 * E @ C @ E
        (fK,) = torch.autograd.grad(W, q)
        # Ė = (∂E/∂q) q̇ by forward-mode through a jvp
        _, Ed = torch.autograd.functional.jvp(strain, q.detach(), qd.detach())
        R = 0.5 * Ed @ C @ Ed
        # d = ∂R/∂q̇
        qd2 = qd.detach().clone().requires_grad_(True)
        _, Ed2 = torch.autograd.functional.jvp(strain, q.detach(), qd2, create_graph=True)
        (d,) = torch.autograd.grad(0.5 * Ed2 @ C @ Ed2, qd2)
        f_rom = rom.force(q.detach(), qd.detach(), alpha=0.0, gamma=1.0)
        assert rel(f_rom, fK + d) < 1e-12
        assert torch.isclose(rom.dissipated_power(q.detach(), qd.detach()), 2 * R, rtol=1e-12)


def test_paper_uncombined_recombines_to_symmetric_storage():
    """Eq. 16 K2 with Eq. 25 combination equals the symmetric storage's combined K̃2."""
    rom, _, _ = random_gram_model(3, seed=2)
    G, H = rom.gram()
    K2paper = cv.paper_K2_from_gram(G)
    comb_paper = K2paper + K2paper.transpose(1, 2)  # l != n entries: K2_mnl + K2_mln
    comb = cv.to_combined(K2=rom.K2)["K2"]
    idx = monomial_index(3)
    for (n_, l_) in idx.pairs.tolist():
        expect = K2paper[:, n_, n_] if n_ == l_ else comb_paper[:, n_, l_]
        assert rel(comb[:, n_, l_], expect) < 1e-13
    # pair-structured K3 = 2H symmetrised over its last three = symmetric K3
    up = cv.paper_uncombined_from_gram(G, H)
    assert rel(cv.sym_last3(up["K3pair"]), rom.K3) < 1e-13
    G2, H2 = cv.gram_from_paper_uncombined(up["K2hat"], up["K3pair"])
    assert rel(G2, G) < RT and rel(H2, H) < RT


def test_extended_damping_matrix_reproduces_dissipation():
    n = 4
    rom, _, _ = random_gram_model(n, seed=9)
    DB = rom.extended_damping_matrix()
    g = torch.Generator().manual_seed(3)
    for _ in range(5):
        q = torch.randn(n, generator=g, dtype=torch.float64)
        qd = torch.randn(n, generator=g, dtype=torch.float64)
        L = torch.cat([qd, cv.pair_lift(q, qd)])
        assert torch.isclose(L @ DB @ L, rom.dissipated_power(q, qd), rtol=1e-12)
    # a Gram model is positive semidefinite (K_E is a Gram matrix of strains)
    assert rom.extended_damping_min_eigenvalue() > -1e-10 * DB.abs().max()
