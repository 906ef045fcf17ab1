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
are the default. A load the FE cannot carry (no converged static solution) is recorded as
"failed" and the larger loads of that combination and sign are skipped; the POD uses the rest.

Hand-written; the static solves are the backend's, the eigen-solvers scipy's.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..errors import ConvergenceError, InputError

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


@dataclass
class DualLoad:
    """One static load of the dual-mode generation: F = α Σ K U^(j) (Eqs. 47–48)."""

    combination: tuple[int, int]
    alpha: float
    load: np.ndarray
    tip_linear_pct_span: float


def dual_loads(backend, linear: Basis, options: DualModeOptions | None = None) -> list[DualLoad]:
    """The dual-mode loads in solution order: per combination and sign, increasing |α| (so each
    solve can start from the previous one — and so a Nastran SOL 106 run can continue)."""
    opts = options or DualModeOptions()
    Phi_L = linear.Phi
    nL = Phi_L.shape[1]
    for (j, l) in opts.combinations:
        if not (1 <= j <= nL and 1 <= l <= nL):
            raise InputError(f"dual modes: combination ({j}, {l}) refers to a linear mode outside "
                             f"1..{nL}")
    if opts.n_amplitudes < 1 or not (0 < opts.tip_range[0] <= opts.tip_range[1]):
        raise InputError(f"dual modes: need n_amplitudes >= 1 and 0 < tip_range[0] <= "
                         f"tip_range[1], got {opts.n_amplitudes}, {opts.tip_range}")
    KU = np.asarray(backend.stiffness_matrix() @ Phi_L)
    out = []
    for (j, l) in opts.combinations:
        cols = [j - 1] if j == l else [j - 1, l - 1]
        U = Phi_L[:, cols].sum(axis=1)
        F = KU[:, cols].sum(axis=1)
        alphas = _amplitude_table(backend, U, opts)
        tip_lin = np.abs(U[backend.transverse_dofs]).max()
        for sign in (1.0, -1.0):
            for a in sorted(alphas[np.sign(alphas) == sign], key=abs):
                out.append(DualLoad((int(j), int(l)), float(a), a * F,
                                    float(100 * abs(a) * tip_lin / backend.reference_length)))
    return out


def dual_modes_from_responses(linear: Basis, M, responses: np.ndarray, n_dual: int,
                              normalize: bool = True) -> tuple[Basis, np.ndarray]:
    """Dual modes from nonlinear static responses (rows of ``responses``): residuals outside the
    linear modes, mass-weighted POD, mass-orthonormalised. Returns (basis, residual mass norms)."""
    Phi_L = linear.Phi
    R = _m_project_out(np.atleast_2d(responses).T, Phi_L, M)
    norms = np.sqrt(np.einsum("ij,ij->j", R, np.asarray(M @ R)))
    if normalize:
        R = R / np.where(norms > 0, norms, 1.0)
    W, spectrum = pod(R, M, n_dual)
    W = _m_project_out(W, Phi_L, M)
    # mass-orthonormalise the dual vectors among themselves (Cholesky: order-preserving)
    G = W.T @ np.asarray(M @ W)
    L = np.linalg.cholesky(0.5 * (G + G.T))
    W = scipy.linalg.solve_triangular(L, W.T, lower=True).T
    sign = np.sign(W[np.abs(W).argmax(axis=0), np.arange(n_dual)])
    W = W * np.where(sign == 0, 1.0, sign)
    basis = Basis(np.concatenate([Phi_L, W], axis=1), linear.kinds + ["dual"] * n_dual,
                  np.concatenate([linear.frequencies_hz, np.full(n_dual, np.nan)]), spectrum)
    return basis, norms


def dual_basis(backend, linear: Basis, n_dual: int, options: DualModeOptions | None = None,
               progress: Callable[[int, int], None] | None = None) -> Basis:
    """Linear modes + n_dual dual modes (DIGEST Sec. 6, Eqs. 47–48), solved by the backend."""
    opts = options or DualModeOptions()
    t0 = time.perf_counter()
    loads = dual_loads(backend, linear, opts)
    responses, records = [], []
    prev = None          # (combination, sign, u, alpha) of the last converged solve
    failed = set()
    span = backend.reference_length
    for k, ld in enumerate(loads, start=1):
        if progress is not None:
            progress(k, len(loads))
        key = (ld.combination, np.sign(ld.alpha))
        rec = {"combination": list(ld.combination), "alpha": ld.alpha,
               "tip_linear_pct_span": ld.tip_linear_pct_span}
        if key in failed:
            # past a load the FE could not carry, the larger ones are skipped too
            records.append({**rec, "status": "skipped"})
            continue
        u0 = prev[2] * (ld.alpha / prev[3]) if prev is not None and prev[:2] == key else None
        try:
            sol = backend.static_solve(ld.load, u0=u0)
        except ConvergenceError as exc:
            failed.add(key)
            records.append({**rec, "status": "failed", "message": str(exc)})
            continue
        prev = (*key, sol.u, ld.alpha)
        responses.append(sol.u)
        records.append({**rec, "status": "ok", "iterations": int(sol.iterations),
                        "tip_pct_span": float(100 * np.abs(sol.u[backend.transverse_dofs]).max()
                                              / span)})
    basis, norms = dual_modes_from_responses(linear, backend.mass_matrix(), np.array(responses),
                                             n_dual, opts.normalize_snapshots)
    ok = [r for r in records if r["status"] == "ok"]
    for r, nrm in zip(ok, norms):
        r["residual_mass_norm"] = float(nrm)
    basis.snapshots = records
    basis.seconds = linear.seconds + time.perf_counter() - t0
    return basis
