"""The cubic and quartic terms of a condensed potential about a state, fitted to the exact
condensed tangents and forces of static solves about it.

About a deformed state x = 0 (tangent K_c) the condensed structural force is the gradient of
a potential, and its Taylor expansion to fourth order is

    V(x) = ½ xᵀ K_c x + (1/6) V3(x, x, x) + (1/24) V4(x, x, x, x),
    N(x) = f(x) − f(0) − K_c x = ½ V3(x, x) + (1/6) V4(x, x, x),
    K_t(x) − K_c = V3(x) + ½ V4(x, x),

with V3, V4 fully symmetric, i.e. K2 = V3/2 and K3 = V4/6 in the ROM's force
(:mod:`torchrom.rom.model`, Eq. 54). Every solve gives N (n numbers) and the exact condensed
tangent K_t (n(n+1)/2 numbers), both linear in the potential's monomial coefficients, which
are found by one least-squares solve. Because the unknowns are the potential's coefficients,
the force is a gradient by construction: nothing is symmetrized afterwards.

Which coefficients the solves determine: loads on the first k coordinates move those at first
order and the rest only through the nonlinear coupling, so the first differences of K_t along
a loaded coordinate i give V3[i, :, :] and the second differences along i, j give
V4[i, j, :, :]. The fit keeps the cubic monomials with at least one loaded index and the
quartic ones with at least two (counted with multiplicity); the others (a higher mode's own
cubic stiffening) are left at zero.

Why not the fit about rest (:func:`.condensation.stiffness_from_condensation`): it fits the
force of the loaded coordinates along the solves' manifold δp_j = 0 (j > k), whose loaded block
is a gradient only when the solved structure's modal stiffness A is diagonal and no linear part
is kept outside it (D = 0). About a deformed state the tangent couples every coordinate, and
on a skeleton (a linear skin, D ≠ 0) A is not diagonal: that block then is not symmetric (its
unsymmetric part is of the order of its symmetric one on the skinned Pazy wing at 5°), and a
cubic in the loaded coordinates cannot fit it.

Written here: no library fits a potential to condensed FE tangents.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from math import factorial

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class PotentialMonomials:
    """The cubic and quartic monomials x^e of n coordinates kept by the fit (module
    docstring): ``exponents`` (T, n) and ``order`` (T,) 3 or 4; ``loaded`` = k."""

    n: int
    loaded: int
    exponents: np.ndarray
    order: np.ndarray

    @classmethod
    def of(cls, n: int, loaded: int) -> PotentialMonomials:
        rows, orders = [], []
        for order, least in ((3, 1), (4, 2)):
            for t in itertools.combinations_with_replacement(range(n), order):
                if sum(i < loaded for i in t) >= least:
                    e = np.zeros(n, dtype=int)
                    np.add.at(e, list(t), 1)
                    rows.append(e)
                    orders.append(order)
        return cls(n, int(loaded), np.array(rows, dtype=int).reshape(-1, n),
                   np.array(orders, dtype=int))

    def gradient(self, y: np.ndarray) -> np.ndarray:
        """∂m_t/∂y_i at one point ``y`` (n,): (n, T)."""
        E = self.exponents
        out = np.zeros((self.n, len(E)))
        for i in range(self.n):
            e = E.copy()
            e[:, i] -= 1
            ok = e[:, i] >= 0
            out[i, ok] = E[ok, i] * np.prod(y[None, :] ** e[ok], axis=1)
        return out

    def hessian(self, y: np.ndarray) -> np.ndarray:
        """∂²m_t/∂y_i∂y_j at one point ``y`` (n,), the entries i ≤ j: (n(n+1)/2, T)."""
        E = self.exponents
        iu, ju = np.triu_indices(self.n)
        out = np.zeros((len(iu), len(E)))
        for r, (i, j) in enumerate(zip(iu, ju)):
            e = E.copy()
            e[:, i] -= 1
            c = E[:, i].astype(float)
            c = c * e[:, j]
            e[:, j] -= 1
            ok = (e >= 0).all(axis=1) & (c != 0)
            out[r, ok] = c[ok] * np.prod(y[None, :] ** e[ok], axis=1)
        return out

    def tensors(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The fully symmetric (V3, V4) of the potential Σ θ_t m_t."""
        n = self.n
        V3, V4 = np.zeros((n,) * 3), np.zeros((n,) * 4)
        for e, order, th in zip(self.exponents, self.order, theta):
            idx = tuple(np.repeat(np.arange(n), e))
            perms = set(itertools.permutations(idx))
            # V = (1/order!) Σ V[idx] x^idx over all orderings: V[t] = order! θ / #orderings
            value = factorial(order) * th / len(perms)
            target = V3 if order == 3 else V4
            for p in perms:
                target[p] = value
        return V3, V4


