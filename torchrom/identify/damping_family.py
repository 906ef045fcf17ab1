"""Admissible damping decompositions: a one-parameter family between two of them (issue 15).

A decomposition (G, H) of the energy-form tensors (:mod:`.damping`) is admissible when it
reproduces the identified K2, K3 coefficients (paper Eqs. 16, 25–27: an affine set), gives the
Kelvin–Voigt tensors D̄1 = K1, D̄2, D̄3 (Eqs. 42–44) and has a positive semidefinite extended
matrix (Eq. 45); *strictly* admissible when it reproduces K2, K3 to identification accuracy
(:data:`STRICT_REPRODUCTION`). The set is convex, so :func:`damping_family` returns
m(θ) = (1 − θ) m_A + θ m_B between the pipeline's optimum decomposition and the exact tensors of
the FE material (projected onto the identified coefficients), each member checked rather than
assumed; :func:`restored_min_eigenvalue` shows what the optimum decomposition's reproduction
error buys. :func:`sdp_member` is the criterion's own optimum over the whole set: maximise t
with the scaled extended matrix − t I semidefinite, a semidefinite program solved by SCS
(O'Donoghue et al.).

Over :mod:`.damping`; the eigen-solvers are torch's, the conic solver SCS's.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from ..rom import NonlinearROM
from ..rom import conventions as cv
from . import damping as dmp

#: smallest scaled eigenvalue an admissible member may have: the decomposition's own margin
#: (:class:`~.damping.DecompositionOptions`) less rounding of the scaled matrix (entries ~1)
ADMISSIBLE_FLOOR = -1e-9
#: relative error to which a *strictly* admissible member's G, H reproduce the identified K2, K3
#: (identification accuracy; rounding gives ~1e-15)
STRICT_REPRODUCTION = 1e-6
#: SCS iteration limit and tolerance of :func:`sdp_member`. The optimum t* is ~1.5e-5 on the
#: quick Goland 9L12D ROM (before issue 48 SCS stopped at 2,000 iterations, "inaccurate", with
#: t* = 3.6e-3). Over the null-space coordinates (:func:`_sdp_entries`) SCS reports "solved" at
#: 1e-6 in ~2,900 iterations (~28 s on one thread) with t* within ~4e-6 of the member's
#: own λ_min; at 1e-5 t* is only within ~1e-4 (benchmarks/bench_damping_decomposition.py)
SDP_ITERATIONS = 10000
SDP_EPS = 1e-6


@dataclass
class DampingMember:
    """One admissible decomposition: ``theta`` (0: the first tensor set, 1: the second), the
    damping tensors at γ = 1 (symmetric storage) and the checks of the module docstring."""

    name: str
    theta: float
    D1: np.ndarray
    D2: np.ndarray
    D3: np.ndarray
    min_eigenvalue_scaled: float
    reproduction_error_K2: float
    reproduction_error_K3: float
    #: the reproduction error a member may have: the first tensor set's own (the study's
    #: decomposition, whose enforcement of semidefiniteness gives up some K̃3 reproduction), at
    #: least :data:`STRICT_REPRODUCTION`
    tolerance: float = STRICT_REPRODUCTION
    #: how the member was found (the SDP's solver report; empty for the family's members)
    report: dict = field(default_factory=dict)

    def _within(self, tol: float) -> bool:
        return (self.min_eigenvalue_scaled >= ADMISSIBLE_FLOOR
                and max(self.reproduction_error_K2, self.reproduction_error_K3) <= tol)

    @property
    def admissible(self) -> bool:
        """Semidefinite and as faithful to K2, K3 as the first tensor set."""
        return self._within(self.tolerance)

    @property
    def strict(self) -> bool:
        """Semidefinite and reproducing K2, K3 to identification accuracy."""
        return self._within(STRICT_REPRODUCTION)

    def summary(self) -> dict:
        return {"name": self.name, "theta": self.theta, "admissible": self.admissible,
                "strict": self.strict, "tolerance": self.tolerance,
                "min_eigenvalue_scaled": self.min_eigenvalue_scaled,
                "reproduction_error_K2": self.reproduction_error_K2,
                "reproduction_error_K3": self.reproduction_error_K3,
                **({"solver": self.report} if self.report else {})}

    def rom(self, base: NonlinearROM) -> NonlinearROM:
        """``base`` with this member's damping tensors (stiffness and basis unchanged)."""
        return base.replace(D1=torch.as_tensor(self.D1), D2=torch.as_tensor(self.D2),
                            D3=torch.as_tensor(self.D3))


def _entries(p: dmp.DecompositionProblem, D2, D3) -> torch.Tensor:
    """Scaled class entries of the (G, H) of Kelvin–Voigt tensors D̄2, D̄3."""
    G, H = cv.gram_from_damping(torch.as_tensor(D2), torch.as_tensor(D3))
    return torch.as_tensor(p.fs * dmp._class_values(p.st, G.numpy(), H.numpy()))


