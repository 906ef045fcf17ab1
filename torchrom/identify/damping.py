"""Non-intrusive identification of the Kelvin–Voigt nonlinear damping tensors D̄1, D̄2, D̄3 (γ = 1).

Two methods (DIGEST Sec. 5, NOTES-damping):

- ``exact``, for FE backends that expose the material tangent K_mat(u) = ∫ Bᵀ(u) C B(u): with
  D = γC the tangent damping matrix of Eq. 32 is its projection Φᵀ K_mat(Φq) Φ = D̄1 + D̄2(q) +
  D̄3(q, q), a quadratic polynomial in q fitted like the stiffness. Unique.
- ``decomposition``, the paper's route: the identified stiffness coefficients fix only the
  symmetrised parts of the energy-form tensors G and H (:mod:`torchrom.rom.conventions`); the
  "optimum decomposition" (paper Ref. 28) chooses the free parameters, subset of modes by subset
  (Eqs. 16, 25–27 inverted), to maximise the smallest eigenvalue of the extended matrix (Eq. 45):
  each subset's small semidefinite program solved to its optimum by a batched log-barrier method
  (:mod:`.eigmax`; the soft-minimum Adam ascent before issue 48 is kept as an option), then the
  whole basis at once by the soft-minimum ascent (or by L-BFGS with its analytic gradient,
  an option), and finally enforces positive
  semidefiniteness by projection onto the affine set of the identified coefficients (or, where
  that set is too thin, by clipping the Schur complement of the pair block, reported as the K̃3
  reproduction error). Eigenvalues are compared on the extended matrix scaled to unit diagonal
  order, invariant to the normalisation of the basis.

Written here (no library implements this); the eigen-solvers are torch's.
"""

from __future__ import annotations

import contextlib
import itertools
import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import torch

from ..errors import InputError
from ..rom import conventions as cv
from ..rom.monomials import monomial_index
from .stiffness import TangentPlan, _full_sym, _rel_spread, fit_quadratic_matrix


# ------------------------------------------------------------------------------------------------
# exact: from the projected material tangent
# ------------------------------------------------------------------------------------------------
@dataclass
class DampingIdentification:
    """Damping tensors at γ = 1 (symmetric storage) with diagnostics."""

    D1: np.ndarray
    D2: np.ndarray
    D3: np.ndarray
    method: str
    report: dict = field(default_factory=dict)
    G: np.ndarray | None = None
    H: np.ndarray | None = None


def damping_from_material_tangents(plan: TangentPlan, Kmat: np.ndarray) -> DampingIdentification:
    """``exact``: D̄1, D̄2, D̄3 from Φᵀ K_mat(Φq) Φ at the plan's points (Eq. 32).

    D_T[m, n] = D̄1_mn + D̄2_mln q_l + D̄3_mlpn q_l q_p, so with the fit
    T = T0 + A1(q) + A2(q, q): D̄1 = T0, D̄2[m, l, n] = A1[m, n, l], D̄3[m, l, p, n] = A2[m, n, l, p].
    """
    T0, A1, A2 = fit_quadratic_matrix(plan, Kmat)
    D1 = 0.5 * (T0 + T0.T)
    D2 = np.einsum("mnl->mln", A1)
    D3 = np.einsum("mnlp->mlpn", A2)
    G, H = cv.gram_from_damping(torch.as_tensor(D2), torch.as_tensor(D3))
    _, D2kv, D3kv = cv.damping_from_gram(torch.as_tensor(D1), G, H)
    report = {
        "material_tangent_asymmetry": max(_rel_spread(T, T.T) for T in Kmat),
        # departure from the Kelvin–Voigt structure (0 for a strain-based FE)
        "kelvin_voigt_residual_D2": _rel_spread(D2, D2kv.numpy()),
        "kelvin_voigt_residual_D3": _rel_spread(D3, D3kv.numpy()),
    }
    K_E = cv.energy_extended_matrix(torch.as_tensor(D1), G, H)
    with _one_thread():  # on two threads of a loaded 2-core machine: 2.8 s each, not 2 ms
        report["min_eigenvalue"] = float(torch.linalg.eigvalsh(K_E).min())
        report["min_eigenvalue_scaled"] = float(torch.linalg.eigvalsh(
            scale_matrix(K_E, D1, H.numpy())).min())
    return DampingIdentification(D1, D2, D3, "exact", report, G.numpy(), H.numpy())


# ------------------------------------------------------------------------------------------------
# decomposition: structure of the indeterminacy
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Structure:
    """Entries of the extended matrix K_E = [[K1, B], [Bᵀ, C]] on [q ; pair space] as *classes*.

    A G class (m | {i ≤ j}) is the entry B[m, (ij)] = f G[m, i, j]; an H class {P ≤ Q} is the
    entry C[P, Q] = f_P f_Q H[P, Q], where f = √2 for a pair i < j and 1 for i = j (the
    orthonormal pair basis of :func:`~torchrom.rom.conventions.symmetric_pair_basis`).
    ``alpha`` holds the coefficient of each class in the identified coefficient of its multiset:
    K2_abc = Σ α_c G_c, K3_abcd = Σ α_c H_c (fully symmetrized K2, K3).
    """

    n: int
    rows: np.ndarray      # matrix row of each class (G classes first, then H classes)
    cols: np.ndarray
    f: np.ndarray         # pair-basis factor
    alpha: np.ndarray     # constraint coefficient in class-value units
    group: np.ndarray     # multiset id: triples 0..N3-1 for G, N3 + quadruple id for H
    omega: np.ndarray     # entries of the symmetric matrix the class occupies (2 or 1)
    support: list         # distinct modes of each class's multiset, per group
    g_index: np.ndarray   # (n_G, 3) (m, i, j)
    h_index: np.ndarray   # (n_H, 4) (p1, p2, q1, q2)
    n_groups: int

    @property
    def n_g(self) -> int:
        return len(self.g_index)


