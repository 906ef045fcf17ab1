"""Batched Newton iteration for periodic orbits with one free scalar and two linear conditions.

Unknowns per case z = [X (2H+1, n) flattened, ω, μ]: the Fourier coefficients, the angular
frequency (rad/s) and one scalar μ — a fictitious damping c (cold start, :mod:`.solve`) or a
continuation parameter (:mod:`.continuation`). Equations:

    R(X, ω, μ) = 0                    harmonic balance (:class:`~.balance.HarmonicBalance`)
    r · b_1 = 0                       phase condition: the output y = r·q has no sin τ term
    w · z = d                         one linear condition: an amplitude (w picks r·a_1), a
                                      fixed μ (w picks μ), or a pseudo-arclength condition

All B cases are solved together: one batched LU per iteration (rows equilibrated, because the
force rows of stiff dual coordinates are ~1e7 times the displacement rows). Each case stops on
its own once its scaled correction is below the tolerance; a case whose iterate turns non-finite
is marked and frozen, never touching its neighbours. Steps are limited to a fraction of the
orbit's size, which keeps Newton inside its basin on the stiff dual coordinates; a case that
needs :data:`MAX_LIMITED_STEPS` limited steps in a row is lost and stops, unconverged.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import torch

Tensor = torch.Tensor

#: the slaved coordinates are re-solved after steps larger than this (relative to the orbit)
SLAVE_ABOVE = 1e-3

#: a case stops, unconverged, after this many limited steps in a row (Newton has lost it: on
#: the paper's LCO sweep, ``torchrom paper --method hb``, none of the 273 cases that converged
#: took more than 2 limited steps in all, while the ones that did not wandered with limited
#: steps until ``max_iterations``, H = 3–19)
MAX_LIMITED_STEPS = 3

#: evaluate(X, ω, μ, active) -> (R, J, R_ω, R_μ) for the cases ``active`` (index tensor)
Evaluate = Callable[[Tensor, Tensor, Tensor, Tensor], tuple[Tensor, Tensor, Tensor, Tensor]]
#: residual(X, ω, μ, active) -> R
Residual = Callable[[Tensor, Tensor, Tensor, Tensor], Tensor]


@dataclass(frozen=True)
class NewtonOptions:
    """Newton settings.

    Attributes:
        max_iterations: iterations before a case is declared unconverged.
        tol: convergence on the correction, relative to the orbit's largest coefficient
            (and to ω for the frequency).
        max_step: largest correction of the coefficients per iteration, as a fraction of the
            orbit's largest coefficient (and of ω for the frequency).
    """

    max_iterations: int = 25
    tol: float = 1e-7
    max_step: float = 0.5


@dataclass
class NewtonResult:
    """Per-case outcome: the iterate, convergence flags, iterations and the last scaled
    residual max |R| / (max |J| · max |X|) (the force error relative to the largest force the
    Jacobian can produce on the orbit)."""

    X: Tensor
    omega: Tensor
    mu: Tensor
    converged: Tensor
    iterations: Tensor
    residual: Tensor
    jacobian_solves: int = 0
    #: sign of the determinant of the augmented Jacobian at the last iteration (±1)
    det_sign: Tensor | None = None


def newton(evaluate: Evaluate, X: Tensor, omega: Tensor, mu: Tensor, phase_row: Tensor,
           w: Tensor, d: Tensor, scale: Tensor, options: NewtonOptions = NewtonOptions(),
           active: Tensor | None = None, residual_fn: Residual | None = None,
           slaved: Tensor | None = None) -> NewtonResult:
    """Solve the augmented system (module docstring) for the cases ``active`` (default all).

    Args:
        X (B, nh, n), omega (B,), mu (B,): the starting iterate (not modified).
        phase_row: (n,) the output row r of the phase condition.
        w: (B, nh·n + 2) and d (B,): the linear condition w·z = d.
        scale: (B,) a size of the orbit's coefficients (the step limit and the tolerance use
            max(scale, max |X|)).
        residual_fn, slaved: with both, after every Newton step the equations of the coordinates
            ``slaved`` (indices into n, e.g. the stiff dual modes) are solved once more for
            those coordinates alone (one residual evaluation and a solve with the step's
            Jacobian block): their response is quadratic in the others, so a plain Newton step
            leaves them far off their slow manifold and the next step overshoots.
    """
    X, omega, mu = X.clone(), omega.clone(), mu.clone()
    B, nh, n = X.shape
    nz = nh * n + 2
    converged = torch.zeros(B, dtype=torch.bool, device=X.device)
    iterations = torch.zeros(B, dtype=torch.long, device=X.device)
    residual = torch.full((B,), float("nan"), dtype=X.dtype, device=X.device)
    det_sign = torch.zeros(B, dtype=X.dtype, device=X.device)
    todo = torch.arange(B, device=X.device) if active is None else active.clone()
    solves = 0
    # the last unlimited step of every case, relative to its orbit (inf: none yet)
    prev_rel = torch.full((B,), math.inf, dtype=X.dtype, device=X.device)
    limited = torch.zeros(B, dtype=torch.long, device=X.device)  # limited steps in a row
    for _ in range(options.max_iterations):
        if todo.numel() == 0:
            break
        Xa, wa, ma = X[todo], omega[todo], mu[todo]
        R, J, R_w, R_m = evaluate(Xa, wa, ma, todo)
        Ba = len(todo)
        A = X.new_zeros(Ba, nz, nz)
        A[:, : nh * n, : nh * n] = J
        A[:, : nh * n, -2] = R_w.reshape(Ba, -1)
        A[:, : nh * n, -1] = R_m.reshape(Ba, -1)
        A[:, -2, 2 * n: 3 * n] = phase_row  # r · b_1
        A[:, -1] = w[todo]
        z = torch.cat([Xa.reshape(Ba, -1), wa[:, None], ma[:, None]], dim=1)
        rhs = torch.cat([R.reshape(Ba, -1), (Xa[:, 2] @ phase_row)[:, None],
                         ((w[todo] * z).sum(1) - d[todo])[:, None]], dim=1)
        sol, ok, det_sign[todo] = equilibrated_solve(A, rhs)
        step = -sol
        solves += 1
        size = torch.maximum(Xa.abs().amax(dim=(1, 2)), scale[todo])
        dX = step[:, : nh * n]
        dxmax = dX.abs().amax(dim=1)
        lam = torch.clamp(options.max_step * size / dxmax.clamp_min(1e-300), max=1.0)
        lam = torch.minimum(lam, torch.clamp(0.2 * wa.abs() / step[:, -2].abs().clamp_min(
            1e-300), max=1.0))
        step = step * lam[:, None]
        znew = z + step
        # converged when the step is below the tolerance, or when the contraction of the
        # last two steps, θ = |Δ_k| / |Δ_{k−1}| < 1/2, bounds the error left after this one,
        # θ/(1 − θ)|Δ_k| (Hairer & Wanner, Solving ODEs II, Sec. IV.8): a quadratically
        # converging case stops one Jacobian early
        rel = torch.maximum(dxmax / size, step[:, -2].abs() / wa.abs().clamp_min(1e-300))
        prev = prev_rel[todo]
        theta = torch.where(torch.isfinite(prev), rel / prev, torch.full_like(rel, math.inf))
        left = torch.where((lam >= 1) & (theta < 0.5), theta / (1 - theta) * rel, rel)
        done = ok & (left <= options.tol)
        prev_rel[todo] = torch.where(lam >= 1, rel, torch.full_like(rel, math.inf))
        Xn = znew[:, : nh * n].view(Ba, nh, n)
        # the slaved coordinates are re-solved while the steps are large (near the solution a
        # plain Newton step converges quadratically on them too: a residual saved per step)
        far = ok & ~done & (rel > SLAVE_ABOVE)
        if residual_fn is not None and slaved is not None and slaved.numel() and bool(
                far.any()):
            f = torch.nonzero(far).reshape(-1)
            Xn = Xn.clone()
            Xn[f] = _resolve_slaved(residual_fn, J[f], Xn[f], znew[f, -2], znew[f, -1], todo[f],
                                    slaved, torch.ones_like(f, dtype=torch.bool))
        X[todo] = torch.where(ok[:, None, None], Xn, Xa)
        omega[todo] = torch.where(ok, znew[:, -2], wa)
        mu[todo] = torch.where(ok, znew[:, -1], ma)
        iterations[todo] += 1
        rs = R.abs().amax(dim=(1, 2)) / (J.abs().amax(dim=(1, 2)) * size).clamp_min(1e-300)
        residual[todo] = rs
        converged[todo] = done
        # a failed case (singular or non-finite) stops, unconverged, and so does one that
        # took MAX_LIMITED_STEPS limited steps in a row; converged cases stop
        limited[todo] = torch.where(lam < 1, limited[todo] + 1, torch.zeros_like(lam,
                                                                                dtype=torch.long))
        keep = ok & ~done & (limited[todo] < MAX_LIMITED_STEPS)
        todo = todo[keep]
    return NewtonResult(X, omega, mu, converged, iterations, residual, solves, det_sign)


def _resolve_slaved(residual: Residual, J: Tensor, X: Tensor, omega: Tensor, mu: Tensor,
                    active: Tensor, slaved: Tensor, ok: Tensor) -> Tensor:
    """X with the slaved coordinates corrected by one Newton step on their own equations
    (the other unknowns held), using the Jacobian block of the step just taken."""
    B, nh, n = X.shape
    rows = (torch.arange(nh, device=X.device)[:, None] * n + slaved[None, :]).reshape(-1)
    R = residual(X, omega, mu, active).reshape(B, -1)[:, rows]
    Jd = J[:, rows][:, :, rows]
    sol, solved, _ = equilibrated_solve(Jd, R)
    dx = -sol
    good = ok & solved
    Xf = X.reshape(B, -1).clone()
    Xf[:, rows] = torch.where(good[:, None], Xf[:, rows] + dx, Xf[:, rows])
    return Xf.view(B, nh, n)


def _max_magnitude(A: Tensor, dim: int) -> Tensor:
    """max |A| along ``dim`` without the |A| temporary (NaN where a NaN is)."""
    return torch.maximum(A.amax(dim=dim), A.amin(dim=dim).neg())


@dataclass
class EquilibratedLU:
    """The LU factors of batched matrices A (B, m, m) with rows and then columns scaled to
    unit largest entry (:func:`equilibrated_lu`), for any number of right-hand sides."""

    lu: Tensor
    piv: Tensor
    row: Tensor
    col: Tensor
    ok: Tensor

    def solve(self, b: Tensor) -> tuple[Tensor, Tensor]:
        """(x, ok) of A x = b (b (B, m)); x = 0 where the case failed."""
        finite = torch.isfinite(b).all(dim=1)
        b = torch.where(finite[:, None], b, torch.zeros_like(b)) / self.row
        with single_thread():
            x = torch.linalg.lu_solve(self.lu, self.piv, b[..., None])[..., 0] / self.col
        ok = self.ok & finite & torch.isfinite(x).all(dim=1)
        return torch.where(ok[:, None], x, torch.zeros_like(x)), ok

    @property
    def det_sign(self) -> Tensor:
        """sign(det A) (the equilibration factors are positive): Π sign(U_ii) · (−1)^swaps."""
        m = self.lu.shape[-1]
        swaps = (self.piv != torch.arange(1, m + 1, device=self.piv.device,
                                          dtype=self.piv.dtype)).sum(1)
        return torch.sign(self.lu.diagonal(dim1=1, dim2=2)).prod(1) * (
            1.0 - 2.0 * (swaps % 2)).to(self.lu.dtype)


def equilibrated_lu(A: Tensor) -> EquilibratedLU:
    """The factors of A (B, m, m) with rows and then columns scaled to unit largest entry
    before the LU (the force rows of stiff dual coordinates are orders above the others, their
    unknowns orders below). A case whose matrix is not finite, singular or whose LU fails is
    marked (``ok`` False) and never disturbs the others (its matrix is replaced by the
    identity before the batched factorisation)."""
    m = A.shape[-1]
    eye = torch.eye(m, dtype=A.dtype, device=A.device)
    tiny = torch.finfo(A.dtype).tiny
    # a row's largest magnitude is NaN or inf exactly when the row holds one (amax and amin
    # propagate NaN): a finiteness check of A at the cost of a vector's. max(amax, −amin)
    # rather than the inf-norm: torch 2.13's CPU vector_norm(ord=inf) is ~3x slower (a tenth
    # of a Goland UQ case), |A| a temporary of A's size; A is scaled in one new copy, the
    # caller's matrix left alone
    row = _max_magnitude(A, 2)
    finite = torch.isfinite(row).all(dim=1)
    if not bool(finite.all()):
        A = torch.where(finite[:, None, None], A, eye)
        row = torch.where(finite[:, None], row, torch.ones_like(row))
    row = row.clamp_min(tiny)
    A = A / row[..., None]
    col = _max_magnitude(A, 1).clamp_min(tiny)
    A.div_(col[:, None, :])
    with single_thread():
        lu, piv, info = torch.linalg.lu_factor_ex(A)
        # a finite matrix factors into finite factors unless a pivot vanished (then U's
        # diagonal holds the zero or the overflow): U's diagonal is the check
        valid = (piv >= 1).all(dim=1) & (info == 0) & torch.isfinite(
            lu.diagonal(dim1=1, dim2=2)).all(dim=1)
        if not bool(valid.all()):  # refactor with the failed cases replaced
            A = torch.where(valid[:, None, None], A, eye)
            lu, piv, info = torch.linalg.lu_factor_ex(A)
    return EquilibratedLU(lu, piv, row, col, finite & valid)


def equilibrated_solve(A: Tensor, b: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """(x, ok, sign det A) of the batched systems A x = b (A (B, m, m), b (B, m)) through
    :func:`equilibrated_lu`; a failed case gets x = 0 and ok = False."""
    f = equilibrated_lu(A)
    x, ok = f.solve(b)
    return x, ok, f.det_sign


@contextlib.contextmanager
def single_thread() -> Iterator[None]:
    """torch's intra-op threads set to one for the block (restored after). torch 2.13's CPU
    batched LU — MKL's getrf inside torch's parallel loop over the batch — returned invalid
    pivots ("Parameter 6 was incorrect on entry to DLASWP") or hung on this machine with two
    threads, for batches of matrices of about 150 rows and more (every Goland Newton system):
    the factorisations run on one thread, which for many small matrices costs nothing."""
    threads = torch.get_num_threads()
    if threads == 1:
        yield
        return
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)
