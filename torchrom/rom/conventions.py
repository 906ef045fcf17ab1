"""Conversions between the storage conventions of the ROM tensors (paper Eqs. 14–28).

Three conventions appear in the paper and in this package (n basis functions, summation implied):

1. **Symmetric storage** (torchrom's, DESIGN "Conventions"): K2_mnl symmetric in (n, l), K3_mnlp
   symmetric in (n, l, p), D3_mlpn symmetric in (l, p); the force is
   f_m = K1_mn q_n + K2_mnl q_n q_l + K3_mnlp q_n q_l q_p + D1_mn q̇_n + D2_mln q_l q̇_n
   + D3_mlpn q_l q_p q̇_n, and the tangent stiffness is K1 + 2 K2(q,·) + 3 K3(q,q,·).
2. **Combined** (paper Eqs. 25–28, "ordered index"): one coefficient per distinct monomial,
   K̃2_mnl = 0 for l < n, K2_mnn for l = n, K2_mnl + K2_mln for l > n; K̃3_mnlp nonzero only for
   p ≥ l ≥ n, the sum over the distinct permutations; D̃3_mlpn nonzero only for p ≥ l. This is what
   the stiffness identification (Eqs. 37–41) delivers. Its compressed form — a matrix over the
   monomials of :mod:`torchrom.rom.monomials` — is the compute kernels' storage.
3. **Energy (Gram) form** (NOTES-damping): strains E = e^(n) q_n + h^(nl) q_n q_l give
   K1_mn = ∫ e^(m):C:e^(n), G_{m,(nl)} = ∫ e^(m):C:h^(nl) (symmetric in n, l) and
   H_{(ms),(nl)} = ∫ h^(ms):C:h^(nl) (symmetric within each pair and under pair exchange).
   The paper's "uncombined" tensors are K̂2_mnp = D̂2_mnp = 2 G_{m,(np)} (Eqs. 17, 22) and the
   pair-structured K3_mnlp = 2 H_{(mn),(lp)} (Eq. 18, symmetries Eq. 27), D3_mpln = 4 H_{(mp),(ln)}
   (Eq. 23, no ½). With D = γC (Eq. 52, γ = 1 here):
       K2_mnl = G_{m,nl} + G_{n,ml} + G_{l,mn},     K3_msnl = sym_(s,n,l) 2 H_{(ms),(nl)},
       D1 = K1,  D2_mln = 2 (G_{m,nl} + G_{n,ml}),   D3_mlpn = 2 (H_{(ml),(pn)} + H_{(mp),(ln)}),
   obtained from W = ½ ∫E:C:E (f = ∂W/∂q) and R = ½ ∫Ė:C:Ė (d = ∂R/∂q̇). The stiffness sees only
   the symmetrized parts of G and H (the identification's indeterminacy), whereas D2 and D3
   determine G and H uniquely (:func:`gram_from_damping`).

All functions take and return float64 torch tensors (numpy arrays are accepted). Everything here is
hand-written: no library implements these conventions.
"""

from __future__ import annotations

import itertools

import numpy as np
import torch

from .monomials import monomial_index

Tensor = torch.Tensor


def _t(x) -> Tensor:
    if isinstance(x, torch.Tensor):
        return x
    return torch.as_tensor(np.array(x, dtype=np.float64))


# --------------------------------------------------------------------------------------------
# Symmetrization
# --------------------------------------------------------------------------------------------
def sym_last2(T: Tensor) -> Tensor:
    """Symmetrize a (n, n, n) tensor in its last two indices."""
    T = _t(T)
    return 0.5 * (T + T.transpose(1, 2))


def sym_last3(T: Tensor) -> Tensor:
    """Symmetrize a (n, n, n, n) tensor in its last three indices."""
    T = _t(T)
    perms = list(itertools.permutations((1, 2, 3)))
    return sum(T.permute(0, *p) for p in perms) / len(perms)


def sym_middle2(T: Tensor) -> Tensor:
    """Symmetrize a (n, n, n, n) tensor in its middle two indices (D3_mlpn in (l, p))."""
    T = _t(T)
    return 0.5 * (T + T.transpose(1, 2))


