"""Implicit condensation: the cubic stiffness of a ROM on the linear modes alone, whose in-plane
(membrane) motion the FE relaxes in its own nonlinear static solves.

**Method** (Hollkamp & Gordon, JSV 2008, "implicit condensation"; the applied-force variant of
Muravyov & Rizzi's STEP). Modal loads F = K Φ p, with p on the STEP directions (±a_j e_j, the
four sign pairs ±a_j e_j ± a_l e_l, ±(a_j e_j + a_k e_k + a_l e_l)) at the load levels
s = 1/L, 2/L, …, 1, are solved by the full nonlinear FE, each direction continued from its last
level. Each solution u gives the modal coordinates q = (ΦᵀMΦ)⁻¹ ΦᵀM u, and the load's modal
force is Φᵀ F = K1 p, so

    K1 (p − q) = K̃2(q, q) + K̃3(q, q, q)                                     (Eqs. 25–26)

is fitted, row by row, by least squares on the distinct monomials of q over all solves.

**Why.** A thin wing bends almost inextensionally: its membrane DOFs follow the bending as a
nearly exact quadratic companion. On an explicit basis (linear + dual modes) the cubic force of a
bending coordinate is then hundreds of times its linear part and is cancelled by the dual
coordinates' terms (the Pazy spar, L/t = 244: 700 times at 2 % of the span), so a
non-cubic term of the FE (co-rotational kinematics) of 4e-4 relative breaks the balance and the
ROM locks. Here the FE does the cancellation; what is fitted is the softening that remains, over
the range of the load levels rather than at a Taylor point — the levels' largest amplitude sets
the ROM's validity envelope.

**A skin left out of the nonlinear terms** (:class:`Skeleton`). A foil skin (the Pazy wing's
12 µm PSHELL) buckles in compression at strains of order 1e-7 and wrinkles: modelled as a shell
it stops every static solve (as the AePW-3 group reports of SOL 400 on the same deck), and kept
linear it resists the bending's foreshortening (a spurious hardening). With a skeleton (the
model without the skin) the solves are the skeleton's, on the skinned modes restricted to its
DOFs, and the ROM's linear part stays the whole model's: the skin adds its small-deflection
stiffness and its mass, and nothing to the geometric nonlinearity.

What it gives up: the ROM's coordinates are the linear modes only (no dual modes), the in-plane
displacements are not among the outputs (the outputs are Φ q), the in-plane inertia is left out
(the in-plane modes lie far above the bending ones), and a static solve needs a restrained
structure. Written by hand: no library implements the condensation over an FE backend.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import ConvergenceError, InputError
from ..rom import conventions as cv
from ..rom.monomials import monomial_index
from .stiffness import StepPlan, StiffnessIdentification, _full_sym, _rel_spread


@dataclass(frozen=True)
class CondensationPlan:
    """Applied modal loads p (the linear response Φ p) of the condensation: the STEP directions
    (:class:`~torchrom.identify.stiffness.StepPlan`) at ``levels`` equal fractions of the
    ``amplitudes`` a_j, the largest last. ``points`` (D × levels, n), direction-major."""

    amplitudes: np.ndarray
    levels: int = 3
    directions: np.ndarray = field(init=False, repr=False)
    points: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if int(self.levels) < 1:
            raise InputError(f"condensation levels: expected a positive count, got {self.levels}")
        a = np.asarray(self.amplitudes, dtype=float)
        d = StepPlan(a).points
        s = np.arange(1, int(self.levels) + 1) / int(self.levels)
        object.__setattr__(self, "amplitudes", a)
        object.__setattr__(self, "levels", int(self.levels))
        object.__setattr__(self, "directions", d)
        object.__setattr__(self, "points", (d[:, None, :] * s[None, :, None]).reshape(-1, a.size))


def equal_force_amplitudes(K1: np.ndarray, first: float) -> np.ndarray:
    """Modal amplitudes a_j = first · k_1 / k_j (k_j = K1_jj): every mode loaded by the modal
    force that takes the first mode to ``first`` — not each to the same deflection, which would
    bend a higher mode (its curvature ~ (ω_j/ω_1) times the first's at the same deflection)
    far beyond the range the wing's loads reach, and into rotations a cubic cannot fit."""
    k = np.diag(np.asarray(K1, dtype=float))
    if np.any(k <= 0):
        raise InputError("condensation: every mode needs a positive modal stiffness (a free "
                         "structure's rigid-body modes cannot be loaded statically)")
    return first * k[0] / k


def monomials(q: np.ndarray) -> np.ndarray:
    """The distinct quadratic and cubic monomials of each row of ``q`` (P, n): (P, N2 + N3), in
    the order of the combined coefficients (:mod:`torchrom.rom.monomials`)."""
    q = np.atleast_2d(q)
    idx = monomial_index(q.shape[1])
    m2 = q[:, idx.pairs[:, 0]] * q[:, idx.pairs[:, 1]]
    m3 = m2[:, idx.triple_pair] * q[:, idx.triples[:, 2]]
    return np.concatenate([m2, m3], axis=1)


def monomial_gradients(q: np.ndarray) -> np.ndarray:
    """∂(monomial)/∂q_j of :func:`monomials` at each row of ``q`` (P, k): (P, k, N2 + N3)."""
    q = np.atleast_2d(q)
    P, k = q.shape
    idx = monomial_index(k)
    eye = np.eye(k)
    a, b = idx.pairs[:, 0], idx.pairs[:, 1]
    d2 = eye[:, a][None] * q[:, None, b] + eye[:, b][None] * q[:, None, a]
    x, y, z = idx.triples[:, 0], idx.triples[:, 1], idx.triples[:, 2]
    d3 = (eye[:, x][None] * (q[:, y] * q[:, z])[:, None] + eye[:, y][None] * (q[:, x] *
          q[:, z])[:, None] + eye[:, z][None] * (q[:, x] * q[:, y])[:, None])
    return np.concatenate([d2, d3], axis=2)


def condensed_tangent(S: np.ndarray, A: np.ndarray, k: int) -> np.ndarray:
    """∂N/∂q_j (n, k), j ≤ k, of the condensed nonlinear force N = A (p − q) along the solves'
    manifold (p_j = 0 for j > k), from S = (KΦ)ᵀ K_T⁻¹ (KΦ) at a solution (n, n) and A = ΦᵀKΦ:
    dq = A⁻¹ S dp, so dp_k = G_kk⁻¹ dq_k with G = A⁻¹ S, and dN = (A_{:,k} − S_{:,k}) dp_k.
    Zero at u = 0 (S = A)."""
    G = np.linalg.solve(A, S)
    return np.linalg.solve(G[:k, :k].T, (A[:, :k] - S[:, :k]).T).T


def _embed_monomials(C: np.ndarray, k: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Combined coefficients (rows, N2 + N3 of the first ``k`` coordinates) as those of all
    ``n`` coordinates (K̃2 (rows, N2(n)), K̃3 (rows, N3(n))), zero where a coordinate > k
    enters."""
    sub, full = monomial_index(k), monomial_index(n)
    K2c = np.zeros((C.shape[0], full.n_pairs))
    K2c[:, full.pair_id[sub.pairs[:, 0], sub.pairs[:, 1]]] = C[:, :sub.n_pairs]
    where = {tuple(t): i for i, t in enumerate(full.triples.tolist())}
    K3c = np.zeros((C.shape[0], full.n_triples))
    K3c[:, [where[tuple(t)] for t in sub.triples.tolist()]] = C[:, sub.n_pairs:]
    return K2c, K3c


def stiffness_from_condensation(p: np.ndarray, q: np.ndarray, K1: np.ndarray,
                                amplitudes: np.ndarray, n_nonlinear: int | None = None,
                                failed: str = "", tangents: np.ndarray | None = None
                                ) -> StiffnessIdentification:
    """K2, K3 (symmetric storage) fitted to K1 (p − q) = K̃2(q,q) + K̃3(q,q,q) over the solves.

    Args:
        p: (P, n) applied modal loads (linear responses); q: (P, n) the FE's modal coordinates;
        K1: (n, n) linear modal stiffness; amplitudes: (n,) the plan's a_j (scales the fit);
        n_nonlinear: the monomials are those of the first ``n_nonlinear`` coordinates (all
        by default); every row is fitted (the other modes' static response to them);
        failed: what failed on the way (said when the rest does not determine the fit);
        tangents: (P, n, k) ∂N/∂q_j of each solve (:func:`condensed_tangent`), fitted
        together with the forces: a force fit alone leaves the cross terms' coefficients, and
        so the tangent about a deformed state, poorly determined.
    ``residuals``: ``condensation_fit``, ‖K̃2(q,q) + K̃3(q,q,q) − K1 (p − q)‖ / ‖K1 (p − q)‖
    over all rows and solves (0 when the condensed force is a cubic polynomial of q);
    ``condensation_asymmetry``, the least-squares fit's departure from the full symmetry of a
    potential force in the loaded modes' block (relative to its largest entry), which is then
    imposed."""
    p, q, a = np.atleast_2d(p), np.atleast_2d(q), np.asarray(amplitudes, dtype=float)
    n = q.shape[1]
    k = n if n_nonlinear is None else int(n_nonlinear)
    g = (p - q) @ np.asarray(K1).T
    # scaled coordinates q/a keep the monomial columns of one size (conditioning of the fit)
    A = monomials(q[:, :k] / a[:k])
    scale = monomials(a[None, :k])[0]
    rank = int(np.linalg.matrix_rank(A)) if len(A) else 0
    if rank < A.shape[1]:
        raise InputError(f"condensation: the {len(q)} converged static solves{failed} "
                         f"determine only {rank} of the {A.shape[1]} cubic-polynomial "
                         f"coefficients of {k} modes; use a smaller --amplitude (the largest "
                         "load level) or more --levels so that more solves converge, or "
                         "--stiffness tangent (imposed displacements, no static solves)")
    if tangents is None:
        C, *_ = np.linalg.lstsq(A, g, rcond=None)
    else:  # ∂N/∂(q_j/a_j) = a_j ∂N/∂q_j beside N: one least-squares system per row
        dA = monomial_gradients(q[:, :k] / a[:k]).reshape(-1, A.shape[1])
        dg = (np.asarray(tangents)[:, :, :k] * a[None, None, :k]).transpose(0, 2, 1)
        C, *_ = np.linalg.lstsq(np.vstack([A, dA]), np.vstack([g, dg.reshape(-1, n)]),
                                rcond=None)
    K2c, K3c = _embed_monomials((C / scale[:, None]).T, k, n)   # in the unscaled q
    sym = cv.symmetric_from_compact(torch.as_tensor(K2c), torch.as_tensor(K3c))
    K2, K3 = sym["K2"].numpy(), sym["K3"].numpy()
    # the loaded modes' condensed force derives from the condensed strain energy: their block
    # is made fully symmetric (the nearest potential force), so the ROM creates no energy; the
    # fit's departure from it is reported. The unloaded modes' rows (k < n) stay as fitted.
    b2, b3 = K2[:k, :k, :k], K3[:k, :k, :k, :k]
    asym = max(_rel_spread(b2, _full_sym(b2)), _rel_spread(b3, _full_sym(b3)))
    K2[:k, :k, :k], K3[:k, :k, :k, :k] = _full_sym(b2), _full_sym(b3)
    nl = (np.einsum("mjl,pj,pl->pm", K2, q, q) + np.einsum("mjlr,pj,pl,pr->pm", K3, q, q, q))
    fit = float(np.linalg.norm(nl - g) / max(np.linalg.norm(g), np.finfo(float).tiny))
    res = {"condensation_fit": fit, "condensation_asymmetry": asym}
    if tangents is not None:
        T = np.asarray(tangents)[:, :, :k]
        model = (2 * np.einsum("mjl,pl->pmj", K2[:, :k], q) +
                 3 * np.einsum("mjlr,pl,pr->pmj", K3[:, :k], q, q))
        res["condensation_tangent_fit"] = float(
            np.linalg.norm(model - T) / max(np.linalg.norm(T), np.finfo(float).tiny))
    K1 = np.asarray(K1, dtype=float)
    return StiffnessIdentification(0.5 * (K1 + K1.T), K2, K3, "condensed", a, res, len(q))


@dataclass(frozen=True)
class Skeleton:
    """The structure whose static solves give the condensed nonlinear terms when it is not the
    whole model (the model without its foil skin): its backend, the model's free-DOF index of
    each of its free DOFs (``rows``), and what was left out (``what``, for the ROM's record)."""

    backend: object
    rows: np.ndarray
    what: str


def skeleton_of(fe, skeleton_fe, backend, what: str) -> Skeleton:
    """The :class:`Skeleton` of the FE model ``fe`` given the same deck without the left-out
    elements (``skeleton_fe``, its ``backend``): every skeleton DOF must be a DOF of ``fe``."""
    rows = np.array([fe.dof_index(g, c, what="skeleton") for g, c in skeleton_fe.free_dofs()],
                    dtype=int)
    return Skeleton(backend, rows, what)


@dataclass
class CondensationData:
    """What the condensation's solves gave: the applied loads ``p`` and the FE's modal
    coordinates ``q`` of the converged solves (P, n), and the loads whose solve failed."""

    p: np.ndarray
    q: np.ndarray
    failed: list[np.ndarray]
    tangents: np.ndarray | None = None

    @property
    def points(self) -> np.ndarray:
        return self.p


def solve_plan(plan: CondensationPlan, n: int, k: int, solve, record, u_start=None,
               progress=None) -> tuple[list, str]:
    """Each direction's load levels of ``plan`` (on the first ``k`` of ``n`` coordinates)
    solved in turn, a level continued from the one below, the first from ``u_start``:
    ``solve(p, u0)`` gives u, ``record(p, u)`` takes each converged one, ``progress(done,
    total)`` follows. A direction whose solve fails keeps its lower levels. Returns the
    failed loads and the first failure's words (for the fit's refusal)."""
    L, total = plan.levels, len(plan.points)
    failed, first_error, done = [], "", 0
    for d in range(len(plan.directions)):
        u = u_start
        for lev in range(L):
            p = np.zeros(n)
            p[:k] = plan.points[d * L + lev]
            try:
                u = solve(p, u)
            except ConvergenceError as err:
                first_error = first_error or f"; the first failure: {err}"
                failed.extend(plan.points[d * L + lev:(d + 1) * L])
                done += L - lev
                if progress is not None:
                    progress(done, total)
                break
            record(p, u)
            done += 1
            if progress is not None:
                progress(done, total)
    return failed, first_error


def tangent_gram(solver, u: np.ndarray, KPhi: np.ndarray) -> np.ndarray:
    """(KΦ)ᵀ K_T(u)⁻¹ (KΦ) of a backend at ``u``."""
    from ..fe.solvers import factor_symmetric

    X = np.asarray(factor_symmetric(solver.tangent_stiffness(u)).solve(KPhi))
    return KPhi.T @ X.reshape(KPhi.shape)


def identify_stiffness_condensed(backend, Phi: np.ndarray, amplitudes: np.ndarray, *,
                                 levels: int = 3, n_nonlinear: int | None = None,
                                 progress=None, skeleton: Skeleton | None = None,
                                 higher: np.ndarray | None = None, tangents: bool = False
                                 ) -> tuple[StiffnessIdentification, CondensationData]:
    """Run the condensation plan on a (restrained) backend; ``progress(done, total)`` after
    each static solve. A direction whose solve fails keeps its lower levels (the failed loads
    are in the returned data); the fit then refuses if the rest no longer determines it.
    ``n_nonlinear``: load only the first modes (all by default): the ROM's nonlinear terms are
    those of their coordinates, the others' response to them included (O(k³) solves).
    ``skeleton``: solve that structure instead, on Φ's rows of its DOFs (module docstring);
    the linear stiffness K1 stays the backend's. ``higher``: the amplitudes of the modes after
    the first (n,) instead of the first mode's modal force (:func:`equal_force_amplitudes`),
    for an LCO whose motion lies in a higher mode beyond what that force reaches.
    ``tangents``: at each solution also the condensed tangent (one factorisation of K_T and n
    solves, :func:`condensed_tangent`), fitted with the forces."""
    from .backend import project

    K = backend.stiffness_matrix()
    K1 = project(K, Phi)
    n = Phi.shape[1]
    k = n if n_nonlinear is None else int(n_nonlinear)
    a = equal_force_amplitudes(K1, float(amplitudes[0]))
    if higher is not None:
        a[1:] = np.asarray(higher, dtype=float)[1:]
    plan = CondensationPlan(a[:k], levels)
    # the solved structure, its K and K1_solved (its linear response to K Φ p is Φ p), and the
    # projection's weight W in q = (ΦᵀWΦ)⁻¹ ΦᵀW u. W = M for the model's own modes (there W = K
    # gives the same q: K Φ = M Φ Λ); on a skeleton Φ is no eigenbasis, and only W = K keeps the
    # condensed force a gradient (the solve's Lagrange condition ∇U = K Φ p then matches the
    # projection's constraint Φᵀ K u = K1 q), as the ROM's potential needs.
    if skeleton is None:
        solver, K1_solved, W = backend, K1, backend.mass_matrix()
    else:
        solver, Phi = skeleton.backend, Phi[skeleton.rows]
        K = W = solver.stiffness_matrix()
        K1_solved = project(K, Phi)
    WPhi = np.asarray(W @ Phi)
    gram = Phi.T @ WPhi
    P, Q, T = [], [], []
    KPhi = np.asarray(K @ Phi)

    def record(p, u):
        P.append(p)
        Q.append(np.linalg.solve(gram, WPhi.T @ u))
        if tangents:
            T.append(condensed_tangent(tangent_gram(solver, u, KPhi), K1_solved, k))

    failed, first_error = solve_plan(
        plan, n, k, lambda p, u0: solver.static_solve(np.asarray(K @ (Phi @ p)).ravel(),
                                                      u0=u0).u, record, progress=progress)
    data = CondensationData(np.array(P).reshape(-1, Phi.shape[1]),
                            np.array(Q).reshape(-1, Phi.shape[1]), failed,
                            np.array(T).reshape(-1, n, k) if tangents else None)
    why = f" ({len(failed)} loads failed{first_error})" if failed else ""
    stiff = stiffness_from_condensation(data.p, data.q, K1_solved, a, n_nonlinear=k, failed=why,
                                        tangents=data.tangents)
    stiff.plan_info = {"levels": plan.levels, "nonlinear_modes": k,
                       "static_solves": len(data.q), "failed_solves": len(failed)}
    if skeleton is not None:
        stiff.K1 = 0.5 * (K1 + K1.T)
        stiff.plan_info["skeleton"] = skeleton.what
    return stiff, data


# -- the exact condensation at a deformed state, and the ROM about it ----------------------------
@dataclass(frozen=True)
class ModalLoadLaw:
    """The load that holds a reference state, as a generalized force on the modal coordinates:
    F(q) = ``constant`` − ``stiffness`` q (e.g. a steady aerodynamic load −q∞ (Q_α α + Q(0) q)).
    ``condition`` (JSON) describes it for the ROM's record."""

    constant: np.ndarray
    stiffness: np.ndarray
    condition: dict = field(default_factory=dict)

    def scaled(self, factor: float) -> ModalLoadLaw:
        return ModalLoadLaw(factor * np.asarray(self.constant),
                            factor * np.asarray(self.stiffness), self.condition)


@dataclass
class CondensedState:
    """One condensed equilibrium: ``q`` the ROM coordinates, ``p`` the solved structure's modal
    load, ``u`` its displacements, ``S`` = (KΦ)ᵀ K_T⁻¹ (KΦ), ``iterations`` (FE solves)."""

    q: np.ndarray
    p: np.ndarray
    u: np.ndarray
    S: np.ndarray
    iterations: int


class ExactCondensation:
    """The exact implicit condensation of a (restrained) backend ``solver`` on ``Phi`` (its
    DOFs × n) with the ROM's linear stiffness ``K1`` (n, n).

    The solved structure carries the load K Φ p; its solution u(p) has the coordinates
    q = A⁻¹ Φᵀ K u, A = Φᵀ K Φ. The ROM's structural force at q is exactly D q + A p(q), with
    D = K1 − A the part of K1 the solved structure lacks (a linear skin's; zero without one),
    and its tangent there is K_c = D + A S⁻¹ A with S = (KΦ)ᵀ K_T(u)⁻¹ (KΦ) (dq/dp = A⁻¹ S).
    Written here: no library condenses an FE tangent onto a ROM basis."""

    def __init__(self, solver, Phi: np.ndarray, K1: np.ndarray):
        from .backend import project

        self.backend, self.Phi = solver, np.asarray(Phi)
        K = solver.stiffness_matrix()
        self.KPhi = np.asarray(K @ self.Phi)
        self.A = project(K, self.Phi)
        self.D = np.asarray(K1, dtype=float) - self.A

    def solve(self, p: np.ndarray, u0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
        """(u, q, S) of the load K Φ p."""
        u = self.backend.static_solve(self.KPhi @ p, u0=u0).u
        q = np.linalg.solve(self.A, self.KPhi.T @ u)
        return u, q, tangent_gram(self.backend, u, self.KPhi)

    def coordinates(self, u: np.ndarray) -> np.ndarray:
        return np.linalg.solve(self.A, self.KPhi.T @ u)

    def equilibrium_under(self, law: ModalLoadLaw, p0: np.ndarray, u0: np.ndarray | None = None,
                          rtol: float = 1e-9, max_iter: int = 12) -> CondensedState:
        """Newton on p from ``p0`` until D q(p) + A p + G q(p) = c (``law``: c − G q) within
        ``rtol`` of ‖c‖ (ConvergenceError otherwise); each step one nonlinear FE solve."""
        G, c = np.asarray(law.stiffness), np.asarray(law.constant)
        scale = max(np.linalg.norm(c), np.finfo(float).tiny)
        p, u = np.asarray(p0, dtype=float).copy(), u0
        for it in range(1, max_iter + 1):
            u, q, S = self.solve(p, u)
            R = (self.D + G) @ q + self.A @ p - c
            if np.linalg.norm(R) <= rtol * scale:
                return CondensedState(q, p, u, S, it)
            J = (self.D + G) @ np.linalg.solve(self.A, S) + self.A
            p = p - np.linalg.solve(J, R)
        raise ConvergenceError(f"condensed equilibrium: not converged in {max_iter} FE solves "
                               f"(residual {np.linalg.norm(R) / scale:.1e} of the load)")

    def tangent(self, state: CondensedState) -> np.ndarray:
        """K_c = D + A S⁻¹ A at ``state`` (symmetrized: S is, to rounding)."""
        Kc = self.D + self.A @ np.linalg.solve(state.S, self.A)
        return 0.5 * (Kc + Kc.T)

    def force(self, state: CondensedState) -> np.ndarray:
        """The structural force D q + A p at ``state``."""
        return self.D @ state.q + self.A @ state.p


#: the load fractions by which the reference equilibrium is approached from rest (a step that
#: fails is halved, at most :data:`REFERENCE_HALVINGS` times)
REFERENCE_STEPS = (0.25, 0.5, 0.75, 1.0)
REFERENCE_HALVINGS = 4


def reference_equilibrium(condensation: ExactCondensation, law: ModalLoadLaw
                          ) -> CondensedState:
    """The condensed equilibrium under ``law``, its load continued from rest in
    :data:`REFERENCE_STEPS` (a failed step halved)."""
    n = condensation.A.shape[0]
    p, u, lam, state = np.zeros(n), None, 0.0, None
    targets = list(REFERENCE_STEPS)
    halvings = 0
    while targets:
        target = targets[0]
        try:
            state = condensation.equilibrium_under(law.scaled(target), p, u)
        except ConvergenceError:
            if halvings >= REFERENCE_HALVINGS:
                raise
            halvings += 1
            targets.insert(0, 0.5 * (lam + target))
            continue
        p, u, lam = state.p, state.u, target
        targets.pop(0)
    return state


def identify_stiffness_about(backend, Phi: np.ndarray, law: ModalLoadLaw,
                             amplitudes: np.ndarray, *, levels: int = 1,
                             n_nonlinear: int | None = None, progress=None,
                             skeleton: Skeleton | None = None
                             ) -> tuple[StiffnessIdentification, CondensationData]:
    """The condensed ROM about the deformed state that ``law`` holds (:mod:`torchrom.rom.
    reference`): the exact condensation's equilibrium q_ref (:func:`reference_equilibrium`),
    its tangent K_c as the ROM's K1 (exact there), and K2, K3 the Taylor terms of the
    condensed potential about it (:func:`.potential_fit.fit_potential`), fitted to the solves
    of the modal loads p_ref + δp, δp on the STEP directions of ``amplitudes`` (n,) over the
    first ``n_nonlinear`` modes, each solved from the reference: with x = q − q_ref, each
    solve's force change f(q_ref + x) − f_ref = A δp + D x = K_c x + K2(x,x) + K3(x,x,x) and
    its exact condensed tangent D + A S⁻¹ A = K_c + 2 K2(x) + 3 K3(x,x).
    The ROM's coordinates are x; ``reference`` on the result keeps q_ref and f_ref.
    ``progress(done, total)`` after each FE solve (the reference's first)."""
    from ..rom.reference import ReferenceState
    from .backend import project
    from .potential_fit import fit_potential

    K1 = project(backend.stiffness_matrix(), Phi)
    n = Phi.shape[1]
    k = n if n_nonlinear is None else int(n_nonlinear)
    solver, Phi_s = (backend, Phi) if skeleton is None else (skeleton.backend, Phi[skeleton.rows])
    cond = ExactCondensation(solver, Phi_s, K1)
    ref = reference_equilibrium(cond, law)
    Kc, f_ref = cond.tangent(ref), cond.force(ref)
    plan = CondensationPlan(np.asarray(amplitudes, dtype=float)[:k], levels)
    dP, X, T = [], [], []

    def record(dp, u):
        dP.append(dp)
        X.append(cond.coordinates(u) - ref.q)
        S = tangent_gram(solver, u, cond.KPhi)
        T.append(cond.D + cond.A @ np.linalg.solve(S, cond.A))

    failed, first_error = solve_plan(
        plan, n, k, lambda dp, u0: solver.static_solve(cond.KPhi @ (ref.p + dp), u0=u0).u,
        record, u_start=ref.u, progress=progress)
    dP, X = np.array(dP).reshape(-1, n), np.array(X).reshape(-1, n)
    T = np.array(T).reshape(-1, n, n)
    N = dP @ cond.A.T + X @ (cond.D - Kc).T
    why = f" ({len(failed)} loads failed{first_error})" if failed else ""
    try:
        fit = fit_potential(X, 0.5 * (T + T.transpose(0, 2, 1)), N, Kc, k)
    except InputError as err:
        raise InputError(f"condensation about the state: {err}{why}") from None
    stiff = StiffnessIdentification(Kc, fit.K2, fit.K3, "condensed", plan.amplitudes,
                                    {"condensation_fit": fit.force_fit,
                                     "condensation_tangent_fit": fit.tangent_fit}, len(X))
    stiff.plan_info = {"levels": plan.levels, "nonlinear_modes": k,
                       "static_solves": len(X) + ref.iterations, "failed_solves": len(failed),
                       "about": law.condition, "fit": "potential (forces and exact tangents)"}
    if skeleton is not None:
        stiff.plan_info["skeleton"] = skeleton.what
    stiff.reference = ReferenceState(ref.q, f_ref, law.condition)
    return stiff, CondensationData(dP, X, failed, T)
