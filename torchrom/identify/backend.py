"""The FE-backend protocol: the only way the identification talks to a finite element model.

A backend answers six questions about a (geometrically nonlinear, elastic) FE model whose free
degrees of freedom (DOFs) form a vector u of length ``n_dof`` (DIGEST Secs. 4–6):

- ``mass_matrix()`` and ``stiffness_matrix()``: the linear M and K (dense or scipy.sparse);
- ``internal_force(u)``: the restoring force f(u) at an imposed displacement (STEP, Eqs. 37–41);
- ``tangent_stiffness(u)``: K_T(u) = ∂f/∂u at an imposed displacement (tangent method, Eqs. 37–41);
- ``material_tangent(u)`` (optional, ``has_material_tangent``): the tangent without its
  initial-stress part, K_mat(u) = ∫ Bᵀ(u) C B(u); for Kelvin–Voigt damping D = γC its projection is
  the tangent damping matrix D_T (Eq. 32) — the ``exact`` damping identification;
- ``static_solve(load, u0)``: the nonlinear static solution f(u) = load (dual modes, validation).

Each backend also carries ``reference_length`` (the span: amplitudes are fractions of it),
``transverse_dofs`` (DOFs whose largest |u| is "the tip transverse displacement" of DIGEST Sec. 6),
``translational_dofs`` and ``outputs`` (name → DOF index, e.g. "A_Tz"). The base class counts every
call and its time (``counters``), so the CLI can report FE solve counts.

Implementations: :class:`CallableBackend` (user Python callables; static solves by the Newton
solver below), the built-in FE (:mod:`torchrom.identify.fe_backend`) and file exchange with
Nastran (:mod:`torchrom.identify.nastran`). Everything here is hand-written except the sparse and
dense linear solves (scipy) and the eigen-solver (scipy.linalg / scipy.sparse.linalg).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from ..eigen import arpack_start, orient_columns
from ..errors import ConvergenceError, InputError


@dataclass
class StaticSolution:
    """Result of a nonlinear static solve f(u) = load."""

    u: np.ndarray
    converged: bool
    iterations: int
    load_factor: float = 1.0


@dataclass
class Counters:
    """How often each FE service was used and how long it took (seconds)."""

    static_solves: int = 0
    newton_iterations: int = 0
    force_evaluations: int = 0
    tangent_evaluations: int = 0
    material_tangent_evaluations: int = 0
    seconds: dict[str, float] = field(default_factory=dict)

    def add_time(self, key: str, dt: float) -> None:
        self.seconds[key] = self.seconds.get(key, 0.0) + dt

    def as_dict(self) -> dict:
        return {
            "static_solves": self.static_solves,
            "newton_iterations": self.newton_iterations,
            "force_evaluations": self.force_evaluations,
            "tangent_evaluations": self.tangent_evaluations,
            "material_tangent_evaluations": self.material_tangent_evaluations,
            "seconds": dict(self.seconds),
        }


def as_dense(A) -> np.ndarray:
    """A dense float64 array from a dense or scipy.sparse matrix."""
    if scipy.sparse.issparse(A):
        return np.asarray(A.toarray(), dtype=float)
    return np.asarray(A, dtype=float)


def project(A, Phi: np.ndarray) -> np.ndarray:
    """Φᵀ A Φ for a dense or sparse (n_dof, n_dof) matrix A."""
    return Phi.T @ np.asarray(A @ Phi)


def solve_linear(A, b: np.ndarray) -> np.ndarray:
    """Solve A x = b for a dense or scipy.sparse A."""
    if scipy.sparse.issparse(A):
        return scipy.sparse.linalg.spsolve(A.tocsc(), b)
    return scipy.linalg.solve(np.asarray(A), b, assume_a="sym")


def newmark_newton(M, force, tangents, x0: np.ndarray, *, dt: float, steps: int, tol: float,
                   max_iter: int, record, solve=solve_linear, rounding_stop: bool = False,
                   what: str = "transient") -> None:
    """Newmark average acceleration (β = ¼, γ_N = ½) from rest at ``x0`` for
    M ẍ + force(x, ẋ) = 0, Newton on M/(β dt²) + K + γ_N/(β dt) C with
    ``(K, C) = tangents(x, ẋ)`` (C may be None); the FE and the ROM free decays share it.

    A step has converged when |R| ≤ tol |M a| after at least one correction, or, with
    ``rounding_stop``, when a correction is at the rounding level of x (a near-rest start makes
    |M a| tiny, so the relative residual test alone can be out of reach). ``record(k, x, ẋ)``
    is called for k = 0..steps; ConvergenceError names ``what`` and the step."""
    b, g = 0.25, 0.5
    x, v = np.array(x0, float), np.zeros(len(x0))
    a = solve(M, -force(x, v))
    record(0, x, v)
    for k in range(1, steps + 1):
        xp = x + dt * v + dt**2 * (0.5 - b) * a
        vp = v + dt * (1 - g) * a
        xn = xp.copy()
        for it in range(max_iter):
            an = (xn - xp) / (b * dt**2)
            vn = vp + g * dt * an
            R = M @ an + force(xn, vn)
            if it > 0 and np.linalg.norm(R) <= tol * max(np.linalg.norm(M @ an), 1e-300):
                break
            K, C = tangents(xn, vn)
            J = M / (b * dt**2) + K
            if C is not None:
                J = J + (g / (b * dt)) * C
            dx = solve(J, R)
            xn = xn - dx
            if rounding_stop and np.linalg.norm(dx) <= 1e-13 * max(np.linalg.norm(xn), 1e-300):
                break
        else:
            raise ConvergenceError(f"{what}: Newton did not converge at step {k}")
        a = (xn - xp) / (b * dt**2)
        v = vp + g * dt * a
        x = xn
        record(k, x, v)


class FEBackend:
    """Base class of the FE backends: counted, timed public services over ``_``-methods.

    Subclasses set ``n_dof`` and implement ``_mass``, ``_stiffness``, ``_internal_force``,
    ``_tangent_stiffness`` and optionally ``_material_tangent`` and ``_static_solve`` (the default
    is :func:`newton_static_solve` on ``internal_force``/``tangent_stiffness``).
    """

    n_dof: int
    name: str = "fe"
    reference_length: float = 1.0
    has_material_tangent: bool = False

    def __init__(self) -> None:
        self.counters = Counters()
        self._M = None
        self._K = None
        #: the structure the condensation solves when it is not this one (the model without
        #: its foil skin: :class:`~torchrom.identify.condensation.Skeleton`); None: this one
        self.skeleton = None

    # -- descriptive attributes with defaults ------------------------------------------------
    @property
    def transverse_dofs(self) -> np.ndarray:
        return getattr(self, "_transverse_dofs", np.arange(self.n_dof))

    def transverse_displacements(self, u) -> np.ndarray:
        """The transverse deflections whose largest magnitude is "the tip transverse
        displacement" (DIGEST Sec. 6): here ``u`` at :attr:`transverse_dofs`; an FE backend
        projects each grid's displacement on the wing's up axis. Empty: none known."""
        return np.asarray(u)[self.transverse_dofs]

    @property
    def translational_dofs(self) -> np.ndarray:
        return getattr(self, "_translational_dofs", np.arange(self.n_dof))

    @property
    def outputs(self) -> dict[str, int]:
        return getattr(self, "_outputs", {})

    def dof_label(self, dof: int) -> str | None:
        """``"G1001:T3"`` of a DOF when the backend knows its grid (None otherwise)."""
        return None

    def mesh_shapes(self, Phi):
        """The columns of ``Phi`` on the model's grids, with its mesh
        (:class:`~torchrom.rom.shapes.MeshShapes`), when the backend knows them (None
        otherwise: the ROM then keeps no shapes)."""
        return None

    @property
    def metadata(self) -> dict:
        return {"backend": type(self).__name__, "name": self.name,
                "n_dof": int(self.n_dof), "reference_length": float(self.reference_length)}

    # -- counted services ----------------------------------------------------------------------
    def mass_matrix(self):
        if self._M is None:
            self._M = self._mass()
        return self._M

    def stiffness_matrix(self):
        if self._K is None:
            self._K = self._stiffness()
        return self._K

    def internal_force(self, u: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        f = np.asarray(self._internal_force(self._check_u(u)), dtype=float).reshape(-1)
        self.counters.force_evaluations += 1
        self.counters.add_time("internal_force", time.perf_counter() - t0)
        return f

    def tangent_stiffness(self, u: np.ndarray):
        t0 = time.perf_counter()
        K = self._tangent_stiffness(self._check_u(u))
        self.counters.tangent_evaluations += 1
        self.counters.add_time("tangent_stiffness", time.perf_counter() - t0)
        return K

    def material_tangent(self, u: np.ndarray):
        if not self.has_material_tangent:
            raise InputError(f"{self.name}: this FE backend provides no material tangent; use "
                             "--damping decomposition")
        t0 = time.perf_counter()
        K = self._material_tangent(self._check_u(u))
        self.counters.material_tangent_evaluations += 1
        self.counters.add_time("material_tangent", time.perf_counter() - t0)
        return K

    def static_solve(self, load: np.ndarray, u0: np.ndarray | None = None) -> StaticSolution:
        t0 = time.perf_counter()
        load = np.asarray(load, dtype=float).reshape(-1)
        if load.shape != (self.n_dof,):
            raise InputError(f"{self.name}: load has {load.size} entries, expected {self.n_dof}")
        sol = self._static_solve(load, None if u0 is None else self._check_u(u0))
        self.counters.static_solves += 1
        self.counters.newton_iterations += int(sol.iterations)
        self.counters.add_time("static_solve", time.perf_counter() - t0)
        return sol

    # -- projected services (the identification only ever needs these) -----------------------
    def projected_tangents(self, Phi: np.ndarray, Q: np.ndarray, material: bool = False):
        """Φᵀ K_T(Φq) Φ (and Φᵀ K_mat(Φq) Φ if ``material``) for each row q of Q.

        Returns (KT (P, n, n), Kmat (P, n, n) or None). Backends with a batched FE may override.
        """
        Q = np.atleast_2d(Q)
        KT = np.empty((len(Q), Phi.shape[1], Phi.shape[1]))
        Km = np.empty_like(KT) if material else None
        for p, q in enumerate(Q):
            u = Phi @ q
            KT[p] = project(self.tangent_stiffness(u), Phi)
            if material:
                Km[p] = project(self.material_tangent(u), Phi)
        return KT, Km

    def projected_forces(self, Phi: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """Φᵀ f(Φq) for each row q of Q: (P, n)."""
        Q = np.atleast_2d(Q)
        return np.stack([Phi.T @ self.internal_force(Phi @ q) for q in Q])

    # -- defaults --------------------------------------------------------------------------------
    def _static_solve(self, load: np.ndarray, u0: np.ndarray | None) -> StaticSolution:
        return newton_static_solve(self._internal_force, self._tangent_stiffness, load, u0=u0,
                                   name=self.name)

    def _material_tangent(self, u):  # pragma: no cover - guarded by has_material_tangent
        raise InputError(f"{self.name}: no material tangent")

    def _check_u(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float).reshape(-1)
        if u.shape != (self.n_dof,):
            raise InputError(f"{self.name}: displacement has {u.size} entries, expected "
                             f"{self.n_dof}")
        return u

    def load_shapes(self) -> dict[str, np.ndarray]:
        """Named unit load vectors for the validation (e.g. "uniform", "step"); none by default."""
        return dict(getattr(self, "_load_shapes", {}))

    def free_decay(self, u0: np.ndarray, *, t_end: float, dt: float, gamma: float,
                   record) -> tuple[np.ndarray, np.ndarray]:
        """Nonlinear free vibration from rest at u0 with Kelvin–Voigt damping γ K_mat(u) u̇:
        Newmark average acceleration, Newton on K_T + (½/(¼ dt)) γ K_mat + M/(¼ dt²) (the
        derivative of K_mat(u) u̇ in u is left out of the iteration matrix: modified Newton).
        Returns (t (k,), u[:, record] (k, len(record)))."""
        M = self.mass_matrix()
        steps = int(round(t_end / dt))
        rec = np.asarray(record, dtype=int)
        out = np.zeros((steps + 1, len(rec)))

        def force(u, v):
            f = self.internal_force(u)
            return f + gamma * np.asarray(self.material_tangent(u) @ v) if gamma else f

        def tangents(u, v):
            return (self.tangent_stiffness(u),
                    gamma * self.material_tangent(u) if gamma else None)

        def keep(k, u, v):
            out[k] = u[rec]

        newmark_newton(M, force, tangents, np.asarray(u0, float), dt=dt, steps=steps, tol=1e-9,
                       max_iter=40, record=keep, what=f"{self.name}: transient")
        return np.arange(steps + 1) * dt, out

    def modes(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The n lowest linear modes: (frequencies_hz (n,), mass-normalised shapes (n_dof, n))."""
        return generalized_modes(self.stiffness_matrix(), self.mass_matrix(), n, name=self.name)