def sym_gram_H(H: Tensor) -> Tensor:
    """Impose the symmetries of H_{(ms),(nl)}: within each pair and under pair exchange."""
    H = _t(H)
    H = 0.5 * (H + H.transpose(0, 1))
    H = 0.5 * (H + H.transpose(2, 3))
    return 0.5 * (H + H.permute(2, 3, 0, 1))


# --------------------------------------------------------------------------------------------
# Symmetric storage <-> combined (paper Eqs. 25-28) and compact monomial matrices
# --------------------------------------------------------------------------------------------
def compact_from_symmetric(K2: Tensor | None = None, K3: Tensor | None = None,
                           D3: Tensor | None = None) -> dict[str, Tensor]:
    """Monomial-coefficient matrices: K2c (n, N2), K3c (n, N3), D3c (n, N2, n).

    K2c[m, P] is the coefficient of the monomial P = (n ≤ l) in f_m, i.e. the combined K̃2_mnl;
    likewise K3c for P = (n ≤ l ≤ p) and D3c[m, (l ≤ p), n] = D̃3_mlpn.
    """
    out: dict[str, Tensor] = {}
    for name, T in (("K2", K2), ("K3", K3), ("D3", D3)):
        if T is None:
            continue
        T = _t(T)
        idx = monomial_index(T.shape[0])
        if name == "K2":
            p = torch.as_tensor(idx.pairs)
            mult = torch.as_tensor(idx.pair_mult, dtype=T.dtype)
            out["K2c"] = T[:, p[:, 0], p[:, 1]] * mult
        elif name == "K3":
            t = torch.as_tensor(idx.triples)
            mult = torch.as_tensor(idx.triple_mult, dtype=T.dtype)
            out["K3c"] = T[:, t[:, 0], t[:, 1], t[:, 2]] * mult
        else:
            p = torch.as_tensor(idx.pairs)
            mult = torch.as_tensor(idx.pair_mult, dtype=T.dtype)
            out["D3c"] = T[:, p[:, 0], p[:, 1], :] * mult[None, :, None]
    return out


def symmetric_from_compact(K2c: Tensor | None = None, K3c: Tensor | None = None,
                           D3c: Tensor | None = None) -> dict[str, Tensor]:
    """Inverse of :func:`compact_from_symmetric`: share each coefficient equally among orderings."""
    out: dict[str, Tensor] = {}
    if K2c is not None:
        K2c = _t(K2c)
        n = K2c.shape[0]
        idx = monomial_index(n)
        vals = K2c / torch.as_tensor(idx.pair_mult, dtype=K2c.dtype)
        K2 = K2c.new_zeros(n, n, n)
        for (a, b) in ((0, 1), (1, 0)):
            K2[:, idx.pairs[:, a], idx.pairs[:, b]] = vals
        out["K2"] = K2
    if K3c is not None:
        K3c = _t(K3c)
        n = K3c.shape[0]
        idx = monomial_index(n)
        vals = K3c / torch.as_tensor(idx.triple_mult, dtype=K3c.dtype)
        K3 = K3c.new_zeros(n, n, n, n)
        for perm in itertools.permutations(range(3)):
            t = idx.triples[:, list(perm)]
            K3[:, t[:, 0], t[:, 1], t[:, 2]] = vals
        out["K3"] = K3
    if D3c is not None:
        D3c = _t(D3c)
        n = D3c.shape[0]
        idx = monomial_index(n)
        vals = D3c / torch.as_tensor(idx.pair_mult, dtype=D3c.dtype)[None, :, None]
        D3 = D3c.new_zeros(n, n, n, n)
        for (a, b) in ((0, 1), (1, 0)):
            D3[:, idx.pairs[:, a], idx.pairs[:, b], :] = vals
        out["D3"] = D3
    return out