@lru_cache(maxsize=8)
def _structure(n: int) -> _Structure:
    idx = monomial_index(n)
    pairs, pid = idx.pairs, idx.pair_id
    tid = {tuple(t): i for i, t in enumerate(idx.triples.tolist())}
    quads = list(itertools.combinations_with_replacement(range(n), 4))
    qid = {q: i for i, q in enumerate(quads)}
    rows, cols, f, alpha, group, omega, gi, hi = [], [], [], [], [], [], [], []
    for m in range(n):
        for P, (i, j) in enumerate(pairs.tolist()):
            ms = tuple(sorted((m, i, j)))
            rows.append(m)
            cols.append(n + P)
            f.append(math.sqrt(2.0) if i != j else 1.0)
            alpha.append(float(ms.count(m)))
            group.append(tid[ms])
            omega.append(2.0)
            gi.append((m, i, j))
    n3 = idx.n_triples
    for P, Q in itertools.combinations_with_replacement(range(len(pairs)), 2):
        (a, b), (c, d) = pairs[P], pairs[Q]
        x = tuple(sorted((a, b, c, d)))
        count = 0
        for (p1, p2), (p3, p4) in (((0, 1), (2, 3)), ((0, 2), (1, 3)), ((0, 3), (1, 2))):
            key = tuple(sorted((pid[x[p1], x[p2]], pid[x[p3], x[p4]])))
            count += key == (P, Q)
        rows.append(n + P)
        cols.append(n + Q)
        f.append((math.sqrt(2.0) if a != b else 1.0) * (math.sqrt(2.0) if c != d else 1.0))
        alpha.append(2.0 * count / 3.0)
        group.append(n3 + qid[x])
        omega.append(2.0 if P != Q else 1.0)
        hi.append((a, b, c, d))
    support = [tuple(sorted(set(t))) for t in idx.triples.tolist()] + [
        tuple(sorted(set(q))) for q in quads]
    return _Structure(n, np.array(rows), np.array(cols), np.array(f), np.array(alpha),
                      np.array(group), np.array(omega), support, np.array(gi, dtype=int),
                      np.array(hi, dtype=int).reshape(-1, 4), n3 + len(quads))


def _class_values(st: _Structure, G: np.ndarray, H: np.ndarray) -> np.ndarray:
    g, h = st.g_index, st.h_index
    return np.concatenate([G[g[:, 0], g[:, 1], g[:, 2]], H[h[:, 0], h[:, 1], h[:, 2], h[:, 3]]])