@dataclass
class PotentialFit:
    """K2 = V3/2, K3 = V4/6 (symmetric storage) and how well they fit: ``tangent_fit`` and
    ``force_fit``, each ‖model − solves‖ / ‖solves‖ over all solves."""

    K2: np.ndarray
    K3: np.ndarray
    tangent_fit: float
    force_fit: float


def fit_potential(x: np.ndarray, tangents: np.ndarray, forces: np.ndarray, Kc: np.ndarray,
                  loaded: int) -> PotentialFit:
    """V3, V4 about a state from solves there: their coordinates ``x`` (P, n), exact condensed
    tangents ``tangents`` (P, n, n) and nonlinear forces N = f − f(0) − K_c x ``forces``
    (P, n), with the state's tangent ``Kc`` (n, n); ``loaded``: how many leading coordinates
    the solves loaded (module docstring). The coordinates are scaled to y = √(K_c,ii) x (each
    mode's energy scale), and each solve's tangent rows weighted by ‖y‖ so that they count
    in force units beside its forces."""
    x, Kt, N = np.atleast_2d(x), np.asarray(tangents, float), np.atleast_2d(forces)
    P, n = x.shape
    kd = np.diag(np.asarray(Kc, float))
    if np.any(kd <= 0):
        raise InputError("potential fit: the state's tangent needs a positive diagonal (a "
                         "stable equilibrium)")
    w = 1.0 / np.sqrt(kd)
    y = x / w
    mono = PotentialMonomials.of(n, loaded)
    iu, ju = np.triu_indices(n)
    rows_t, rhs_t, rows_f, rhs_f = [], [], [], []
    for p in range(P):
        s = float(np.linalg.norm(y[p]))
        dT = (Kt[p] - Kc) * np.outer(w, w)
        rows_t.append(s * mono.hessian(y[p]))
        rhs_t.append(s * dT[iu, ju])
        rows_f.append(mono.gradient(y[p]))
        rhs_f.append(w * N[p])
    At, bt = np.vstack(rows_t), np.concatenate(rhs_t)
    Af, bf = np.vstack(rows_f), np.concatenate(rhs_f)
    A, b = np.vstack([At, Af]), np.concatenate([bt, bf])
    rank = int(np.linalg.matrix_rank(A)) if len(A) else 0
    if rank < A.shape[1]:
        raise InputError(f"potential fit: the {P} solves determine only {rank} of the "
                         f"{A.shape[1]} cubic and quartic coefficients of {n} coordinates "
                         f"({loaded} loaded); load more directions or more levels")
    theta, *_ = np.linalg.lstsq(A, b, rcond=None)
    V3y, V4y = mono.tensors(theta)
    # back to x: V(x) = V(y(x)), y = x / w, so each index of V3, V4 carries a factor 1/w
    V3 = np.einsum("abc,a,b,c->abc", V3y, 1 / w, 1 / w, 1 / w)
    V4 = np.einsum("abcd,a,b,c,d->abcd", V4y, 1 / w, 1 / w, 1 / w, 1 / w)

    def rel(res, ref):
        return float(np.linalg.norm(res) / max(np.linalg.norm(ref), np.finfo(float).tiny))

    return PotentialFit(V3 / 2, V4 / 6, rel(At @ theta - bt, bt), rel(Af @ theta - bf, bf))