def to_combined(K2: Tensor | None = None, K3: Tensor | None = None,
                D3: Tensor | None = None) -> dict[str, Tensor]:
    """Symmetric storage -> the paper's combined dense tensors K̃2, K̃3, D̃3 (Eqs. 25, 26, 28).

    Entries with out-of-order indices are zero.
    """
    compact = compact_from_symmetric(K2, K3, D3)
    out: dict[str, Tensor] = {}
    if "K2c" in compact:
        n = compact["K2c"].shape[0]
        idx = monomial_index(n)
        K2t = compact["K2c"].new_zeros(n, n, n)
        K2t[:, idx.pairs[:, 0], idx.pairs[:, 1]] = compact["K2c"]
        out["K2"] = K2t
    if "K3c" in compact:
        n = compact["K3c"].shape[0]
        idx = monomial_index(n)
        K3t = compact["K3c"].new_zeros(n, n, n, n)
        K3t[:, idx.triples[:, 0], idx.triples[:, 1], idx.triples[:, 2]] = compact["K3c"]
        out["K3"] = K3t
    if "D3c" in compact:
        n = compact["D3c"].shape[0]
        idx = monomial_index(n)
        D3t = compact["D3c"].new_zeros(n, n, n, n)
        D3t[:, idx.pairs[:, 0], idx.pairs[:, 1], :] = compact["D3c"]
        out["D3"] = D3t
    return out


def from_combined(K2: Tensor | None = None, K3: Tensor | None = None,
                  D3: Tensor | None = None, *, check: bool = True) -> dict[str, Tensor]:
    """The paper's combined dense tensors (Eqs. 25, 26, 28) -> symmetric storage.

    With ``check`` (default) the out-of-order entries must be zero, as Eqs. 25–28 define them;
    a nonzero one is reported (it would be silently ignored otherwise).
    """
    from ..errors import InputError

    compact: dict[str, Tensor] = {}
    if K2 is not None:
        K2 = _t(K2)
        idx = monomial_index(K2.shape[0])
        compact["K2c"] = K2[:, idx.pairs[:, 0], idx.pairs[:, 1]]
        if check:
            _check_zero_outside(K2, lambda n, l: l < n, "combined K2 (Eq. 25)", InputError)
    if K3 is not None:
        K3 = _t(K3)
        idx = monomial_index(K3.shape[0])
        compact["K3c"] = K3[:, idx.triples[:, 0], idx.triples[:, 1], idx.triples[:, 2]]
        if check:
            _check_zero_outside(K3, lambda n, l, p: not (p >= l >= n), "combined K3 (Eq. 26)",
                                InputError)
    if D3 is not None:
        D3 = _t(D3)
        idx = monomial_index(D3.shape[0])
        compact["D3c"] = D3[:, idx.pairs[:, 0], idx.pairs[:, 1], :]
        if check:
            _check_zero_outside(D3, lambda l, p, _n: p < l, "combined D3 (Eq. 28)", InputError)
    return symmetric_from_compact(compact.get("K2c"), compact.get("K3c"), compact.get("D3c"))


def _check_zero_outside(T: Tensor, outside, name: str, err) -> None:
    n = T.shape[0]
    mask = torch.zeros(T.shape[1:], dtype=torch.bool)
    for ix in itertools.product(range(n), repeat=T.dim() - 1):
        if outside(*ix):
            mask[ix] = True
    bad = T[:, mask].abs().max().item() if mask.any() else 0.0
    scale = max(T.abs().max().item(), np.finfo(float).tiny)
    if bad > 1e-12 * scale:
        raise err(f"{name}: entries with out-of-order indices must be zero, largest is {bad:.3e}")


# --------------------------------------------------------------------------------------------
# Energy (Gram) form <-> tensors
# --------------------------------------------------------------------------------------------
def stiffness_from_gram(G: Tensor, H: Tensor) -> tuple[Tensor, Tensor]:
    """K2, K3 (symmetric storage) of the strain energy W = ½ Lᵀ K_E L (NOTES-damping).

    K2_mnl = G_{m,nl} + G_{n,ml} + G_{l,mn};  K3 = sym over the last three of 2 H_{(ms),(nl)}.
    """
    G, H = _t(G), _t(H)
    K2 = G + torch.einsum("nml->mnl", G) + torch.einsum("lmn->mnl", G)
    K3 = sym_last3(2.0 * H)
    return K2, K3