def generalized_modes(K, M, n: int, name: str = "fe") -> tuple[np.ndarray, np.ndarray]:
    """Lowest n eigenpairs of K φ = ω² M φ, φᵀ M φ = 1, frequencies in Hz, signs by
    :func:`torchrom.eigen.orient_columns` and a fixed ARPACK start (reproducible shapes)."""
    n_dof = K.shape[0]
    if not 1 <= n <= n_dof:
        raise InputError(f"{name}: asked for {n} modes of a model with {n_dof} DOFs")
    if scipy.sparse.issparse(K) and n < n_dof // 2 and n_dof > 400:
        lam, V = scipy.sparse.linalg.eigsh(K.tocsc(), k=n, M=M.tocsc(), sigma=0.0, which="LM",
                                           v0=arpack_start(n_dof))
    else:
        lam, V = scipy.linalg.eigh(as_dense(K), as_dense(M), subset_by_index=(0, n - 1))
    order = np.argsort(lam)
    lam, V = lam[order], V[:, order]
    Mv = np.asarray(M @ V)
    V = V / np.sqrt(np.einsum("ij,ij->j", V, Mv))
    V = orient_columns(V)
    with np.errstate(invalid="ignore"):
        f = np.sqrt(np.where(lam > 0, lam, np.nan)) / (2 * np.pi)
    return f, V