def _onto_admissible(p: dmp.DecompositionProblem, m: torch.Tensor, floor: float) -> torch.Tensor:
    """m on the affine set of the identified coefficients when its extended matrix stays at
    λ_min ≥ ``floor`` there; otherwise m itself if it already is (the optimum decomposition: its
    Schur-complement step gave up a little K̃3 reproduction for semidefiniteness), else the
    projection raised to ``floor`` by that same Schur-complement step."""
    K1hat = torch.as_tensor(p.K1hat)

    def lam(x):
        return float(torch.linalg.eigvalsh(dmp._assemble(p.st, K1hat, x))[0])

    on = dmp._affine_projector(p.st, p.alpha_hat, p.b)(m)
    if lam(on) >= floor:
        return on
    if lam(m) >= ADMISSIBLE_FLOOR:
        return m
    return dmp._schur_clip(p.st, K1hat, on, floor)


def _member(p: dmp.DecompositionProblem, name: str, theta: float, m: torch.Tensor
            ) -> DampingMember:
    G, H, err2, err3 = p.tensors(m.numpy())
    D1, D2, D3 = cv.damping_from_gram(torch.as_tensor(p.K1), torch.as_tensor(G),
                                      torch.as_tensor(H))
    return DampingMember(name, float(theta), D1.numpy(), D2.numpy(), D3.numpy(),
                         _min_eigenvalue(p, m), err2, err3)


def _tolerance(first: DampingMember) -> float:
    """The reproduction error a member may have: the first tensor set's own, at least
    :data:`STRICT_REPRODUCTION` (:attr:`DampingMember.tolerance`)."""
    return max(STRICT_REPRODUCTION, first.reproduction_error_K2, first.reproduction_error_K3)


def _min_eigenvalue(p: dmp.DecompositionProblem, m: torch.Tensor) -> float:
    return float(torch.linalg.eigvalsh(dmp._assemble(p.st, torch.as_tensor(p.K1hat), m))[0])


def restored_min_eigenvalue(rom: NonlinearROM, damped: NonlinearROM) -> float:
    """Smallest scaled eigenvalue of ``damped``'s decomposition once the identified K2, K3
    coefficients of ``rom`` are restored exactly (Frobenius projection onto their affine set):
    negative where the decomposition is semidefinite only thanks to its reproduction error."""
    with dmp._one_thread():
        p = dmp.decomposition_problem(rom.K1.numpy(), rom.K2.numpy(), rom.K3.numpy())
        m = dmp._affine_projector(p.st, p.alpha_hat, p.b)(_entries(p, damped.D2, damped.D3))
        return _min_eigenvalue(p, m)


def damping_family(rom: NonlinearROM, first: NonlinearROM, second: NonlinearROM,
                   thetas: Sequence[float], names: tuple[str, str] = ("decomposition", "exact"),
                   floor: float = 1e-9) -> list[DampingMember]:
    """Admissible decompositions m(θ) = (1 − θ) m_first + θ m_second for ``thetas`` in [0, 1]
    (0 and 1 are the two tensor sets themselves, brought onto the admissible set).

    ``rom``: the identified stiffness (K1, K2, K3) every member must reproduce; ``first``,
    ``second``: ROMs on the same basis whose D̄2, D̄3 are Kelvin–Voigt tensors (e.g. the optimum
    decomposition and ``damping="exact"``). Returns one :class:`DampingMember` per θ, checked.
    """
    if any(not 0.0 <= float(t) <= 1.0 for t in thetas):
        raise ValueError(f"damping_family: thetas must lie in [0, 1], got {list(thetas)}")
    with dmp._one_thread():
        p = dmp.decomposition_problem(rom.K1.numpy(), rom.K2.numpy(), rom.K3.numpy())
        ends = [_onto_admissible(p, _entries(p, r.D2, r.D3), floor) for r in (first, second)]
        tol = _tolerance(_member(p, names[0], 0.0, ends[0]))
        out = []
        for t in thetas:
            t = float(t)
            name = names[0] if t == 0.0 else names[1] if t == 1.0 else f"θ = {t:g}"
            member = _member(p, name, t, (1.0 - t) * ends[0] + t * ends[1])
            member.tolerance = tol
            out.append(member)
    return out


