"""The ROM basis: mass-normalised linear modes plus dual modes (DIGEST Sec. 6, Eqs. 47–48).

Dual modes capture what the linear modes cannot: mostly the in-plane (membrane) displacements that
a large transverse deflection drags along. For each combination (j, l) of linear modes, static loads

    F = α K U^(j)                 (l = j, Eq. 47)      or      F = α (K U^(j) + K U^(l))   (Eq. 48)

— loads that would produce exactly U^(j) (+ U^(l)) in a linear model — are applied with 20 values
of α (half positive, half negative) spread uniformly in the predicted tip transverse displacement
from 0.1 % to 15 % of the span, and solved nonlinearly. The parts of the responses outside the span
of the linear modes (residuals, removed by M-orthogonal projection) are decomposed by proper
orthogonal decomposition (POD, in the mass inner product); the dominant POD vectors, mass-
orthonormalised against the linear modes, are the dual modes. Each snapshot is normalised to unit
mass norm before the POD, so small and large amplitudes weigh alike (the small ones carry the
quadratic, the large ones the cubic, membrane response). The paper's nine combinations (1-based)
are the default.

Hand-written; the static solves are the backend's, the eigen-solvers scipy's.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..errors import InputError

#: the paper's combinations (j, l), 1-based mode numbers (DIGEST Sec. 6)
PAPER_COMBINATIONS: tuple[tuple[int, int], ...] = (
    (1, 1), (1, 2), (1, 3), (1, 4), (1, 5), (2, 2), (2, 3), (2, 4), (2, 5))


@dataclass
class DualModeOptions:
    """Options of the dual-mode generation (DIGEST Sec. 6).

    combinations: (j, l) pairs of 1-based linear-mode numbers (j == l: single mode, Eq. 47);
    n_amplitudes: loads per combination (half positive, half negative);
    tip_range: predicted tip transverse displacement range as fractions of the span;
    normalize_snapshots: scale each residual to unit mass norm before the POD.
    """

    combinations: Sequence[tuple[int, int]] = PAPER_COMBINATIONS
    n_amplitudes: int = 20
    tip_range: tuple[float, float] = (0.001, 0.15)
    normalize_snapshots: bool = True


@dataclass
class Basis:
    """Basis Φ (n_dof, n) = [linear modes | dual modes], mass-orthonormal.

    Attributes: kinds ("linear"/"dual" per column), frequencies_hz (NaN for dual modes),
    pod_values (normalised POD spectrum, descending), snapshots (one record per static solve:
    combination, α, predicted and achieved tip displacement / span), seconds.
    """

    Phi: np.ndarray
    kinds: list[str]
    frequencies_hz: np.ndarray
    pod_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    snapshots: list[dict] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def n(self) -> int:
        return self.Phi.shape[1]


def linear_basis(backend, n_linear: int) -> Basis:
    """The n_linear lowest mass-normalised linear modes of the backend."""
    t0 = time.perf_counter()
    f, V = backend.modes(n_linear)
    return Basis(V, ["linear"] * n_linear, np.asarray(f, float), seconds=time.perf_counter() - t0)


def _m_project_out(R: np.ndarray, Phi: np.ndarray, M) -> np.ndarray:
    """Remove the components along the M-orthonormal columns of Φ (twice, for rounding)."""
    for _ in range(2):
        R = R - Phi @ (Phi.T @ np.asarray(M @ R))
    return R


def pod(snapshots: np.ndarray, M, n_keep: int) -> tuple[np.ndarray, np.ndarray]:
    """Mass-weighted POD (method of snapshots): (M-orthonormal vectors (n_dof, n_keep),
    normalised eigenvalues of all snapshots, descending, summing to 1)."""
    C = snapshots.T @ np.asarray(M @ snapshots)
    lam, V = scipy.linalg.eigh(0.5 * (C + C.T))
    lam, V = lam[::-1], V[:, ::-1]
    lam = np.clip(lam, 0.0, None)
    if n_keep > int(np.sum(lam > 1e-14 * lam[0])):
        raise InputError(f"dual modes: asked for {n_keep} but the {snapshots.shape[1]} snapshots "
                         f"span only {int(np.sum(lam > 1e-14 * lam[0]))} independent directions")
    W = snapshots @ V[:, :n_keep] / np.sqrt(lam[:n_keep])
    return W, lam / lam.sum()


def _amplitude_table(backend, U: np.ndarray, opts: DualModeOptions) -> np.ndarray:
    """α values: predicted (linear) tip transverse displacement spread uniformly over the range."""
    peak = np.abs(U[backend.transverse_dofs]).max()
    if peak == 0:
        peak = np.abs(U[backend.translational_dofs]).max()
    half = opts.n_amplitudes // 2
    lo, hi = opts.tip_range
    fr = np.linspace(lo, hi, half)
    alphas = np.concatenate([fr, -fr[: opts.n_amplitudes - half]])
    return alphas * backend.reference_length / peak


def dual_basis(backend, linear: Basis, n_dual: int, options: DualModeOptions | None = None,
               progress: Callable[[int, int], None] | None = None) -> Basis:
    """Linear modes + n_dual dual modes (DIGEST Sec. 6, Eqs. 47–48)."""
    opts = options or DualModeOptions()
    t0 = time.perf_counter()
    Phi_L = linear.Phi
    nL = Phi_L.shape[1]
    for (j, l) in opts.combinations:
        if not (1 <= j <= nL and 1 <= l <= nL):
            raise InputError(f"dual modes: combination ({j}, {l}) refers to a linear mode outside "
                             f"1..{nL}")
    if opts.n_amplitudes < 1 or not (0 < opts.tip_range[0] <= opts.tip_range[1]):
        raise InputError(f"dual modes: need n_amplitudes >= 1 and 0 < tip_range[0] <= "
                         f"tip_range[1], got {opts.n_amplitudes}, {opts.tip_range}")
    M, K = backend.mass_matrix(), backend.stiffness_matrix()
    KU = np.asarray(K @ Phi_L)
    total = len(opts.combinations) * opts.n_amplitudes
    snaps, records = [], []
    done = 0
    span = backend.reference_length
    for (j, l) in opts.combinations:
        cols = [j - 1] if j == l else [j - 1, l - 1]
        U = Phi_L[:, cols].sum(axis=1)
        F = KU[:, cols].sum(axis=1)
        alphas = _amplitude_table(backend, U, opts)
        tip_lin = np.abs(U[backend.transverse_dofs]).max()
        # continuation: solve each sign in order of increasing |α| from the previous solution
        for sign in (1.0, -1.0):
            prev_u, prev_a = None, None
            for a in sorted(alphas[np.sign(alphas) == sign], key=abs):
                u0 = None if prev_u is None else prev_u * (a / prev_a)
                sol = backend.static_solve(a * F, u0=u0)
                prev_u, prev_a = sol.u, a
                r = _m_project_out(sol.u[:, None], Phi_L, M)[:, 0]
                norm = float(np.sqrt(r @ np.asarray(M @ r)))
                snaps.append(r / norm if (opts.normalize_snapshots and norm > 0) else r)
                records.append({
                    "combination": [int(j), int(l)], "alpha": float(a),
                    "tip_linear_pct_span": float(100 * abs(a) * tip_lin / span),
                    "tip_pct_span": float(100 * np.abs(sol.u[backend.transverse_dofs]).max()
                                          / span),
                    "residual_mass_norm": norm, "iterations": int(sol.iterations),
                })
                done += 1
                if progress is not None:
                    progress(done, total)
    S = np.stack(snaps, axis=1)
    W, spectrum = pod(S, M, n_dual)
    W = _m_project_out(W, Phi_L, M)
    # mass-orthonormalise the dual vectors among themselves (symmetric, order-preserving)
    G = W.T @ np.asarray(M @ W)
    L = np.linalg.cholesky(0.5 * (G + G.T))
    W = scipy.linalg.solve_triangular(L, W.T, lower=True).T
    sign = np.sign(W[np.abs(W).argmax(axis=0), np.arange(n_dual)])
    W = W * np.where(sign == 0, 1.0, sign)
    Phi = np.concatenate([Phi_L, W], axis=1)
    return Basis(Phi, linear.kinds + ["dual"] * n_dual,
                 np.concatenate([linear.frequencies_hz, np.full(n_dual, np.nan)]),
                 spectrum, records, linear.seconds + time.perf_counter() - t0)