def newton_static_solve(force: Callable, tangent: Callable, load: np.ndarray,
                        u0: np.ndarray | None = None, *, rtol: float = 1e-10,
                        max_iterations: int = 30, min_increment: float = 1e-4,
                        name: str = "fe") -> StaticSolution:
    """Newton–Raphson with adaptive load increments for f(u) = load.

    The load factor advances by an increment that is halved when a step fails to converge within
    ``max_iterations`` (and grown after an easy step), so large loads (dual modes at 15 % of span,
    DIGEST Sec. 6) converge without the user choosing increments. Convergence: ‖f(u) − λ load‖
    ≤ rtol ‖load‖ (and a correction below rtol of ‖u‖).
    """
    load = np.asarray(load, dtype=float)
    u = np.zeros_like(load) if u0 is None else np.array(u0, dtype=float)
    scale = max(np.linalg.norm(load), np.finfo(float).tiny)
    lam, inc, total_it = 0.0, 1.0, 0
    # a good initial guess (continuation) may already be the answer
    if u0 is not None and np.linalg.norm(force(u) - load) <= rtol * scale:
        return StaticSolution(u, True, 0, 1.0)
    while lam < 1.0:
        target = min(1.0, lam + inc)
        v = u.copy()
        ok = False
        for it in range(1, max_iterations + 1):
            r = target * load - force(v)
            if np.linalg.norm(r) <= rtol * scale and it > 1:
                ok = True
                break
            dv = solve_linear(tangent(v), r)
            if not np.all(np.isfinite(dv)):
                break
            v = v + dv
            total_it += 1
            if np.linalg.norm(dv) <= 1e-3 * rtol * max(np.linalg.norm(v), 1e-300):
                ok = np.linalg.norm(target * load - force(v)) <= 1e3 * rtol * scale
                break
        if ok:
            u, lam = v, target
            if it <= 4:
                inc = min(1.0, 2.0 * inc)
        else:
            inc *= 0.5
            if inc < min_increment:
                raise ConvergenceError(
                    f"{name}: static Newton solve did not converge: reached load factor {lam:.4f}"
                    f" with increments down to {inc:.1e}")
    return StaticSolution(u, True, total_it, 1.0)