def _tensors_from_values(st: _Structure, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = st.n
    G = np.zeros((n, n, n))
    H = np.zeros((n, n, n, n))
    g, h = st.g_index, st.h_index
    vg, vh = v[:st.n_g], v[st.n_g:]
    G[g[:, 0], g[:, 1], g[:, 2]] = vg
    G[g[:, 0], g[:, 2], g[:, 1]] = vg
    for (a, b, c, d) in itertools.permutations(range(4)):
        # the 8 orderings that keep the pair structure {p1 p2}{q1 q2}
        if {frozenset((a, b)), frozenset((c, d))} == {frozenset((0, 1)), frozenset((2, 3))}:
            H[h[:, a], h[:, b], h[:, c], h[:, d]] = vh
    return G, H


def _assemble(st: _Structure, K1hat: torch.Tensor, m: torch.Tensor) -> torch.Tensor:
    """The (scaled) extended matrix from its K1 block and the class entries m (matrix units)."""
    n = st.n
    N = n + n * (n + 1) // 2
    X = m.new_zeros(N, N)
    X[:n, :n] = K1hat
    r = torch.as_tensor(st.rows)
    c = torch.as_tensor(st.cols)
    X = X.index_put((r, c), m).index_put((c, r), m)
    return X


def _scales(st: _Structure, K1: np.ndarray, H0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-class scale σ and per-coordinate scale s of the extended matrix."""
    n = st.n
    d1 = np.diag(K1).copy()
    if np.any(d1 <= 0):
        raise InputError("decomposition: K1 has a non-positive diagonal entry; the basis is not "
                         "a set of elastic deformations")
    hd = np.array([H0[i, i, i, i] for i in range(n)])
    floor = max(hd.max(), np.finfo(float).tiny) * 1e-12
    hd = np.where(hd > floor, hd, max(hd.max(), 1.0) if hd.max() > 0 else 1.0)
    s_q = d1 ** -0.5
    pairs = monomial_index(n).pairs
    s_p = (hd[pairs[:, 0]] * hd[pairs[:, 1]]) ** -0.25
    s = np.concatenate([s_q, s_p])
    return s[st.rows] * s[st.cols], s


def scale_matrix(K_E: torch.Tensor, K1, H) -> torch.Tensor:
    """The extended damping matrix K_E scaled symmetrically, S K_E S, with the scales of the
    decomposition (from K1 and H): the matrix whose smallest eigenvalue the decomposition and the
    damping checks report (dimensionless)."""
    n = np.shape(K1)[0]
    _, s = _scales(_structure(n), np.asarray(K1), np.asarray(H))
    s = torch.as_tensor(s, dtype=K_E.dtype)
    return s[:, None] * K_E * s[None, :]


#: how the subset stages and the whole-basis stage are solved (:class:`DecompositionOptions`)
SUBSET_SOLVERS = ("barrier", "adam")
WHOLE_SOLVERS = ("lbfgs", "adam")


@dataclass
class DecompositionOptions:
    """Options of the optimum decomposition.

    iterations: Adam steps per stage; lr: step size (scaled units); tau: soft-min temperatures
    (start, end; geometric); penalty: weight of ‖x‖² keeping flat directions small; margin:
    smallest scaled eigenvalue the enforcement aims at; max_newton: Newton steps of the exact
    (coefficient-preserving) enforcement before falling back to the Schur-complement clipping;
    subset_solver: "barrier" (each subset's small semidefinite program solved to its optimum,
    :mod:`.eigmax`) or "adam" (the soft-minimum ascent of ``iterations`` steps, the method
    before issue 48, kept as the benchmark's peer).

    The whole-basis stage after the subsets (the first part of the enforcement; 0 iterations
    skip it): whole_solver "adam" is the ascent of whole_iterations steps of size whole_lr (the
    default); "lbfgs" maximises the same soft minimum by L-BFGS with its analytic gradient
    (one eigen-decomposition per evaluation), whole_lbfgs_iterations iterations at each
    temperature of whole_taus: 2.5x faster and a higher smallest eigenvalue, but it moves the
    paper study's at-threshold finding "amplitude decreases with γ" (issue 48, docs/guide/
    paper.md), so it is not the study's default.
    """

    iterations: int = 60
    lr: float = 0.05
    tau: tuple[float, float] = (0.05, 5e-4)
    penalty: float = 1e-6
    margin: float = 1e-9
    whole_iterations: int = 300
    whole_lr: float = 0.03
    max_newton: int = 40
    subset_solver: str = "barrier"
    whole_solver: str = "adam"
    whole_taus: tuple[float, ...] = (0.05, 5e-3)
    whole_lbfgs_iterations: int = 60


@dataclass
class _Null:
    """Null-space directions of one set of parameters (in matrix-entry units)."""

    cls: np.ndarray       # class index of each nonzero
    par: np.ndarray       # parameter index of each nonzero
    val: np.ndarray
    subset: np.ndarray    # (n_par,) subset id of each parameter (within its stage)
    subsets: list         # the subsets (tuples of modes)


def _null_spaces(st: _Structure, alpha_hat: np.ndarray) -> dict[int, _Null]:
    """Orthonormal (Frobenius) null-space directions per multiset, grouped by support size."""
    order = np.argsort(st.group, kind="stable")
    bounds = np.flatnonzero(np.diff(st.group[order])) + 1
    by_size: dict[int, dict] = {}
    for members in np.split(order, bounds):
        k = len(members)
        if k < 2:
            continue
        supp = st.support[st.group[members[0]]]
        beta = alpha_hat[members] / np.sqrt(st.omega[members])
        # orthonormal basis of beta's orthogonal complement
        _, _, vt = np.linalg.svd(beta[None, :])
        basis = vt[1:] / np.sqrt(st.omega[members])[None, :]
        d = by_size.setdefault(len(supp), {"cls": [], "par": [], "val": [], "subset": [],
                                           "ids": {}})
        sid = d["ids"].setdefault(supp, len(d["ids"]))
        for row in basis:
            p = len(d["subset"])
            d["subset"].append(sid)
            d["cls"].extend(members.tolist())
            d["par"].extend([p] * k)
            d["val"].extend(row.tolist())
    out = {}
    for size, d in by_size.items():
        out[size] = _Null(np.array(d["cls"]), np.array(d["par"]), np.array(d["val"]),
                          np.array(d["subset"]), list(d["ids"]))
    return out


def whole_null(nulls: dict[int, _Null], n: int) -> _Null:
    """All null-space directions of :func:`_null_spaces` as one set on the whole basis (one
    subset): orthonormal in the Frobenius metric of the extended matrix, so the coordinates of
    a class-entry change d along them are x_a = Σ_c ω_c val_ac d_c."""
    allp = [nulls[k] for k in sorted(nulls)]
    offsets = np.cumsum([0] + [len(nl.subset) for nl in allp])
    return _Null(np.concatenate([nl.cls for nl in allp]),
                 np.concatenate([nl.par + o for nl, o in zip(allp, offsets)]),
                 np.concatenate([nl.val for nl in allp]),
                 np.zeros(int(offsets[-1]), dtype=int), [tuple(range(n))])


def _subset_indices(n: int, subsets: list) -> torch.Tensor:
    pid = monomial_index(n).pair_id
    rows = []
    for S in subsets:
        rows.append(list(S) + [n + pid[i, j] for i, j in
                               itertools.combinations_with_replacement(S, 2)])
    return torch.as_tensor(np.array(rows, dtype=np.int64))


def _optimise_stage(st: _Structure, K1hat: torch.Tensor, m0: torch.Tensor, null: _Null,
                    opt: DecompositionOptions, iterations: int | None = None,
                    lr: float | None = None) -> tuple[torch.Tensor, dict]:
    """Maximise the smallest eigenvalue of each subset's extended matrix over its parameters
    (soft minimum, Adam ascent with a geometrically decaying step, best iterate kept)."""
    iterations = opt.iterations if iterations is None else iterations
    lr = opt.lr if lr is None else lr
    P = len(null.subset)
    idx = _subset_indices(st.n, null.subsets)
    cls = torch.as_tensor(null.cls)
    par = torch.as_tensor(null.par)
    val = torch.as_tensor(null.val, dtype=m0.dtype)
    subset_of = torch.as_tensor(null.subset)

    def lam(x):
        m = m0.index_add(0, cls, val * x[par])
        X = _assemble(st, K1hat, m)
        sub = X[idx[:, :, None], idx[:, None, :]]
        return torch.linalg.eigvalsh(sub)

    x = torch.zeros(P, dtype=m0.dtype, requires_grad=True)
    with torch.no_grad():
        lam0 = lam(x)[:, 0].clone()
    best = lam0.clone()
    best_x = torch.zeros(P, dtype=m0.dtype)
    # Adam ascent (written out: a handful of lines, and no optimiser state to configure)
    mom, var = torch.zeros_like(best_x), torch.zeros_like(best_x)
    b1, b2 = 0.9, 0.999
    t0, t1 = opt.tau
    for it in range(iterations):
        frac = it / max(1, iterations - 1)
        tau = t0 * (t1 / t0) ** frac
        step_size = lr * 0.1**frac
        ev = lam(x)
        soft = -tau * torch.logsumexp(-ev / tau, dim=1)
        obj = soft.sum() - opt.penalty * (x * x).sum()
        (grad,) = torch.autograd.grad(obj, x)
        with torch.no_grad():
            cur = ev[:, 0]
            better = cur > best
            best = torch.where(better, cur, best)
            best_x = torch.where(better[subset_of], x, best_x)
            mom = b1 * mom + (1 - b1) * grad
            var = b2 * var + (1 - b2) * grad * grad
            step = step_size * (mom / (1 - b1 ** (it + 1))) / (
                (var / (1 - b2 ** (it + 1))).sqrt() + 1e-12)
            x += step
    with torch.no_grad():
        final = lam(best_x)[:, 0]
        m = m0.index_add(0, cls, val * best_x[par])
    info = {"subsets": len(null.subsets), "parameters": P,
            "min_eigenvalue_before": float(lam0.min()), "min_eigenvalue_after": float(final.min()),
            "subsets_improved": int((final > lam0 + 1e-12).sum())}
    return m, info


def _optimise_stage_barrier(st: _Structure, K1hat: torch.Tensor, m0: torch.Tensor, null: _Null,
                            opt: DecompositionOptions) -> tuple[torch.Tensor, dict]:
    """Maximise the smallest eigenvalue of each subset's extended matrix over its parameters,
    each subset's small semidefinite program solved to its optimum (within k·1e-11) by the
    batched barrier method of :func:`.eigmax.maximise_min_eigenvalue` (same penalty ρ‖x‖² as
    the ascent)."""
    from .eigmax import BarrierOptions, maximise_min_eigenvalue

    idx = _subset_indices(st.n, null.subsets)                 # (B, k) global indices
    B, k = idx.shape
    X0 = _assemble(st, K1hat, m0)
    F0 = X0[idx[:, :, None], idx[:, None, :]]
    # local index of each parameter within its subset, and of each nonzero's row and column
    order = np.argsort(null.subset, kind="stable")
    local = np.empty(len(null.subset), dtype=np.int64)
    counts = np.bincount(null.subset, minlength=B)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    local[order] = np.arange(len(order)) - np.repeat(starts, counts)
    p = int(counts.max())
    sub = null.subset[null.par]                                # subset of each nonzero
    idx_np = idx.numpy()
    r_loc = np.argmax(idx_np[sub] == st.rows[null.cls][:, None], axis=1)
    c_loc = np.argmax(idx_np[sub] == st.cols[null.cls][:, None], axis=1)
    F = torch.zeros(B, p, k, k, dtype=m0.dtype)
    val = torch.as_tensor(null.val, dtype=m0.dtype)
    j = torch.as_tensor(local[null.par])
    sb, rl, cl = (torch.as_tensor(a) for a in (sub, r_loc, c_loc))
    F.index_put_((sb, j, rl, cl), val, accumulate=True)
    off = rl != cl  # a diagonal class (an H entry on a pair with itself) occupies one entry
    F.index_put_((sb[off], j[off], cl[off], rl[off]), val[off], accumulate=True)
    res = maximise_min_eigenvalue(F0, F, BarrierOptions(penalty=opt.penalty))
    lam0 = torch.linalg.eigvalsh(F0)[:, 0]
    x = torch.zeros(len(null.subset), dtype=m0.dtype)
    x[:] = res.x[torch.as_tensor(null.subset), torch.as_tensor(local)]
    m = m0.index_add(0, torch.as_tensor(null.cls), val * x[torch.as_tensor(null.par)])
    final = res.min_eigenvalue
    info = {"subsets": len(null.subsets), "parameters": len(null.subset),
            "min_eigenvalue_before": float(lam0.min()), "min_eigenvalue_after": float(final.min()),
            "subsets_improved": int((final > lam0 + 1e-12).sum()),
            "solver": "barrier", "newton_steps": res.newton_steps}
    return m, info


def _lbfgs_maximise(f, x: torch.Tensor, iterations: int, memory: int = 20) -> torch.Tensor:
    """Maximise f (``f(x) -> (value, gradient)``) from ``x`` by L-BFGS: the two-loop recursion
    for the direction and a backtracking (Armijo) line search from the unit step (Nocedal &
    Wright, Algorithms 7.4 and 3.1); a pair with non-positive curvature is not stored. Written
    here: torch.optim's L-BFGS costs ~1.3 s to import (torch._dynamo) and scipy's runs its
    BLAS on every thread (slower than the eigen-decompositions on a loaded machine)."""
    value, grad = f(x)
    pairs: list[tuple[torch.Tensor, torch.Tensor, float]] = []
    for _ in range(iterations):
        q = grad.clone()  # ascent: the quasi-Newton direction of −f, negated
        alphas = []
        for s_, y_, r_ in reversed(pairs):
            a = r_ * float(s_ @ q)
            alphas.append(a)
            q -= a * y_
        if pairs:
            s_, y_, _ = pairs[-1]
            q *= float(s_ @ y_) / float(y_ @ y_)
        else:
            q /= max(float(grad.norm()), 1e-300)  # first step: unit length
        for (s_, y_, r_), a in zip(pairs, reversed(alphas)):
            q += (a - r_ * float(y_ @ q)) * s_
        slope = float(grad @ q)
        if slope <= 0.0:  # not an ascent direction (rounding): restart from the gradient
            pairs.clear()
            q, slope = grad.clone(), float(grad @ grad)
        step = 1.0
        for _ in range(30):
            x_new = x + step * q
            value_new, grad_new = f(x_new)
            if value_new >= value + 1e-4 * step * slope:
                break
            step *= 0.5
        else:
            break  # no increase along the direction: converged to rounding
        s_, y_ = x_new - x, grad - grad_new  # y of −f
        sy = float(s_ @ y_)
        if sy > 1e-300:
            pairs.append((s_, y_, 1.0 / sy))
            del pairs[:-memory]
        x, value, grad = x_new, value_new, grad_new
    return x


def _whole_soft_min(st: _Structure, K1hat: torch.Tensor, m0: torch.Tensor, null: _Null,
                    rho: float):
    """f(x, τ) -> (s_τ(x), ∇s_τ(x), λ_min(S(x))): the penalised soft minimum of the whole
    extended matrix S(x) = X(m0) + Σ_a x_a D_a over the null-space parameters x,
    s_τ(x) = −τ log Σ_i exp(−λ_i/τ) − ρ‖x‖², with its analytic gradient: for
    S = V diag(λ) Vᵀ and the weights w = softmax(−λ/τ), ∂s_τ/∂x_a = ⟨D_a, V diag(w) Vᵀ⟩ − 2ρx_a
    (the directions D_a are the Frobenius-orthonormal null directions of :func:`whole_null`:
    one gather of the weighted projector's entries); one eigen-decomposition per call."""
    N = st.n + st.n * (st.n + 1) // 2
    P = len(null.subset)
    cls, par = torch.as_tensor(null.cls), torch.as_tensor(null.par)
    val = torch.as_tensor(null.val, dtype=m0.dtype)
    rows, cols = torch.as_tensor(st.rows), torch.as_tensor(st.cols)
    om = torch.as_tensor(st.omega, dtype=m0.dtype)
    X0 = _assemble(st, K1hat, m0)

    def f(x: torch.Tensor, tau: float) -> tuple[float, torch.Tensor, float]:
        dm = torch.zeros(len(st.rows), dtype=m0.dtype).index_add_(0, cls, val * x[par])
        lam, V = torch.linalg.eigh(X0 + torch.zeros(N, N, dtype=m0.dtype).index_put_(
            (rows, cols), dm).index_put_((cols, rows), dm))
        W = (V * torch.softmax(-lam / tau, 0)) @ V.T
        grad = torch.zeros(P, dtype=m0.dtype).index_add_(
            0, par, val * (om * W[rows, cols])[cls]) - 2.0 * rho * x
        soft = -tau * torch.logsumexp(-lam / tau, 0) - rho * (x @ x)
        return float(soft), grad, float(lam[0])

    return f


def _optimise_whole_lbfgs(st: _Structure, K1hat: torch.Tensor, m0: torch.Tensor, null: _Null,
                          opt: DecompositionOptions) -> tuple[torch.Tensor, dict]:
    """Raise the smallest eigenvalue of the whole extended matrix over every null-space
    parameter: maximise the soft minimum of :func:`_whole_soft_min` by L-BFGS
    (:func:`_lbfgs_maximise`) at each temperature τ of ``opt.whole_taus`` in turn (each from
    the best point so far), the best iterate (largest λ_min) kept."""
    soft_min = _whole_soft_min(st, K1hat, m0, null, opt.penalty)
    lam0 = float(torch.linalg.eigvalsh(_assemble(st, K1hat, m0))[0])
    best = {"lam": lam0, "x": torch.zeros(len(null.subset), dtype=m0.dtype), "evaluations": 0}

    def f(x: torch.Tensor, tau: float) -> tuple[float, torch.Tensor]:
        value, grad, lam = soft_min(x, tau)
        best["evaluations"] += 1
        if lam > best["lam"]:
            best["lam"], best["x"] = lam, x
        return value, grad

    for tau in opt.whole_taus:
        _lbfgs_maximise(lambda x, tau=tau: f(x, tau), best["x"], opt.whole_lbfgs_iterations)
    x = best["x"]
    m = m0.index_add(0, torch.as_tensor(null.cls),
                     torch.as_tensor(null.val, dtype=m0.dtype) * x[torch.as_tensor(null.par)])
    return m, {"subsets": 1, "parameters": len(null.subset), "min_eigenvalue_before": lam0,
               "min_eigenvalue_after": best["lam"], "subsets_improved": int(best["lam"] > lam0),
               "solver": "lbfgs", "evaluations": best["evaluations"]}


def _affine_projector(st: _Structure, alpha_hat: np.ndarray, b: np.ndarray):
    """Frobenius projection of class entries m onto {Σ_c∈group α̂_c m_c = b_group}."""
    grp = torch.as_tensor(st.group)
    ah = torch.as_tensor(alpha_hat)
    om = torch.as_tensor(st.omega)
    bt = torch.as_tensor(b)
    denom = torch.zeros(st.n_groups, dtype=ah.dtype).index_add(0, grp, ah * ah / om)

    def proj(m):
        s = torch.zeros(st.n_groups, dtype=m.dtype).index_add(0, grp, ah * m)
        t = (s - bt) / denom
        return m - (ah / om) * t[grp]

    return proj


class _ConstraintOperator:
    """The linear map A: symmetric X -> one value per constraint group, and its adjoint.

    Every upper-triangle entry e = (r, c) of X belongs to exactly one group g(e) with coefficient
    a_e: the K1 entries (one group each, a = 1), the G and H classes (their multisets, a = α̂).
    With the Frobenius product ⟨X, Y⟩ = Σ_e ω_e X_e Y_e (ω = 2 off the diagonal),
    A(X)_g = Σ_{e∈g} a_e X_e and A*(y)_e = a_e y_g(e) / ω_e.
    """

    def __init__(self, st: _Structure, alpha_hat: np.ndarray):
        n = st.n
        iu = np.triu_indices(n)
        self.rows = torch.as_tensor(np.concatenate([iu[0], st.rows]))
        self.cols = torch.as_tensor(np.concatenate([iu[1], st.cols]))
        n_k1 = len(iu[0])
        self.group = torch.as_tensor(np.concatenate([np.arange(n_k1), n_k1 + st.group]))
        self.a = torch.as_tensor(np.concatenate([np.ones(n_k1), alpha_hat]))
        self.omega = torch.where(self.rows == self.cols, 1.0, 2.0).to(self.a.dtype)
        self.n_groups = n_k1 + st.n_groups
        self.N = n + n * (n + 1) // 2
        self.n_k1 = n_k1
        self.flat_rc = self.rows * self.N + self.cols
        self.flat_cr = self.cols * self.N + self.rows

    def __call__(self, X: torch.Tensor) -> torch.Tensor:
        vals = self.a * X[self.rows, self.cols]
        return torch.zeros(self.n_groups, dtype=X.dtype).index_add(0, self.group, vals)

    def adjoint(self, y: torch.Tensor) -> torch.Tensor:
        vals = self.a * y[self.group] / self.omega
        X = y.new_zeros(self.N * self.N)
        X[self.flat_rc] = vals
        X[self.flat_cr] = vals
        return X.view(self.N, self.N)


def _nearest_psd_constrained(A: _ConstraintOperator, X0: torch.Tensor, b: torch.Tensor,
                             floor: float, tol: float = 1e-13, max_newton: int = 60
                             ) -> tuple[torch.Tensor, dict]:
    """argmin ‖X − X0‖_F subject to A(X) = b and X ⪰ floor·I.

    The dual θ(y) = ½‖Π₊(X0 − floor·I + A*y)‖² − yᵀ(b − A(floor·I)) is minimised by the
    semismooth Newton–CG method of Qi & Sun (SIAM J. Matrix Anal. Appl. 28, 2006) for the nearest
    correlation matrix, with the generalised Jacobian of the PSD projection Π₊ from one
    eigen-decomposition per iteration; quadratic convergence where the feasible set has an
    interior. Returns X = Π₊(·) + floor·I and a report.
    """
    N = X0.shape[0]
    eye = torch.eye(N, dtype=X0.dtype)
    bb = b - A(floor * eye)
    Xs = X0 - floor * eye
    bscale = max(float(bb.abs().max()), 1.0)
    y = torch.zeros_like(bb)

    def evaluate(y):
        Z = Xs + A.adjoint(y)
        w, Q = torch.linalg.eigh(0.5 * (Z + Z.T))
        wp = w.clamp_min(0.0)
        P = (Q * wp) @ Q.T
        theta = 0.5 * float((wp * wp).sum()) - float(y @ bb)
        return theta, A(P) - bb, (w, Q, P)

    theta, g, (w, Q, P) = evaluate(y)
    iterations = 0
    history = []
    for _ in range(max_newton):
        res = float(g.abs().max()) / bscale
        history.append(res)
        # stop at convergence, or when the residual stagnates (a feasible set too thin to reach:
        # the caller falls back to the Schur-complement clipping)
        if res < tol or (len(history) > 4 and res > 0.5 * history[-5]):
            break
        iterations += 1
        pos = w > 0
        wp = w.clamp_min(0.0)
        dw = w[:, None] - w[None, :]
        same = dw.abs() < 1e-300
        Om = torch.where(same, pos[:, None].to(w.dtype).expand_as(dw),
                         (wp[:, None] - wp[None, :]) / torch.where(same, torch.ones_like(dw), dw))
        mu = min(1e-2, 0.5 * res) * 1e-2

        def V(d, Q=Q, Om=Om, mu=mu):
            H = Q.T @ A.adjoint(d) @ Q
            return A(Q @ (Om * H) @ Q.T) + mu * d

        # conjugate gradients on (V + μI) d = −g
        d = torch.zeros_like(g)
        r = -g.clone()
        p = r.clone()
        rr = float(r @ r)
        cg_tol = min(0.1, res) ** 1.5 * float(g.norm())
        for _ in range(60):
            Vp = V(p)
            alpha = rr / max(float(p @ Vp), 1e-300)
            d += alpha * p
            r -= alpha * Vp
            rr_new = float(r @ r)
            if rr_new ** 0.5 <= cg_tol:
                break
            p = r + (rr_new / rr) * p
            rr = rr_new
        # Armijo backtracking on the dual objective
        step, slope = 1.0, float(g @ d)
        for _ in range(30):
            theta_new, g_new, aux = evaluate(y + step * d)
            if theta_new <= theta + 1e-4 * step * slope:
                break
            step *= 0.5
        y = y + step * d
        theta, g, (w, Q, P) = theta_new, g_new, aux
    X = P + floor * eye
    info = {"newton_iterations": iterations, "constraint_residual": float(g.abs().max()) / bscale,
            "change": float((X - X0).norm() / max(float(X0.norm()), 1e-300))}
    return X, info


def _schur_clip(st: _Structure, K1hat: torch.Tensor, m: torch.Tensor, floor: float
                ) -> torch.Tensor:
    """Raise the Schur complement C − Bᵀ K1⁻¹ B of the extended matrix to ⪰ floor by changing
    only the pair block C (i.e. H, D̄3): K1 (D̄1) and B (G, D̄2) are kept exactly."""
    n = st.n
    X = _assemble(st, K1hat, m)
    K, B, C = X[:n, :n], X[:n, n:], X[n:, n:]
    S = C - B.T @ torch.linalg.solve(K, B)
    w, V = torch.linalg.eigh(0.5 * (S + S.T))
    C = C + (V * (floor - w).clamp_min(0.0)) @ V.T
    X = X.clone()
    X[n:, n:] = 0.5 * (C + C.T)
    is_h = torch.as_tensor(st.rows >= n)
    return torch.where(is_h, X[torch.as_tensor(st.rows), torch.as_tensor(st.cols)], m)


def _enforce_psd(st: _Structure, K1hat: torch.Tensor, m: torch.Tensor, alpha_hat: np.ndarray,
                 b: np.ndarray, floor: float, max_newton: int) -> tuple[torch.Tensor, dict]:
    """Make the extended matrix positive semidefinite (λ_min ≥ floor).

    First the exact way: the nearest matrix with λ_min ≥ floor that reproduces the identified
    coefficients and K1 (eigenvalue clipping and re-imposing the coefficients, solved as one
    projection problem by :func:`_nearest_psd_constrained`). Where that set is empty or too thin
    to reach in ``max_newton`` Newton steps — bases with dual modes have near-inextensional
    strain combinations, so the true Gram matrix is nearly singular — the Schur complement of the
    pair block is clipped instead: D̄1 = K1 and D̄2 stay as identified and decomposed, D̄3 changes
    as little as needed (reported as the reproduction error of K̃3 by the damping's energy form;
    the ROM's stiffness tensors are the identified ones either way).
    """
    X0 = _assemble(st, K1hat, m)
    start = float(torch.linalg.eigvalsh(X0)[0])
    info = {"min_eigenvalue_before": start, "target": floor}
    if start >= floor:
        info.update(method="none", min_eigenvalue_after=start)
        return m, info
    A = _ConstraintOperator(st, alpha_hat)
    bfull = torch.cat([K1hat[tuple(torch.triu_indices(st.n, st.n))], torch.as_tensor(b)])
    # aim 1e-7 (scaled units: the diagonal is ~1) above the floor, so that re-imposing the
    # coefficients after a Newton solve converged to ~1e-9 cannot push λ_min below it
    X, more = _nearest_psd_constrained(A, X0, bfull, floor + 1e-7, max_newton=max_newton)
    info.update(more)
    if more["constraint_residual"] < 1e-8:
        info["method"] = "constrained_projection"
        # re-impose the identified coefficients exactly (the Newton residual is ~1e-13)
        m_new = _affine_projector(st, alpha_hat, b)(X[torch.as_tensor(st.rows),
                                                      torch.as_tensor(st.cols)])
    else:
        info["method"] = "schur_clip"
        m_new = _schur_clip(st, K1hat, m, floor)
    info["min_eigenvalue_after"] = float(torch.linalg.eigvalsh(_assemble(st, K1hat, m_new))[0])
    return m_new, info


@contextlib.contextmanager
def _one_thread():
    """Small batched eigen-problems: torch's thread pool costs more than it gives (10× on a loaded
    2-core machine), so the decomposition runs on one intra-op thread."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


@dataclass
class DecompositionProblem:
    """The data of the decomposition in scaled class units (see the module docstring).

    st: class structure; K1, K2s, K3s: symmetrized K1 and fully symmetrized K2, K3; fs: class
    value -> scaled matrix entry factor; alpha_hat: constraint coefficients in scaled units; b:
    identified coefficient of each multiset (G groups: sorted triples; H: sorted quadruples);
    K1hat: the scaled K1 block. The identified coefficients are Σ_c∈group alpha_hat_c m_c = b.
    """

    st: _Structure
    K1: np.ndarray
    K2s: np.ndarray
    K3s: np.ndarray
    fs: np.ndarray
    alpha_hat: np.ndarray
    b: np.ndarray
    K1hat: np.ndarray

    def tensors(self, m) -> tuple[np.ndarray, np.ndarray, float, float]:
        """(G, H) of the scaled class entries m, and the relative errors with which their
        stiffness tensors reproduce the identified K2, K3."""
        G, H = _tensors_from_values(self.st, np.asarray(m) / self.fs)
        K2r, K3r = cv.stiffness_from_gram(torch.as_tensor(G), torch.as_tensor(H))
        return G, H, _rel_spread(K2r.numpy(), self.K2s), _rel_spread(K3r.numpy(), self.K3s)


def decomposition_problem(K1, K2, K3) -> DecompositionProblem:
    """Scaled decomposition data of identified (pseudo-)stiffness tensors K1, K2, K3."""
    K1 = 0.5 * (np.asarray(K1, float) + np.asarray(K1, float).T)
    K2s, K3s = _full_sym(np.asarray(K2, float)), _full_sym(np.asarray(K3, float))
    n = K1.shape[0]
    st = _structure(n)
    sigma, s = _scales(st, K1, K3s / 2.0)
    fs = st.f * sigma
    idx = monomial_index(n)
    quads = list(itertools.combinations_with_replacement(range(n), 4))
    b = np.concatenate([K2s[tuple(idx.triples.T)], K3s[tuple(np.array(quads).T)]])
    return DecompositionProblem(st, K1, K2s, K3s, fs, st.alpha / fs, b,
                                s[:n, None] * K1 * s[None, :n])


def optimum_decomposition(K1: np.ndarray, K2: np.ndarray, K3: np.ndarray,
                          options: DecompositionOptions | None = None) -> DampingIdentification:
    """``decomposition`` (see :func:`_optimum_decomposition`), on one intra-op thread."""
    with _one_thread():
        return _optimum_decomposition(K1, K2, K3, options)


def _optimum_decomposition(K1: np.ndarray, K2: np.ndarray, K3: np.ndarray,
                           options: DecompositionOptions | None = None) -> DampingIdentification:
    """``decomposition``: Kelvin–Voigt damping (D = γC, γ = 1) from identified stiffness tensors.

    Args:
        K1, K2, K3: pseudo-stiffness tensors (symmetric storage); for D = γC the stiffness ones.
    Returns:
        DampingIdentification with D̄1 = K1 (Eq. 42), D̄2, D̄3 from the chosen (G, H)
        (Eqs. 43–44 via :func:`~torchrom.rom.conventions.damping_from_gram`), and a report of the
        smallest eigenvalues (scaled and unscaled) of the symmetric split, after the subset
        optimisation and after the enforcement, per-stage statistics and the reproduction error of
        the identified combined coefficients.
    """
    opt = options or DecompositionOptions()
    if opt.subset_solver not in SUBSET_SOLVERS:
        raise InputError(f"decomposition: subset_solver: expected one of {SUBSET_SOLVERS}, got "
                         f"{opt.subset_solver!r}")
    if opt.whole_solver not in WHOLE_SOLVERS:
        raise InputError(f"decomposition: whole_solver: expected one of {WHOLE_SOLVERS}, got "
                         f"{opt.whole_solver!r}")
    p = decomposition_problem(K1, K2, K3)
    st, K1, K2s, K3s, fs, alpha_hat, b = p.st, p.K1, p.K2s, p.K3s, p.fs, p.alpha_hat, p.b
    n = st.n
    G0, H0 = K2s / 3.0, K3s / 2.0            # fully symmetric split (particular solution)
    m0 = torch.as_tensor(fs * _class_values(st, G0, H0))
    K1hat = torch.as_tensor(p.K1hat)

    def report_eigs(mm):
        X = _assemble(st, K1hat, mm)
        G, H = _tensors_from_values(st, mm.numpy() / fs)
        un = cv.energy_extended_matrix(torch.as_tensor(K1), torch.as_tensor(G),
                                       torch.as_tensor(H))
        return float(torch.linalg.eigvalsh(X)[0]), float(torch.linalg.eigvalsh(un)[0])

    report: dict = {"options": opt.__dict__.copy()}
    report["symmetric_split"] = dict(zip(("min_eigenvalue_scaled", "min_eigenvalue"),
                                         report_eigs(m0)))
    # start from the minimum-norm split in the scaled metric: it puts each coefficient on the
    # classes whose modes are stiff (large K1_mm), the structure of a Gram matrix with dual modes
    m = _affine_projector(st, alpha_hat, b)(torch.zeros_like(m0))
    report["min_norm_split"] = dict(zip(("min_eigenvalue_scaled", "min_eigenvalue"),
                                        report_eigs(m)))
    stages = {}
    nulls = _null_spaces(st, alpha_hat)
    for size, name in ((2, "pairs"), (3, "triples"), (4, "quadruples")):
        if size in nulls:
            if opt.subset_solver == "barrier":
                m, stages[name] = _optimise_stage_barrier(st, K1hat, m, nulls[size], opt)
            else:
                m, stages[name] = _optimise_stage(st, K1hat, m, nulls[size], opt)
    report["after_subsets"] = dict(zip(("min_eigenvalue_scaled", "min_eigenvalue"),
                                       report_eigs(m)))
    # last stage: the whole basis (the largest subset), all parameters at once; it prepares the
    # enforcement (the subset optimum can leave the full matrix far from semidefinite)
    if nulls and opt.whole_solver == "lbfgs" and opt.whole_lbfgs_iterations > 0:
        m, stages["whole"] = _optimise_whole_lbfgs(st, K1hat, m, whole_null(nulls, n), opt)
    elif nulls and opt.whole_solver == "adam" and opt.whole_iterations > 0:
        m, stages["whole"] = _optimise_stage(st, K1hat, m, whole_null(nulls, n), opt,
                                             opt.whole_iterations, opt.whole_lr)
    report["stages"] = stages
    report["after_whole"] = dict(zip(("min_eigenvalue_scaled", "min_eigenvalue"),
                                     report_eigs(m)))
    _, _, report["decomposition_reproduction_error_K2"], \
        report["decomposition_reproduction_error_K3"] = p.tensors(m.numpy())
    # never less positive than the particular solution, and at least semidefinite (+ margin)
    floor = max(opt.margin, report["symmetric_split"]["min_eigenvalue_scaled"])
    m, report["enforcement"] = _enforce_psd(st, K1hat, m, alpha_hat, b, floor,
                                              opt.max_newton)
    report["final"] = dict(zip(("min_eigenvalue_scaled", "min_eigenvalue"), report_eigs(m)))
    G, H, report["reproduction_error_K2"], report["reproduction_error_K3"] = p.tensors(m.numpy())
    D1, D2, D3 = cv.damping_from_gram(torch.as_tensor(K1), torch.as_tensor(G),
                                      torch.as_tensor(H))
    return DampingIdentification(D1.numpy(), D2.numpy(), D3.numpy(), "decomposition", report,
                                 G, H)


def symmetric_split_damping(K1, K2, K3) -> DampingIdentification:
    """The plain fully symmetric split (no optimisation): the baseline of the decomposition."""
    K2s, K3s = _full_sym(np.asarray(K2, float)), _full_sym(np.asarray(K3, float))
    G, H = K2s / 3.0, K3s / 2.0
    D1, D2, D3 = cv.damping_from_gram(torch.as_tensor(K1), torch.as_tensor(G),
                                      torch.as_tensor(H))
    return DampingIdentification(D1.numpy(), D2.numpy(), D3.numpy(), "symmetric_split", {}, G, H)
