"""Analyses on an :class:`~torchrom.fe.model.FEModel`: modes, nonlinear statics, transient.

Delegated: the sparse eigensolver (``scipy.sparse.linalg.eigsh``, shift-invert Lanczos/ARPACK),
dense ``scipy.linalg.eigh`` for small models, and sparse LU (``splu``). Written here: the shift,
mass normalisation and sign convention of the modes; Newton–Raphson with load stepping and step
cutting; the displacement-controlled variant; Newmark (average acceleration) with Newton
iterations, Rayleigh damping α M + β K and Kelvin–Voigt damping γ K_mat(u) u̇ (DIGEST Eqs. 46,
51–54 at the FE level).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..eigen import arpack_start, orient_columns
from ..errors import ConvergenceError, InputError
from .dead_load import DeadLoad, applied, reference
from .kinds import classify

#: An eigenvalue ω² at or below this fraction of the model's stiffness-to-mass scale
#: (mean |diag K| / mean |diag M|) is a rigid-body (zero-energy) mode. Rigid-body eigenvalues
#: come out at rounding level, the lowest elastic ones above it. Measured on the public decks
#: (tests/decks) and the project's models: rigid-body at most 1.5e-12 of the scale (the free
#: Dakota cylinder, CQUAD4 with RBE2; ≤ 4e-13 on the others), elastic at least 7.3e-10 (NX's
#: random_test, whose CBUSH's 1e9 rotational springs dominate the mean diagonal: its 12.7 Hz
#: mode; next 2.4e-6, the strut-braced wing). 3e-11 leaves 1.3 decades on either side (it was
#: 1e-8, which counted random_test's first two elastic modes as rigid-body ones).
RIGID_BODY_TOL = 3e-11


@dataclass
class Modes:
    """Linear normal modes: ``frequencies_hz (n,)``, mass-normalised ``shapes (n_dof, n)``
    (Φᵀ M Φ = I, signs by :func:`orient_columns`), ``kinds`` (bending,
    torsion, in-plane, axial), ``eigenvalues`` ω² (rad²/s²), ``fractions`` (content per kind),
    ``notes`` (fewer finite modes than asked, DOFs without stiffness or mass).

    These are the *elastic* modes. An unconstrained or under-constrained model also has
    rigid-body (zero-energy) modes: their eigenvalues (near zero, of either sign; never clipped)
    are ``rigid_eigenvalues`` and their shapes ``rigid_shapes``; ``n_rigid`` counts them.
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    kinds: list[str]
    eigenvalues: np.ndarray
    fractions: list[dict[str, float]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    rigid_eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rigid_shapes: np.ndarray | None = None

    @property
    def n_rigid(self) -> int:
        return len(self.rigid_eigenvalues)

    def records(self, reference_hz=None) -> list[dict]:
        """One dict per mode: mode, frequency_hz, kind (+ paper_hz, diff_pct when given).

        Rigid-body modes come first (kind ``rigid-body``, ``frequency_hz`` = sign(ω²)·√|ω²|/2π,
        ``eigenvalue`` ω²), numbered like Nastran's; the elastic modes follow."""
        out = []
        for i, lam in enumerate(self.rigid_eigenvalues):
            f = float(np.sign(lam) * np.sqrt(abs(lam)) / (2 * np.pi))
            out.append({"mode": i + 1, "frequency_hz": f, "kind": "rigid-body",
                        "eigenvalue": float(lam)})
        r = self.n_rigid
        for i, f in enumerate(self.frequencies_hz):
            rec = {"mode": r + i + 1, "frequency_hz": float(f), "kind": self.kinds[i]}
            if reference_hz is not None:
                ref = reference_hz[i] if i < len(reference_hz) else None
                rec["paper_hz"] = ref
                rec["diff_pct"] = None if ref is None else 100.0 * (float(f) - ref) / ref
            rec.update({f"content_{k}": v for k, v in self.fractions[i].items()})
            out.append(rec)
        return out


def relieved_load(M: sp.spmatrix, rigid: np.ndarray, f: np.ndarray) -> np.ndarray:
    """f − M G Gᵀ f: the load ``f`` balanced by the inertia loads of the rigid-body
    acceleration it causes (Nastran's inertia relief, INREL; G the M-orthonormal rigid-body
    shapes, Gᵀ M G = I, so the acceleration is a = Gᵀ f and Gᵀ (f − M G a) = 0)."""
    return f - np.asarray(M @ (rigid @ (rigid.T @ f)))


def _bordered(A: sp.spmatrix, MG: np.ndarray) -> sp.csc_matrix:
    """[[A, M G], [Gᵀ M, 0]]: A with the rigid-body accelerations as unknowns and the
    constraint Gᵀ M u = 0 (the response M-orthogonal to the rigid-body modes)."""
    r = MG.shape[1]
    return sp.csc_matrix(sp.bmat([[sp.csr_matrix(A), sp.csr_matrix(MG)],
                                  [sp.csr_matrix(MG.T), sp.csr_matrix((r, r))]]))


def inertia_relief_solve(K: sp.spmatrix, M: sp.spmatrix, rigid: np.ndarray,
                         f: np.ndarray) -> np.ndarray:
    """Linear static response of a free (or under-constrained) structure under inertia relief:
    u with K u = f − M G Gᵀ f (:func:`relieved_load`) and Gᵀ M u = 0, G (n, r) the
    M-orthonormal rigid-body shapes (K G = 0). Solved as the bordered system
    K u + M G a = f, Gᵀ M u = 0 (a: the rigid-body accelerations, = Gᵀ f), which is
    non-singular without a support set: the same answer as Nastran's SUPORT-supported INREL
    solve made M-orthogonal to the rigid-body modes."""
    f = np.asarray(f, dtype=float)
    MG = np.asarray(M @ rigid)
    sol = solve_linear(_bordered(K, MG), np.concatenate([f, np.zeros((MG.shape[1],)
                                                                     + f.shape[1:])]))
    return sol[: K.shape[0]]


def inertia_relief_static(fe, load: np.ndarray, rigid: np.ndarray, *, u0=None,
                          max_cuts: int = 10, max_iter: int = 30,
                          tol: float = 1e-9) -> StaticResult:
    """Nonlinear static solution of a free structure under inertia relief: f(u) + M G a = λ F
    with Gᵀ M u = 0 for λ from 0 to 1 (G: M-orthonormal rigid-body shapes; a: the rigid-body
    accelerations, Lagrange multipliers that balance the load, = Gᵀ F in the linear case).
    Newton on the bordered tangent [[K_T(u), M G], [Gᵀ M, 0]]. ``u0`` is a guess of the
    solution at the full load (continuation): tried first for λ = 1; when Newton fails from it,
    the load is stepped from the unloaded state u = 0 (a guess that failed is no solution at
    any λ, and every cut step retried from it failed too: the BAH aircraft's dual-mode walk
    spent minutes there). Step cutting as :func:`static_solve`: a failed step is halved, up to
    ``max_cuts`` times in all, and an easy step after a cut doubles the next one, so the work
    is bounded by about (2 ``max_cuts`` + 1) ``max_iter`` Newton iterations and the result
    says ``converged=False`` with the load factor reached. Convergence:
    ‖r‖ ≤ tol · max(‖λF‖, ‖f(u)‖)."""
    n = fe.n_dof
    F = np.asarray(load, dtype=float).reshape(-1)
    if F.shape != (n,):
        raise InputError(f"inertia_relief_static: load: expected {n} free-DOF entries, got "
                         f"{F.shape}")
    MG = np.asarray(fe.mass_matrix() @ rigid)
    r = MG.shape[1]
    u, a = np.zeros(n), np.zeros(r)
    total, res = 0, 0.0
    if u0 is not None:
        guess = np.array(u0, dtype=float)
        guess = guess - rigid @ (MG.T @ guess)  # a start M-orthogonal to the rigid-body modes
        ok, u_new, a_new, its, res = _relief_newton(fe, guess, a, F, MG, max_iter, tol)
        total += its
        if ok:
            return StaticResult(u_new, True, total, 1.0, res, 1)
    lam, dlam, cuts, steps = 0.0, 1.0, 0, 0
    while lam < 1.0 - 1e-14:
        target = min(1.0, lam + dlam)
        ok, u_new, a_new, its, res = _relief_newton(fe, u, a, target * F, MG, max_iter, tol)
        total += its
        if ok:
            u, a, lam, steps = u_new, a_new, target, steps + 1
            if dlam < 1.0 and its <= max_iter // 4:
                dlam *= 2.0  # an easy step after a cut: lengthen again (as static_solve)
            continue
        cuts += 1
        if cuts > max_cuts:
            return StaticResult(u, False, total, lam, res, steps,
                                message=f"inertia_relief_static: no convergence after "
                                        f"{max_cuts} step cuts at load factor {lam:.4g} "
                                        f"(residual {res:.3g} of the load {np.linalg.norm(F):.3g})",
                                failed_load_factor=target)
        dlam /= 2.0
    return StaticResult(u, True, total, 1.0, res, steps)


def _relief_newton(fe, u, a, F, MG, max_iter, tol):
    u, a = u.copy(), a.copy()
    n, res, first = len(u), np.inf, None
    for it in range(1, max_iter + 1):
        f = fe.internal_force(u)
        ru = f + MG @ a - F
        res = float(np.linalg.norm(ru))
        if not np.isfinite(res):
            return False, u, a, it, res
        if res <= tol * max(np.linalg.norm(F), np.linalg.norm(f), 1e-300):
            return True, u, a, it - 1, res
        first = res if first is None else first
        if it > 3 and res > 1e3 * first:
            return False, u, a, it, res
        rhs = np.concatenate([ru, MG.T @ u])
        try:
            d = solve_linear(_bordered(fe.tangent_stiffness(u), MG), rhs)
        except (RuntimeError, la.LinAlgError):
            return False, u, a, it, res
        u, a = u - d[:n], a - d[n:]
    return False, u, a, max_iter, res


def solve_linear(K: sp.spmatrix, r: np.ndarray) -> np.ndarray:
    """K⁻¹ r by sparse LU (SuperLU). Single-threaded, so it does not degrade when the cores are
    shared, unlike a multi-threaded dense LU."""
    return sla.splu(sp.csc_matrix(K)).solve(r)


def solve_symmetric(K: sp.spmatrix, r: np.ndarray) -> np.ndarray:
    """K⁻¹ r for a symmetric K (a stiffness or a tangent of dead loads): SuperLU in its
    symmetric mode (minimum degree on the pattern of K + Kᵀ, diagonal pivots), which on the
    Pazy wing's 16,764 DOFs factors in 0.14 s with 2.3 M entries against 0.51 s and 7.1 M for
    the general ordering (COLAMD) of :func:`solve_linear`, with a residual as small; the
    general factorisation when the diagonal pivots fail or leave a residual above 1e-8 of r
    (an indefinite tangent past a limit point may need row pivoting)."""
    K = sp.csc_matrix(K)
    try:
        with np.errstate(all="ignore"):
            x = sla.splu(K, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                         options={"SymmetricMode": True}).solve(r)
        if np.all(np.isfinite(x)) and \
                np.linalg.norm(K @ x - r) <= 1e-8 * max(np.linalg.norm(r), 1e-300):
            return x
    except RuntimeError:  # an exactly singular pivot
        pass
    return solve_linear(K, r)


def factor_symmetric(K: sp.spmatrix):
    """The SuperLU factorisation of :func:`solve_symmetric` (symmetric mode) kept for reuse:
    ``.solve(r)`` → K⁻¹ r."""
    with np.errstate(all="ignore"):
        return sla.splu(sp.csc_matrix(K), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                        options={"SymmetricMode": True})


#: modified_newton takes back a reused factorisation's step that multiplies the residual by more.
#: Measured on the Pazy wing: a dual-mode load's start with the last load's factorisation,
#: ×1.8e6 … ×1.7e8 (a Newton step from the same start: ×2e-3); the tip-mass sweep's first step
#: from the last mass's equilibrium, ×7e3 … ×2e4, where the Newton step from that start is no
#: better (the factorisation is nearly its tangent) and a take-back wastes a tangent.
DIVERGED = 1e5
#: modified_newton(newton_above=...) refactorises wherever ‖f(u) − F‖ exceeds this multiple of
#: ‖F‖, the residual of the unloaded state: a state farther from equilibrium than rest is where
#: a factorisation from elsewhere leads astray. Measured on the public TACS wingbox (432 DOFs,
#: co-rotational shells) in the 100 dual-mode solves of a 6L6D ROM, each started from the last
#: solution scaled to the new load (a residual 2e2 to 5e2 times the load, the in-plane part
#: quadratic in it): the reused factorisation's steps went to 1e7 … 1e15 times the load and
#: 50 of the solves gave up after 8 factorisations for full Newton from rest (1,084 tangents in
#: all); with this rule every solve converged by modified Newton, 287 tangents in all. The
#: value 1 is not tuned: it is the rest state's own residual.
NEWTON_ABOVE = 1.0


def modified_newton(fe, F: np.ndarray, u0: np.ndarray, *, tol: float = 1e-6,
                    max_iter: int = 60, factor=None, slow: float = 0.5,
                    max_tangents: int | None = None, work_tol: float | None = None,
                    factor_at_start: bool = False, newton_above: float | None = None):
    """Solve f(u) = F from ``u0`` by modified Newton: u ← u − K₀⁻¹ (f(u) − F) with one
    factorisation K₀ of the tangent reused (``factor``, e.g. the previous load's, else
    K_T(u0)), refactorised at the current u when an iteration reduces the residual by less
    than the factor ``slow``. A step of a reused factorisation that multiplies the residual by
    more than :data:`DIVERGED` (or makes it non-finite) is taken back and replaced by a Newton
    step (the tangent refactorised where it started): on a wing with stiff membranes and
    turning rigid arms (Pazy) a factorisation from another state can send the residual from
    10⁴ to 10¹⁰ times the load in one step, where a fresh tangent brings it down to 10¹. A
    smaller rise is kept (and the tangent refactorised there): on such a wing the residual's
    norm is a poor measure of the distance to the solution, and taking back every rise cost
    the Pazy tip-mass sweep one tangent a mass (4 a mass instead of 3). Converged when
    ‖f(u) − F‖ ≤ ``tol`` ‖F‖. Returns (u, residual evaluations, tangent factorisations,
    factor); ``F`` may be a :class:`~torchrom.fe.dead_load.DeadLoad` (evaluated at each
    iterate). ConvergenceError after ``max_iter``, or when more than ``max_tangents``
    factorisations would be needed (a residual stalled at its rounding floor refactorises at
    every iteration: the caller's full Newton, which detects the floor, is then cheaper).
    With ``work_tol``, also converged when the work of a correction on the residual
    |Δu · r| ≤ ``work_tol`` |u · F| (:func:`static_solve`'s work criterion: the residual's
    rounding floor of an ill-conditioned model can exceed ``tol`` ‖F‖).
    ``factor_at_start``: ``factor`` is the tangent's at ``u0`` (e.g. K at rest), so its first
    step is a Newton step and is kept. ``newton_above``: refactorise wherever the residual is
    above this multiple of ‖F‖ (full Newton far from equilibrium, the factorisation reused only
    near it; see :data:`NEWTON_ABOVE`)."""
    u = np.array(u0, dtype=float)
    norm_F = max(float(np.linalg.norm(reference(F))), 1e-300)
    tangents, prev, fresh = 0, np.inf, False
    u_prev = r_prev = None
    res = np.inf
    for it in range(1, max_iter + 1):
        F_u = applied(F, u)
        r = fe.internal_force(u) - F_u
        res = float(np.linalg.norm(r))
        if res <= tol * norm_F:
            return u, it, tangents, factor
        worse = not np.isfinite(res) or res >= prev
        if (not np.isfinite(res) or res > DIVERGED * prev) and not fresh and u_prev is not None:
            u, r, res = u_prev, r_prev, prev  # the reused factorisation's step, taken back
        elif not np.isfinite(res):
            break
        far = newton_above is not None and res > newton_above * norm_F
        refactor = (factor is None or worse or res > slow * prev
                    or (far and not (it == 1 and factor_at_start)))
        if refactor:
            if max_tangents is not None and tangents >= max_tangents:
                raise ConvergenceError(f"modified_newton: more than {max_tangents} tangent "
                                       f"factorisations (residual {res:.3g} of the load "
                                       f"{norm_F:.3g})")
            factor = factor_symmetric(fe.tangent_stiffness(u))
            tangents += 1
        fresh = refactor or (it == 1 and factor_at_start)  # this step is a Newton step
        prev, u_prev, r_prev = res, u, r
        du = factor.solve(r)
        u = u - du
        if work_tol is not None and abs(float(du @ r)) <= work_tol * abs(float(u @ F_u)):
            return u, it, tangents, factor
    raise ConvergenceError(f"modified_newton: no convergence in {max_iter} iterations "
                           f"(residual {res:.3g} of the load {norm_F:.3g})")


#: sparse eigensolver failures fall back to the dense solvers up to this many free DOFs
DENSE_FALLBACK_DOFS = 3000


def _massless(M: sp.csr_matrix) -> np.ndarray:
    return np.asarray(abs(M).sum(axis=1)).ravel() == 0.0


def _condense(K: np.ndarray, M: np.ndarray, z: np.ndarray):
    """Static condensation of the massless coordinates ``z`` (exact for the eigenproblem):
    (K_c, M_c, X) with the massless part of a mode = −X (massive part). A massless mechanism
    (K_zz singular, e.g. an unconstrained rotation without inertia) is condensed by least squares:
    for a positive semi-definite K its null vectors do not couple to the rest."""
    m = ~z
    Kzz, Kzm = K[np.ix_(z, z)], K[np.ix_(z, m)]
    try:
        with np.errstate(all="raise"):
            X = la.solve(Kzz, Kzm, assume_a="sym")
    except (la.LinAlgError, FloatingPointError, la.LinAlgWarning):
        X = la.lstsq(Kzz, Kzm)[0]
    return K[np.ix_(m, m)] - Kzm.T @ X, M[np.ix_(m, m)], X


def _dense_modes(K: sp.spmatrix, M: sp.spmatrix, n: int):
    """Lowest ``n`` finite modes by dense solvers: ``(vals, vecs, notes)``.

    First, static condensation of the massless DOFs (exact for the eigenproblem) and
    ``eigh``; when the massless block is singular or the mass not positive definite on the
    rest (DOFs with neither stiffness nor mass, a CMASS2 coupling two DOFs), the shifted form
    :func:`_shifted_modes`. At most as many modes as there are finite eigenvalues (Nastran
    returns all of them when asked for more)."""
    K = K.toarray()
    M = M.toarray()
    z = np.asarray(np.abs(M).sum(axis=1)).ravel() == 0.0
    m = ~z
    notes: list[str] = []
    try:
        vals, vecs = _condensed_modes(K, M, z, min(n, int(m.sum())))
        idle = int((z & ~np.abs(K).any(axis=1)).sum())
        if idle:  # condensed by least squares: they take no part in any mode
            notes.append(f"{idle} DOFs have neither stiffness nor mass: no part in any mode "
                         f"(like Nastran's AUTOSPC)")
    except la.LinAlgError:
        vals, vecs, notes = _shifted_modes(K, M, n)
    if len(vals) < n:
        notes.append(f"asked for {n} modes: the model has {len(vals)} finite ones "
                     f"({K.shape[0]} free DOFs), all returned")
    return vals, vecs, notes


def _condensed_modes(K: np.ndarray, M: np.ndarray, z: np.ndarray, n: int):
    """Lowest ``n`` modes with the massless DOFs ``z`` condensed (and massless combinations of
    DOFs, in M's eigenbasis); LinAlgError where that fails (DOFs with neither stiffness nor
    mass)."""
    m = ~z
    if n < 1:
        raise la.LinAlgError("no DOF carries mass")
    T = None
    if z.any():
        Kc, Mc, X = _condense(K, M, z)
    else:
        Kc, Mc = K, M
    mu, U = la.eigh(Mc)
    if mu.min() <= 1e-12 * mu.max():
        # A mass matrix singular without massless DOFs (e.g. a coupled bar mass with no rotary
        # inertia): the massless combinations are condensed the same way in M's eigenbasis.
        zz = mu <= 1e-12 * mu.max()
        n = min(n, int((~zz).sum()))
        T = U
        Kc, Mc, Xt = _condense(U.T @ Kc @ U, np.diag(np.where(zz, 0.0, mu)), zz)
    vals, vm = la.eigh(Kc, Mc, subset_by_index=[0, n - 1])
    if not np.all(np.isfinite(vals)):
        raise la.LinAlgError("non-finite eigenvalues")
    if T is not None:
        full = np.zeros((T.shape[0], n))
        full[~zz] = vm
        full[zz] = -Xt @ vm
        vm = T @ full
    if not z.any():
        return vals, vm
    vecs = np.zeros((K.shape[0], n))
    vecs[m] = vm
    vecs[z] = -X @ vm
    return vals, vecs


def _shifted_modes(K: np.ndarray, M: np.ndarray, n: int):
    """K φ = λ M φ through μ = 1/(λ − σ) of M φ = μ (K − σ M) φ, σ < 0 (dense).

    A = K − σ M is positive semi-definite; its null space (combinations of DOFs with neither
    stiffness nor mass, which take no part in any mode) is removed and reported; massless
    combinations give μ = 0 (infinite frequency) and are not returned."""
    dK = np.abs(np.diag(K))
    dM = np.abs(np.diag(M))
    ratio = (dK.mean() if dK.any() else 1.0) / (dM[dM > 0].mean() if dM.any() else 1.0)
    sigma = -1e-6 * ratio
    w, V = la.eigh(K - sigma * M)
    keep = w > 1e-12 * max(w.max(), 1e-300)
    Q = V[:, keep] / np.sqrt(w[keep])
    mu, Y = la.eigh(Q.T @ M @ Q)
    order = np.argsort(-mu)
    finite = order[mu[order] > 1e-12 * max(mu.max(initial=0.0), 1e-300)][:n]
    notes = []
    if (~keep).any():
        notes.append(f"{int((~keep).sum())} DOF combinations have neither stiffness nor mass: "
                     "no part in any mode (like Nastran's AUTOSPC)")
    return sigma + 1.0 / mu[finite], Q @ Y[:, finite], notes


def stiffness_mass_scale(K: sp.spmatrix, M: sp.spmatrix) -> float:
    """mean |diag K| / mean |diag M| over the DOFs with mass (rad²/s²): the scale of ω²."""
    dK, dM = np.abs(K.diagonal()), np.abs(M.diagonal())
    massive = dM != 0
    return float(np.mean(dK) / max(np.mean(dM[massive]) if massive.any() else 1.0, 1e-300))


def _lowest(K, M, k: int, sigma: float | None, scale: float,
            residual_tol: float | None = None):
    """The lowest ``k`` eigenpairs, ascending, and notes (dense or shift-invert Lanczos)."""
    N = K.shape[0]
    notes: list[str] = []
    if N <= 200 or k >= N - 1:
        vals, vecs, notes = _dense_modes(K, M, k)
    else:
        sigma = -1e-6 * scale if sigma is None else sigma
        try:
            vals, vecs = sla.eigsh(K.tocsc(), k=k, M=M.tocsc(), sigma=sigma, which="LM",
                                   v0=arpack_start(N))
            problem = None
            worst = _residual(K, M, vals, vecs).max()
            if worst > (EIGEN_RESIDUAL_TOL if residual_tol is None else residual_tol):
                problem = f"eigen-residual {worst:.1e}"
        except (RuntimeError, sla.ArpackNoConvergence) as exc:
            problem = f"{exc}"
        if problem is not None:
            # Lanczos on a (nearly) singular mass matrix fails or returns pairs that are not
            # eigenpairs (e.g. density 0): the dense solver condenses the massless part exactly
            if N > DENSE_FALLBACK_DOFS:
                raise ConvergenceError(f"modes: the sparse eigensolver failed ({problem}) on "
                                       f"{N} DOFs; a singular mass matrix? check the densities "
                                       f"and masses (MAT1 RHO, CONM2, CMASS2)")
            vals, vecs, notes = _dense_modes(K, M, k)
    order = np.argsort(vals)
    return vals[order], vecs[:, order], notes


#: largest relative residual ‖K φ − ω² M φ‖ / (‖K φ‖ + |ω²| ‖M φ‖) of an accepted sparse
#: eigenpair (measured ≤ 5e-10 on the Goland wing; 1 for the pseudo-pairs of a singular M)
EIGEN_RESIDUAL_TOL = 1e-6
#: largest model solved densely when the sparse solver cannot be trusted (360 DOFs: 0.1 s)
DENSE_FALLBACK_DOFS = 3000


def _residual(K, M, vals: np.ndarray, vecs: np.ndarray) -> np.ndarray:
    Kv, Mv = K @ vecs, M @ vecs
    num = np.linalg.norm(Kv - Mv * vals, axis=0)
    return num / np.maximum(np.linalg.norm(Kv, axis=0) + np.abs(vals) * np.linalg.norm(Mv, axis=0),
                            1e-300)


def modal_analysis(fe, n: int, sigma: float | None = None) -> Modes:
    """Lowest ``n`` elastic modes of K φ = ω² M φ on the free DOFs of ``fe``, classified by
    kind, and its rigid-body modes (:func:`eigenpairs`)."""
    notes: list[str] = []
    M = fe.mass_matrix()
    if not M.count_nonzero() or not np.abs(M.diagonal()).max(initial=0.0) > 0.0:
        raise InputError(f"{fe.source or fe.name}: modes: the model has no mass (no finite modes): "
                         "expected densities (MAT1 RHO), non-structural mass or mass elements "
                         "(CONM1/CONM2/CMASS)")
    K = fe.stiffness_matrix()
    for name, A in (("stiffness", K), ("mass", M)):
        if not np.isfinite(A.data).all():
            raise InputError(f"{fe.source or fe.name}: modes: the assembled {name} matrix has "
                             f"non-finite entries (a product of the deck's values overflowed: "
                             f"check the largest properties and materials)")
    vals, vecs, rigid_vals, rigid_vecs = _elastic_and_rigid(K, M, n, sigma, notes)
    freqs = np.sqrt(vals) / (2 * np.pi)
    kinds, fractions = classify(fe, vecs)
    return Modes(freqs, vecs, kinds, vals, fractions, notes, rigid_eigenvalues=rigid_vals,
                 rigid_shapes=rigid_vecs)


def eigenpairs(K: sp.spmatrix, M: sp.spmatrix, n: int, sigma: float | None = None,
               notes: list[str] | None = None, residual_tol: float | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Lowest ``n`` elastic eigenpairs (ω² ascending, mass-normalised oriented shapes) of
    K φ = ω² M φ (rigid-body modes skipped; :func:`_elastic_and_rigid`); ``residual_tol``
    the largest relative eigen-residual accepted from the sparse solver (default
    :data:`EIGEN_RESIDUAL_TOL`)."""
    vals, vecs, _, _ = _elastic_and_rigid(K, M, n, sigma, notes, residual_tol)
    return vals, vecs


def _elastic_and_rigid(K: sp.spmatrix, M: sp.spmatrix, n: int, sigma: float | None,
                       notes: list[str] | None, residual_tol: float | None = None):
    """(elastic ω², shapes, rigid-body ω², shapes).

    Sparse shift-invert (ARPACK via ``eigsh``) about a small negative shift ``sigma`` (default
    −1e-6 × the stiffness-to-mass scale, so that a singular K — a free-free model — is still
    factorised); small models (≤ 200 DOFs or n close to n_dof) use a dense solver with static
    condensation of massless DOFs (and of massless combinations of DOFs). Eigenvalues at or below
    ``RIGID_BODY_TOL`` × scale are rigid-body modes: counted and returned apart, and ``n`` more
    elastic modes are computed past them. Asking for more modes than the model has returns all
    its finite ones, with a note (appended to ``notes``), as Nastran does.
    """
    from ..bounds import MAX_MODES, check_count

    N = K.shape[0]
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"modes: n: expected a positive number of modes, got {n!r}")
    check_count("modes: n", "modes asked for", n, MAX_MODES)
    found: list[str] = []
    scale = stiffness_mass_scale(K, M)
    tol = RIGID_BODY_TOL * scale
    k_max = max(1, min(N, int((~_massless(M)).sum())))
    k = min(n, k_max)
    while True:
        vals, vecs, found = _lowest(K, M, k, sigma, scale, residual_tol)
        rigid = vals <= tol
        r = int(rigid.sum())
        if len(vals) - r >= n or k >= k_max or len(vals) < k:
            break
        k = min(n + r + 6, k_max)  # room for the rigid-body modes (a free body has six)
    if not np.all(np.isfinite(vals)):
        raise ConvergenceError("modes: the eigensolver returned non-finite eigenvalues")
    gen_mass = np.einsum("ik,ik->k", vecs, M @ vecs)
    vecs = vecs / np.sqrt(np.abs(gen_mass))
    vecs = orient_columns(vecs)
    elastic = np.nonzero(~rigid)[0][:n]
    if len(elastic) < n:
        found = [f for f in found if not f.startswith("asked for")]
        found.append(f"asked for {n} modes: the model has {r + len(elastic)} finite ones "
                     f"({r} rigid-body, {len(elastic)} elastic; {N} free DOFs), all returned")
    if notes is not None:
        notes.extend(found)
    return vals[elastic], vecs[:, elastic], vals[rigid], vecs[:, rigid]


@dataclass
class StaticResult:
    """Nonlinear static solution: ``u`` (n_dof,), ``converged``, total Newton ``iterations``,
    ``load_factor`` reached (1 when converged), ``residual_norm`` (of the last iterate),
    ``steps`` (load steps taken), ``reactions`` (force on prescribed DOFs, free-DOF vector,
    zero elsewhere), ``history`` (per step: load factor, iterations, residual),
    ``failed_load_factor`` (the load factor of the last attempt that did not converge, None when
    converged)."""

    u: np.ndarray
    converged: bool
    iterations: int
    load_factor: float
    residual_norm: float
    steps: int = 0
    reactions: np.ndarray | None = None
    history: list[dict] = field(default_factory=list)
    message: str = ""
    failed_load_factor: float | None = None


def _prescribed(fe, prescribed) -> tuple[np.ndarray, np.ndarray]:
    if prescribed is None:
        return np.zeros(0, dtype=int), np.zeros(0)
    items = prescribed.items() if isinstance(prescribed, dict) else prescribed
    idx, val = [], []
    for k, v in items:
        k = int(k)
        if not 0 <= k < fe.n_dof:
            raise InputError(f"static_solve: prescribed DOF index {k} outside 0..{fe.n_dof - 1}")
        idx.append(k)
        val.append(float(v))
    return np.array(idx, dtype=int), np.array(val)


def static_solve(
    fe,
    load=None,
    *,
    prescribed=None,
    u0=None,
    n_steps: int = 1,
    max_cuts: int = 10,
    max_iter: int = 30,
    tol: float = 1e-9,
    raise_on_failure: bool = False,
    callback: Callable[[float, np.ndarray], None] | None = None,
) -> StaticResult:
    """Solve f(u) = λ F for λ from 0 to 1 by Newton–Raphson with load stepping.

    ``load`` F (n_dof,), or a :class:`~torchrom.fe.dead_load.DeadLoad` whose generalized force
    follows the large rotations, may be None for pure displacement control. ``prescribed``
    (dict free DOF index → value at λ = 1) imposes u_k = λ value (displacement control, e.g.
    past a limit point); the reactions are returned. ``u0`` is the starting guess (continuation).
    Convergence: ‖r‖ ≤ tol · max(‖λF‖, ‖reactions‖, ‖f_int‖) on the unknown DOFs, or a Newton
    correction ‖Δu‖ ≤ 1e-10 ‖u‖ once the residual has stopped decreasing (the residual has
    reached its rounding floor, which for stiff models can exceed tol · ‖F‖), or the work of a
    Newton correction on the residual |Δu · r| ≤ :data:`WORK_TOL` · |u · λF| (an energy-norm
    error of the order of √WORK_TOL: Nastran's work criterion EPSW, at rounding level; on the
    ill-conditioned Pazy wing, 16,764 DOFs, the residual's rounding floor is 3e-9 ‖λF‖ and
    ‖Δu‖ there 1e-9 ‖u‖, while the work ratio falls from 5e-14 to 7e-17 in the iteration
    that reaches it). A step that
    fails (no convergence in ``max_iter``, NaN, or a growing residual) is halved, up to
    ``max_cuts`` times in all (a step that converges in at most ``max_iter // 4`` iterations
    after a cut doubles the next one, up to 1/``n_steps``, as Nastran's NLPARM increments grow
    back); then the result says ``converged=False`` with the load factor reached
    (or :class:`~torchrom.errors.ConvergenceError` with ``raise_on_failure``).
    """
    n = fe.n_dof
    if isinstance(load, DeadLoad):
        F = load
    else:
        F = np.zeros(n) if load is None else np.asarray(load, dtype=float).reshape(-1)
        if F.shape != (n,):
            raise InputError(f"static_solve: load: expected {n} free-DOF entries, got "
                             f"{F.shape}")
    p_idx, p_val = _prescribed(fe, prescribed)
    unknown = np.setdiff1d(np.arange(n), p_idx)
    if (not isinstance(F, DeadLoad) and not F.any() and not p_val.any()
            and (u0 is None or not np.any(u0))):
        # nothing applied to a structure at rest: u = 0 exactly. Newton cannot tell it: the
        # element forces at rest are rounding (not exactly 0), with no load to measure it by
        return StaticResult(np.zeros(n), True, 0, 1.0, 0.0, 0, np.zeros(n), [], "", None)
    u = np.zeros(n) if u0 is None else np.array(u0, dtype=float)
    lam, total_iter, steps, history = 0.0, 0, 0, []
    dlam = dlam0 = 1.0 / max(int(n_steps), 1)
    cuts = 0
    res_norm = 0.0
    message = ""
    target = None
    while lam < 1.0 - 1e-14:
        target = min(1.0, lam + dlam)
        if target > 1.0 - 1e-12:  # the last step ends at 1 exactly, not at a sum of steps
            target = 1.0
        ok, u_new, its, res_norm = _newton(fe, u, F, target, p_idx, p_val, unknown, max_iter, tol)
        total_iter += its
        if ok:
            u, lam = u_new, target
            steps += 1
            history.append({"load_factor": lam, "iterations": its, "residual": res_norm})
            if callback is not None:
                callback(lam, u)
            if dlam < dlam0 and its <= max_iter // 4:
                dlam = min(dlam0, 2.0 * dlam)  # an easy step after a cut: lengthen again
            continue
        cuts += 1
        if cuts > max_cuts:
            message = (f"static_solve: no convergence after {max_cuts} step cuts at load factor "
                       f"{lam:.4g} (residual {res_norm:.3g})")
            break
        dlam /= 2.0
    converged = lam >= 1.0 - 1e-14
    if not converged and raise_on_failure:
        raise ConvergenceError(message)
    r = fe.internal_force(u) - lam * applied(F, u)
    reactions = np.zeros(n)
    reactions[p_idx] = r[p_idx]
    return StaticResult(u, converged, total_iter, lam, res_norm, steps, reactions, history,
                        message, None if converged else target)


#: relative work of a Newton correction below which a load step has converged (static_solve)
WORK_TOL = 1e-15


def _newton(fe, u, F, lam, p_idx, p_val, unknown, max_iter, tol):
    u = u.copy()
    u[p_idx] = lam * p_val
    first = None
    res = np.inf
    prev = np.inf
    du_norm = np.inf
    f_start = 0.0
    for it in range(1, max_iter + 1):
        f = fe.internal_force(u)
        F_u = applied(F, u)
        r = f - lam * F_u
        ru = r[unknown]
        res = float(np.linalg.norm(ru))
        # unloading to rest (nothing applied) drives f itself to 0, which no fraction of the
        # current f would ever measure: there the step's first internal force is the scale.
        # Only there: a loaded step keeps its criterion (identified tensors are pinned by it)
        if it == 1:
            f_start = float(np.linalg.norm(f))
        applied_norm = float(np.linalg.norm(lam * F_u[unknown]))
        scale = max(applied_norm, np.linalg.norm(r[p_idx]), np.linalg.norm(f),
                    f_start if applied_norm == 0.0 and not p_val.any() else 0.0, 1e-300)
        if not np.isfinite(res):
            return False, u, it, res
        if res <= tol * scale:
            return True, u, it - 1, res
        if du_norm <= 1e-10 * max(np.linalg.norm(u), 1e-300) and res >= 0.5 * prev:
            return True, u, it - 1, res  # at the rounding floor
        prev = res
        first = res if first is None else first
        if it > 3 and res > 1e3 * first:
            return False, u, it, res
        K = fe.tangent_stiffness(u)[unknown][:, unknown]
        try:
            du = solve_symmetric(K, ru)
        except (RuntimeError, la.LinAlgError):
            return False, u, it, res
        u[unknown] -= du
        du_norm = float(np.linalg.norm(du))
        work = abs(float(u[unknown] @ (lam * F_u[unknown])))
        if abs(float(du @ ru)) <= WORK_TOL * work:
            return True, u, it, res
    return False, u, max_iter, res


@dataclass
class TransientResult:
    """Newmark time history: ``t (nt,)``, ``u``/``v`` (nt, n_rec) of the recorded DOFs
    (``dofs``), ``iterations`` (total Newton iterations), ``converged``."""

    t: np.ndarray
    u: np.ndarray
    v: np.ndarray
    dofs: np.ndarray
    iterations: int
    converged: bool


def transient(
    fe,
    *,
    t_end: float,
    dt: float,
    load=None,
    u0=None,
    v0=None,
    alpha: float = 0.0,
    beta: float = 0.0,
    gamma: float = 0.0,
    nonlinear: bool = True,
    record=None,
    newmark_beta: float = 0.25,
    newmark_gamma: float = 0.5,
    tol: float = 1e-9,
    max_iter: int = 20,
) -> TransientResult:
    """M ü + (α M + β K) u̇ + γ K_mat(u) u̇ + f(u) = F(t), Newmark + full Newton.

    ``load`` is None, a constant free-DOF vector or a callable t → vector. ``alpha`` (1/s) and
    ``beta`` (s) give linear Rayleigh damping (DIGEST Eq. 46), ``gamma`` (s) Kelvin–Voigt
    damping D = γ C (Eq. 52: force γ K_mat(u) u̇). ``nonlinear=False`` uses f = K u, K_mat = K.
    ``record`` lists the free-DOF indices stored (default: all). Massless DOFs start with zero
    acceleration (their equations are algebraic and are satisfied from the first step on).
    """
    n = fe.n_dof
    if not dt > 0 or not t_end > 0:
        raise InputError(f"transient: expected dt > 0 and t_end > 0, got dt={dt}, t_end={t_end}")
    M = fe.mass_matrix().tocsc()
    K1 = fe.stiffness_matrix().tocsc()
    if load is None:
        def force(t):
            return np.zeros(n)
    elif callable(load):
        def force(t):
            return np.asarray(load(t), dtype=float)
    else:
        const = np.asarray(load, dtype=float)

        def force(t):
            return const
    dofs = np.arange(n) if record is None else np.asarray(record, dtype=int)
    u = np.zeros(n) if u0 is None else np.array(u0, dtype=float)
    v = np.zeros(n) if v0 is None else np.array(v0, dtype=float)

    def internal(u):
        return fe.internal_force(u) if nonlinear else K1 @ u

    def kv_force(u, v):
        if gamma == 0.0:
            return np.zeros(n)
        return gamma * (fe.material_force(u, v) if nonlinear else K1 @ v)

    def damping(u, v):
        return alpha * (M @ v) + beta * (K1 @ v) + kv_force(u, v)

    r0 = force(0.0) - damping(u, v) - internal(u)
    a = np.zeros(n)
    heavy = ~_massless(M.tocsr())
    if heavy.any():
        Mh = M[heavy][:, heavy]
        a[heavy] = sla.splu(Mh.tocsc()).solve(r0[heavy])
    nb, ng = newmark_beta, newmark_gamma
    steps = int(round(t_end / dt))
    ts = np.arange(steps + 1) * dt
    U = np.zeros((steps + 1, len(dofs)))
    V = np.zeros_like(U)
    U[0], V[0] = u[dofs], v[dofs]
    total = 0
    c_lin = alpha * M + beta * K1
    for k in range(1, steps + 1):
        t = ts[k]
        Fk = force(t)
        u_pred = u + dt * v + dt**2 * (0.5 - nb) * a
        v_pred = v + dt * (1 - ng) * a
        un = u_pred.copy()
        ok = False
        for it in range(max_iter):
            an = (un - u_pred) / (nb * dt**2)
            vn = v_pred + ng * dt * an
            fi = internal(un)
            R = M @ an + damping(un, vn) + fi - Fk
            scale = max(np.linalg.norm(Fk), np.linalg.norm(M @ an), np.linalg.norm(fi), 1e-300)
            if np.linalg.norm(R) <= tol * scale and it > 0:
                ok = True
                break
            c = ng / (nb * dt)
            J = M / (nb * dt**2) + c_lin * c
            if nonlinear:
                # K_T + c γ K_mat + γ ∂(K_mat v)/∂u in one assembly pass.
                J = J + fe.matrix_combination(un, material=1.0 + c * gamma, geometric=1.0,
                                              damping=gamma, v=vn)
            else:
                J = J + K1 * (1.0 + c * gamma)
            un = un - solve_linear(J, R)
            total += 1
        if not ok:
            raise ConvergenceError(
                f"transient: Newton did not converge at t = {t:.6g} s (step {k}); reduce dt"
            )
        a = (un - u_pred) / (nb * dt**2)
        v = v_pred + ng * dt * a
        u = un
        U[k], V[k] = u[dofs], v[dofs]
    return TransientResult(ts, U, V, dofs, total, True)