class CallableBackend(FEBackend):
    """An FE model given as Python callables (numpy in, numpy/scipy out).

    Args:
        internal_force: f(u) -> (n_dof,).
        tangent_stiffness: K_T(u) -> (n_dof, n_dof) dense or scipy.sparse.
        mass: M (n_dof, n_dof).
        stiffness: linear K (default K_T(0)).
        material_tangent: optional K_mat(u) (enables ``--damping exact``).
        static_solve: optional solver(load, u0) -> u or StaticSolution (default: Newton).
        reference_length: length that amplitude fractions refer to (e.g. the span; default 1).
        transverse_dofs, translational_dofs: DOF index arrays (default: all DOFs).
        outputs: name -> DOF index (rows of the basis stored in the ROM).
    """

    def __init__(self, internal_force: Callable, tangent_stiffness: Callable, mass, *,
                 stiffness=None, material_tangent: Callable | None = None,
                 static_solve: Callable | None = None, reference_length: float = 1.0,
                 transverse_dofs=None, translational_dofs=None,
                 outputs: Mapping[str, int] | None = None, name: str = "callables"):
        super().__init__()
        self.n_dof = int(np.shape(mass)[0])
        self.name = name
        self._f, self._kt, self._kmat, self._solver = (internal_force, tangent_stiffness,
                                                       material_tangent, static_solve)
        self._M = mass
        self._K = stiffness
        self.has_material_tangent = material_tangent is not None
        if not reference_length > 0:
            raise InputError(f"{name}: reference_length must be positive, got {reference_length}")
        self.reference_length = float(reference_length)
        if transverse_dofs is not None:
            self._transverse_dofs = np.asarray(transverse_dofs, dtype=int)
        if translational_dofs is not None:
            self._translational_dofs = np.asarray(translational_dofs, dtype=int)
        self._outputs = {str(k): int(v) for k, v in (outputs or {}).items()}

    def _mass(self):
        return self._M

    def _stiffness(self):
        return self._tangent_stiffness(np.zeros(self.n_dof))

    def _internal_force(self, u):
        return self._f(u)

    def _tangent_stiffness(self, u):
        return self._kt(u)

    def _material_tangent(self, u):
        return self._kmat(u)

    def _static_solve(self, load, u0):
        if self._solver is None:
            return super()._static_solve(load, u0)
        res = self._solver(load, u0)
        if isinstance(res, StaticSolution):
            return res
        return StaticSolution(np.asarray(res, dtype=float), True, 0, 1.0)