def damping_from_gram(K1: Tensor, G: Tensor, H: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """D1, D2, D3 at γ = 1 (Eq. 53) from the Rayleigh function R = ½ ∫ Ė:C:Ė.

    D1 = K1, D2_mln = 2 (G_{m,nl} + G_{n,ml}), D3_mlpn = 2 (H_{(ml),(pn)} + H_{(mp),(ln)}).
    """
    K1, G, H = _t(K1), _t(G), _t(H)
    # G[m, n, l] = G_{m,(nl)}; D2[m, l, n] = 2 (G[m, n, l] + G[n, m, l])
    D2 = 2.0 * (torch.einsum("mnl->mln", G) + torch.einsum("nml->mln", G))
    # D3[m, l, p, n] = 2 (H[m, l, p, n] + H[m, p, l, n])
    D3 = 2.0 * (H + torch.einsum("mpln->mlpn", H))
    return K1.clone(), D2, D3


def tensors_from_gram(K1: Tensor, G: Tensor, H: Tensor) -> dict[str, Tensor]:
    """All ROM tensors (symmetric storage, damping at γ = 1) from the energy form (K1, G, H)."""
    K2, K3 = stiffness_from_gram(G, H)
    D1, D2, D3 = damping_from_gram(K1, G, H)
    return {"K1": _t(K1).clone(), "K2": K2, "K3": K3, "D1": D1, "D2": D2, "D3": D3}


def gram_from_damping(D2: Tensor, D3: Tensor) -> tuple[Tensor, Tensor]:
    """Recover (G, H) from Kelvin–Voigt damping tensors; the recovery is unique.

    With S = D2/2 (S_mln = G_{m,nl} + G_{n,ml}), G_{m,nl} = ½ (S_mln + S_mnl − S_nml).
    With T = D3/2 (T_ilpn = H_{(il),(pn)} + H_{(ip),(ln)}),
    H_{(il),(pn)} = ½ (T_ilpn + T_ilnp − T_inpl).
    Tensors not of Kelvin–Voigt form are projected (the formulas are then a least-squares-like
    recovery; check with :func:`damping_from_gram`).
    """
    D2, D3 = _t(D2), _t(D3)
    S = 0.5 * D2
    # G[m, n, l] = ½ (S[m, l, n] + S[m, n, l] − S[n, m, l])
    G = 0.5 * (torch.einsum("mln->mnl", S) + S - torch.einsum("nml->mnl", S))
    G = sym_last2(G)
    T = 0.5 * D3
    # H[i, l, p, n] = ½ (T[i, l, p, n] + T[i, l, n, p] − T[i, n, p, l])
    H = 0.5 * (T + torch.einsum("ilnp->ilpn", T) - torch.einsum("inpl->ilpn", T))
    return G, sym_gram_H(H)


def paper_uncombined_from_gram(G: Tensor, H: Tensor) -> dict[str, Tensor]:
    """The paper's uncombined tensors: K̂2 = D̂2 = 2G (Eqs. 17, 22), pair-structured
    K3_mnlp = 2 H_{(mn),(lp)} (Eq. 18) and D3_mpln = 4 H_{(mp),(ln)} (Eq. 23)."""
    G, H = _t(G), _t(H)
    return {"K2hat": 2.0 * G, "K3pair": 2.0 * H, "D2hat": 2.0 * G, "D3pair": 4.0 * H}


def gram_from_paper_uncombined(K2hat: Tensor, K3pair: Tensor) -> tuple[Tensor, Tensor]:
    """Inverse of :func:`paper_uncombined_from_gram` (stiffness forms)."""
    return 0.5 * _t(K2hat), 0.5 * _t(K3pair)


def paper_K2_from_gram(G: Tensor) -> Tensor:
    """The paper's Eq. 16 quadratic tensor K2_mnl = ½ K̂2_mnl + K̂2_nlm (not symmetric in n, l);
    combining it with Eq. 25 gives the same combined K̃2 as the symmetric storage."""
    K2hat = 2.0 * _t(G)
    return 0.5 * K2hat + torch.einsum("nlm->mnl", K2hat)


# --------------------------------------------------------------------------------------------
# Extended matrices on the symmetric pair subspace (Eqs. 34-36, 45)
# --------------------------------------------------------------------------------------------
def symmetric_pair_basis(n: int, dtype=torch.float64) -> Tensor:
    """Orthonormal basis P (n², N2) of symmetric n×n matrices, columns in monomial-pair order.

    Column (i, j): (e_i e_jᵀ + e_j e_iᵀ)/√2 for i < j and e_i e_iᵀ for i = j, flattened row-major.
    """
    idx = monomial_index(n)
    P = torch.zeros(n * n, idx.n_pairs, dtype=dtype)
    for c, (i, j) in enumerate(idx.pairs.tolist()):
        if i == j:
            P[i * n + i, c] = 1.0
        else:
            P[i * n + j, c] = P[j * n + i, c] = 2.0 ** -0.5
    return P


def extended_matrix(A: Tensor, B: Tensor, C: Tensor) -> Tensor:
    """Restrict [[A, B~], [B~ᵀ, C~]] to coordinates [x ; sym pair space] (dimension n + N2).

    A is (n, n), B is (n, n, n) acting on pairs (last two indices), C is (n, n, n, n) mapping pair
    (first two) to pair (last two). Returns a symmetric (n + N2, n + N2) matrix.
    """
    A, B, C = _t(A), _t(B), _t(C)
    n = A.shape[0]
    P = symmetric_pair_basis(n, A.dtype)
    Bp = B.reshape(n, n * n) @ P
    Cp = P.T @ C.reshape(n * n, n * n) @ P
    top = torch.cat([A, Bp], dim=1)
    bot = torch.cat([Bp.T, Cp], dim=1)
    E = torch.cat([top, bot], dim=0)
    return 0.5 * (E + E.T)


def damping_extended_matrix(D1: Tensor, G: Tensor, H: Tensor) -> Tensor:
    """Extended damping matrix D_B (Eq. 34) on [q̇ ; sym(q ⊗ q̇)], scaled so that
    q̇ᵀ D_T(q) q̇ = Lᵀ D_B L exactly with L = [q̇ ; vec(sym(q ⊗ q̇))] expressed in the orthonormal
    pair basis: D_B = [[D1, 2G~], [2G~ᵀ, 4H~]] (paper: [[D1, ½ D̂2~], [½ D̂2~ᵀ, D3~]] up to the
    scaling of the pair coordinates, which does not change definiteness)."""
    return extended_matrix(_t(D1), 2.0 * _t(G), 4.0 * _t(H))


def energy_extended_matrix(K1: Tensor, G: Tensor, H: Tensor) -> Tensor:
    """K_E = [[K1, G~], [G~ᵀ, H~]] on [q ; sym pair space]: W = ½ Lᵀ K_E L (NOTES-damping).

    This is the pseudo-stiffness extended matrix D_KB of Eq. 45 up to the scaling of the pair
    coordinates (which leaves positive (semi)definiteness unchanged).
    """
    return extended_matrix(_t(K1), _t(G), _t(H))


def pair_lift(q: Tensor, v: Tensor) -> Tensor:
    """Coordinates of sym(q ⊗ v) in the orthonormal pair basis: (..., N2)."""
    n = q.shape[-1]
    idx = monomial_index(n)
    i = torch.as_tensor(idx.pairs[:, 0], device=q.device)
    j = torch.as_tensor(idx.pairs[:, 1], device=q.device)
    s = 0.5 * (q[..., i] * v[..., j] + q[..., j] * v[..., i])
    one = torch.ones((), dtype=q.dtype, device=q.device)
    scale = torch.where(i == j, one, one * 2.0 ** 0.5)
    return s * scale