def _sdp_entries(p: dmp.DecompositionProblem, iterations: int, eps: float
                 ) -> tuple[torch.Tensor, dict]:
    """Class entries maximising the smallest eigenvalue of the scaled extended matrix over the
    affine set of the identified coefficients (SCS), and the solver's report.

    The affine set is parametrised by its null-space coordinates x (m = m_p + Σ x_a d_a, m_p
    the minimum-norm point, d_a the decomposition's null directions: orthonormal in the
    Frobenius metric), so every iterate reproduces the identified coefficients exactly and the
    map x -> svec(X) is an isometry: max t s.t. X(x) − t I ⪰ 0, one PSD cone, no zero cone.
    (As a zero cone of the coefficients in scaled units, whose rows span 1e-2..1e6, SCS stalled
    at its iteration limit; benchmarks/bench_damping_decomposition.py.) A warm start from the
    study's decomposition saved 3–18 % of the iterations there: not worth its code.
    """
    import scipy.sparse as sp

    try:
        import scs
    except ImportError as exc:  # a dependency of torchrom; only a broken install lacks it
        raise ImportError("damping decomposition SDP: the package 'scs' is missing; "
                          "pip install -c constraints.txt -e .") from exc
    st, K1hat = p.st, torch.as_tensor(p.K1hat)
    n = st.n
    N = n + n * (n + 1) // 2
    project = dmp._affine_projector(st, p.alpha_hat, p.b)
    m_p = project(torch.zeros(len(st.rows), dtype=torch.float64))
    null = dmp.whole_null(dmp._null_spaces(st, p.alpha_hat), n)
    P = len(null.subset)

    def vidx(i, j):  # SCS's PSD cone: the lower triangle, column by column
        return j * N - j * (j - 1) // 2 + (i - j)

    # PSD cone: svec(X(m_p) + Σ x_a D_a − t I) = b_p − A_p [x; t] (off-diagonal entries scaled
    # by √2, SCS's convention for the vectorised symmetric matrix)
    lo, hi = np.maximum(st.rows, st.cols), np.minimum(st.rows, st.cols)
    scale = np.where(lo == hi, 1.0, np.sqrt(2.0))
    diag = vidx(np.arange(N), np.arange(N))
    Ap = sp.csc_matrix((np.concatenate([-scale[null.cls] * null.val, np.ones(N)]),
                        (np.concatenate([vidx(lo, hi)[null.cls], diag]),
                         np.concatenate([null.par, np.full(N, P)]))),
                       shape=(N * (N + 1) // 2, P + 1))
    X0 = dmp._assemble(st, K1hat, m_p).numpy()
    il, jl = np.tril_indices(N)
    bp = np.zeros(N * (N + 1) // 2)
    bp[vidx(il, jl)] = X0[il, jl] * np.where(il == jl, 1.0, np.sqrt(2.0))
    c = np.zeros(P + 1)
    c[-1] = -1.0  # maximise t
    solver = scs.SCS({"A": Ap, "b": bp, "c": c}, {"s": [N]}, eps_abs=eps, eps_rel=eps,
                     max_iters=iterations, verbose=False)
    t0 = time.perf_counter()
    sol = solver.solve()
    x = np.asarray(sol["x"])
    m = m_p + torch.as_tensor(np.bincount(null.cls, null.val * x[null.par],
                                          minlength=len(st.rows)))
    info = sol["info"]
    return m, {"solver": "SCS", "status": info["status"], "iterations": int(info["iter"]),
               "seconds": time.perf_counter() - t0, "optimum_t": float(x[-1]), "eps": eps,
               "parameters": P,
               "primal_residual": float(info["res_pri"]),
               "dual_residual": float(info["res_dual"]), "gap": float(info["gap"]),
               # λ_min of the solver's own matrix: an admissible point, so at most t* (checked)
               "min_eigenvalue_scaled_solver": _min_eigenvalue(p, m)}


def sdp_member(rom: NonlinearROM, first: NonlinearROM, iterations: int = SDP_ITERATIONS,
               eps: float = SDP_EPS, floor: float = 1e-9) -> DampingMember:
    """The decomposition criterion's optimum (module docstring) as a :class:`DampingMember`
    named "sdp" (θ NaN: not on the family's segment), checked like the others; admissible by
    the standard of ``first`` (the study's decomposition, as :func:`damping_family`)."""
    with dmp._one_thread():
        p = dmp.decomposition_problem(rom.K1.numpy(), rom.K2.numpy(), rom.K3.numpy())
        m, report = _sdp_entries(p, iterations, eps)
        # the solver's iterate is on the affine set by construction: re-imposed to rounding
        m = dmp._affine_projector(p.st, p.alpha_hat, p.b)(m)
        report["min_eigenvalue_scaled_projected"] = _min_eigenvalue(p, m)
        if report["min_eigenvalue_scaled_projected"] < floor:
            m = dmp._schur_clip(p.st, torch.as_tensor(p.K1hat), m, floor)
        member = _member(p, "sdp", float("nan"), m)
        member.tolerance = _tolerance(_member(
            p, "first", 0.0, _onto_admissible(p, _entries(p, first.D2, first.D3), floor)))
    member.report = report
    return member
