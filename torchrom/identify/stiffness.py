"""Non-intrusive stiffness identification: the tangent-stiffness method (Eqs. 37–41) and STEP.

**Tangent method.** At an imposed displacement u = Φq the projected FE tangent is a quadratic
polynomial in q (symmetric storage, DESIGN "Conventions"):

    K_T(q) = Φᵀ K̂_T(Φq) Φ = K1 + 2 K2(q, ·) + 3 K3(q, q, ·)                          (Eqs. 38–41)

so K_T[m, u] = K1_mu + Σ_j A1_muj q_j + Σ_jl A2_mujl q_j q_l with A1 = 2 K2, A2 = 3 K3. The plan
imposes q = ±a_j e_j (Eqs. 38–40; the two signs separate the quadratic from the cubic term) and
q = ±(a_j e_j + a_l e_l), j < l (Eq. 41; the paper uses one sign and the already identified
K2; using both cancels the quadratic term exactly). The same fit applied to the projected material
tangent gives the damping tangent D_T(q) = D̄1 + D̄2(q) + D̄3(q, q) of Eq. 32 (``exact`` damping,
:mod:`.damping`). Every entry of K2 and K3 is seen several times (K2_muj from the run along j and
K2_mju from the run along u, ...): the tensors are averaged into symmetric storage and the spread
is reported as *symmetry residuals* — large ones mean the FE is not cubic in u (e.g. rotations
not small) or not conservative.

**STEP** (enforced displacements, Muravyov & Rizzi 2003): the projected restoring force
Φᵀ f(Φq) = K1 q + K̃2(q,q) + K̃3(q,q,q) at q = ±a_j e_j, at the four sign pairs ±a_j e_j ± a_l e_l
and at ±(a_j e_j + a_k e_k + a_l e_l) gives every combined coefficient (Eqs. 25–26) by exact
linear algebra on the monomials. It needs only forces (no tangent), but O(n³) evaluations.

Both are exact for an FE whose internal force is a cubic polynomial in u (St Venant–Kirchhoff with
Green strain), for any amplitude, up to rounding ~ ε‖K1‖/(a² ‖K3‖).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import InputError
from ..rom import conventions as cv
from ..rom.monomials import monomial_index


# ------------------------------------------------------------------------------------------------
# amplitudes
# ------------------------------------------------------------------------------------------------
def identification_amplitudes(Phi: np.ndarray, amplitude: float, reference_length: float = 1.0,
                              translational_dofs: np.ndarray | None = None) -> np.ndarray:
    """Modal amplitudes a_j such that max |Φ_j a_j| over the translational DOFs equals
    ``amplitude`` × ``reference_length`` (e.g. 0.01 × span).

    The amplitude is an option of the identification: for a cubic FE any value gives the same
    tensors up to rounding; for a non-cubic one smaller amplitudes approach the Taylor
    coefficients.
    """
    if not amplitude > 0:
        raise InputError(f"identification amplitude must be positive, got {amplitude}")
    rows = Phi if translational_dofs is None else Phi[np.asarray(translational_dofs)]
    peak = np.abs(rows).max(axis=0)
    if np.any(peak == 0):
        bad = np.flatnonzero(peak == 0).tolist()
        raise InputError(f"basis functions {bad} have no translational displacement; pass "
                         "modal amplitudes explicitly")
    return amplitude * reference_length / peak


# ------------------------------------------------------------------------------------------------
# tangent plan and fit (shared by the stiffness and the exact damping)
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TangentPlan:
    """Imposed modal displacements of the tangent method (Eqs. 38–41).

    ``points`` (P, n): row 0 is q = 0; then +a_j e_j, −a_j e_j for each j; then for each pair
    j < l: a_j e_j + a_l e_l and (if ``symmetric_pairs``) its negative.
    """

    amplitudes: np.ndarray
    symmetric_pairs: bool = True
    points: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        a = np.asarray(self.amplitudes, dtype=float)
        n = a.size
        rows = [np.zeros(n)]
        for j in range(n):
            for s in (1.0, -1.0):
                q = np.zeros(n)
                q[j] = s * a[j]
                rows.append(q)
        for j, l in itertools.combinations(range(n), 2):
            for s in ((1.0, -1.0) if self.symmetric_pairs else (1.0,)):
                q = np.zeros(n)
                q[j], q[l] = s * a[j], s * a[l]
                rows.append(q)
        object.__setattr__(self, "amplitudes", a)
        object.__setattr__(self, "points", np.array(rows))

    @property
    def n(self) -> int:
        return self.amplitudes.size

    def single_index(self, j: int, sign: int) -> int:
        return 1 + 2 * j + (0 if sign > 0 else 1)

    def pair_index(self, j: int, l: int, sign: int = 1) -> int:
        n, per = self.n, (2 if self.symmetric_pairs else 1)
        # rank of (j, l) among the pairs j < l in lexicographic order
        rank = j * n - j * (j + 1) // 2 + (l - j - 1)
        return 1 + 2 * n + per * rank + (0 if sign > 0 else 1)


def fit_quadratic_matrix(plan: TangentPlan, T: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                      np.ndarray]:
    """Fit T(q) = T0 + Σ_j A1[:, :, j] q_j + Σ_jl A2[:, :, j, l] q_j q_l to the plan's matrices.

    Args:
        plan: the imposed displacements.
        T: (P, n, n) matrices at ``plan.points``.
    Returns:
        (T0 (n, n), A1 (n, n, n), A2 (n, n, n, n) symmetric in its last two indices).
    """
    a, n = plan.amplitudes, plan.n
    if T.shape != (len(plan.points), n, n):
        raise InputError(f"tangent data: expected shape {(len(plan.points), n, n)}, got "
                         f"{T.shape}")
    T0 = T[0]
    A1 = np.empty((n, n, n))
    A2 = np.empty((n, n, n, n))
    for j in range(n):
        tp, tm = T[plan.single_index(j, 1)], T[plan.single_index(j, -1)]
        A1[:, :, j] = (tp - tm) / (2 * a[j])
        A2[:, :, j, j] = (tp + tm - 2 * T0) / (2 * a[j] ** 2)
    for j, l in itertools.combinations(range(n), 2):
        tp = T[plan.pair_index(j, l, 1)]
        if plan.symmetric_pairs:
            quad = 0.5 * (tp + T[plan.pair_index(j, l, -1)]) - T0
        else:
            quad = tp - T0 - a[j] * A1[:, :, j] - a[l] * A1[:, :, l]
        cross = (quad - a[j] ** 2 * A2[:, :, j, j] - a[l] ** 2 * A2[:, :, l, l]) / (
            2 * a[j] * a[l])
        A2[:, :, j, l] = A2[:, :, l, j] = cross
    return T0, A1, A2


def _rel_spread(T: np.ndarray, T_sym: np.ndarray) -> float:
    scale = np.abs(T).max()
    return float(np.abs(T - T_sym).max() / scale) if scale > 0 else 0.0


def _full_sym(T: np.ndarray) -> np.ndarray:
    perms = list(itertools.permutations(range(T.ndim)))
    return sum(np.transpose(T, p) for p in perms) / len(perms)


@dataclass
class StiffnessIdentification:
    """Identified stiffness tensors (symmetric storage) and their quality indicators.

    ``residuals`` (all relative to the largest entry of the tensor concerned):
    - ``tangent_asymmetry``: max over the plan of ‖K_T − K_Tᵀ‖ (a conservative FE gives 0);
    - ``K2_storage`` / ``K3_storage``: spread between the estimates of the same entry of K2
      (K2_muj vs K2_mju) and of K3 (over its last three indices) — 0 for a cubic FE;
    - ``K2_full`` / ``K3_full``: departure from symmetry in all indices (a potential force has
      fully symmetric K2, K3);
    - ``K1_tangent_vs_linear``: projected tangent at u = 0 vs projected linear stiffness;
    - ``condensation_fit``: the least-squares misfit of the condensation (:mod:`.condensation`).
    """

    K1: np.ndarray
    K2: np.ndarray
    K3: np.ndarray
    method: str
    amplitudes: np.ndarray
    residuals: dict[str, float]
    n_evaluations: int
    #: what the plan did beyond the fit, for the ROM's metadata (e.g. the condensation's load
    #: levels and failed solves)
    plan_info: dict = field(default_factory=dict)
    #: the deformed state the tensors are expanded about
    #: (:class:`~torchrom.rom.reference.ReferenceState`), None about the undeformed state
    reference: object | None = None

    def combined(self) -> dict[str, np.ndarray]:
        """The paper's combined K̃2, K̃3 (Eqs. 25–26) as dense arrays."""
        c = cv.to_combined(torch.as_tensor(self.K2), torch.as_tensor(self.K3))
        return {k: v.numpy() for k, v in c.items()}


#: The largest identification residual (:attr:`StiffnessIdentification.residuals`, relative to
#: the largest entry of the tensor concerned) at or below which it is rounding: a cubic FE's
#: residuals are ε‖K1‖/(a²‖K3‖) (module docstring), growing as the amplitude a falls —
#: measured 1e-13 on the Goland deck (Green strain, a = 1 % of the span) and 6e-13 on the cubic
#: truss of tests/test_identify_stiffness.py at a = 0.1 % of the span (8e-14 at 1 %) — while a
#: co-rotational FE's non-cubic part measured 9e-5 (the Pazy wing's 1L1D) to 4.3e-4 (the
#: public TACS wingbox's 6L6D), both at 1 %: 1e-8 lies four decades above the one and as far
#: below the other.
ROUNDING_RESIDUAL = 1e-8
#: … and above which the cubic fit misrepresents the FE: two estimates of one tensor entry that
#: disagree by 0.1 % of the largest entry are an error of that order in the ROM's nonlinear
#: forces, a decade below the ROM's own static error against the FE that the Goland acceptance
#: allows (2 % at point A, tests/test_identify_goland.py)
SMALL_RESIDUAL = 1e-3


def residual_wording(value: float) -> str:
    """What the largest identification residual ``value`` says, in the words ``torchrom
    identify`` prints after it: rounding (a cubic FE, at or below :data:`ROUNDING_RESIDUAL`),
    small (a non-cubic FE's cubic fit, up to :data:`SMALL_RESIDUAL`), or large (beyond it, or
    not finite)."""
    if value <= ROUNDING_RESIDUAL:
        return "rounding level for a cubic FE"
    if value <= SMALL_RESIDUAL:
        return ("small: the FE is not exactly cubic at this amplitude (e.g. co-rotational "
                "elements), and the ROM holds its cubic fit")
    return ("large — the cubic fit does not represent the FE's forces at these amplitudes; try "
            "a smaller --amplitude")


def stiffness_from_tangents(plan: TangentPlan, KT: np.ndarray, K1_linear: np.ndarray | None = None
                            ) -> StiffnessIdentification:
    """K1, K2, K3 from projected tangents at the plan's points (Eqs. 37–41)."""
    T0, A1, A2 = fit_quadratic_matrix(plan, KT)
    K2raw = 0.5 * A1            # K2[m, u, j]
    K3raw = A2 / 3.0            # K3[m, u, j, l]
    K2 = cv.sym_last2(torch.as_tensor(K2raw)).numpy()
    K3 = cv.sym_last3(torch.as_tensor(K3raw)).numpy()
    K1 = T0 if K1_linear is None else np.asarray(K1_linear, dtype=float)
    asym = max(_rel_spread(T, T.T) for T in KT)
    res = {
        "tangent_asymmetry": asym,
        "K2_storage": _rel_spread(K2raw, K2),
        "K3_storage": _rel_spread(K3raw, K3),
        "K2_full": _rel_spread(K2, _full_sym(K2)),
        "K3_full": _rel_spread(K3, _full_sym(K3)),
        "K1_tangent_vs_linear": _rel_spread(T0, K1),
    }
    return StiffnessIdentification(0.5 * (K1 + K1.T), K2, K3, "tangent", plan.amplitudes, res,
                                   len(plan.points))


def identify_stiffness_tangent(backend, Phi: np.ndarray, amplitudes: np.ndarray, *,
                               symmetric_pairs: bool = True, material: bool = False,
                               progress=None):
    """Run the tangent plan on a backend: returns (StiffnessIdentification, plan, KT, Kmat).

    With ``material`` the projected material tangents are collected at the same displacements
    (for the ``exact`` damping identification). ``progress`` is an optional callable(done, total).
    """
    from .backend import project

    plan = TangentPlan(np.asarray(amplitudes, dtype=float), symmetric_pairs)
    P = len(plan.points)
    n = Phi.shape[1]
    KT = np.empty((P, n, n))
    Km = np.empty((P, n, n)) if material else None
    # ten calls: a backend may evaluate a call's points together (the built-in FE's
    # co-rotational tangents share one automatic-differentiation pass), and progress is
    # reported every 10 % anyway
    chunk = max(1, -(-P // 10))
    for start in range(0, P, chunk):
        kt, km = backend.projected_tangents(Phi, plan.points[start:start + chunk], material)
        KT[start:start + chunk] = kt
        if material:
            Km[start:start + chunk] = km
        if progress is not None:
            progress(min(P, start + chunk), P)
    K1 = project(backend.stiffness_matrix(), Phi)
    return stiffness_from_tangents(plan, KT, K1), plan, KT, Km


# ------------------------------------------------------------------------------------------------
# STEP: enforced displacements, restoring forces only
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StepPlan:
    """Imposed modal displacements of STEP: ±a_j e_j; (s1 a_j, s2 a_l) for the four sign pairs;
    ±(a_j, a_k, a_l) for j < k < l."""

    amplitudes: np.ndarray
    points: np.ndarray = field(init=False, repr=False)
    labels: tuple = field(init=False, repr=False)

    def __post_init__(self):
        a = np.asarray(self.amplitudes, dtype=float)
        n = a.size
        rows, labels = [], []
        for j in range(n):
            for s in (1.0, -1.0):
                q = np.zeros(n)
                q[j] = s * a[j]
                rows.append(q)
                labels.append(("single", j, s))
        for j, l in itertools.combinations(range(n), 2):
            for s1, s2 in ((1, 1), (-1, -1), (1, -1), (-1, 1)):
                q = np.zeros(n)
                q[j], q[l] = s1 * a[j], s2 * a[l]
                rows.append(q)
                labels.append(("pair", j, l, s1, s2))
        for j, k, l in itertools.combinations(range(n), 3):
            for s in (1.0, -1.0):
                q = np.zeros(n)
                q[[j, k, l]] = s * a[[j, k, l]]
                rows.append(q)
                labels.append(("triple", j, k, l, s))
        object.__setattr__(self, "amplitudes", a)
        object.__setattr__(self, "points", np.array(rows).reshape(-1, n))
        object.__setattr__(self, "labels", tuple(labels))


def stiffness_from_forces(plan: StepPlan, F: np.ndarray, K1: np.ndarray
                          ) -> StiffnessIdentification:
    """Combined K̃2, K̃3 (returned in symmetric storage) from projected restoring forces."""
    a, n = plan.amplitudes, plan.amplitudes.size
    if F.shape != (len(plan.points), n):
        raise InputError(f"force data: expected shape {(len(plan.points), n)}, got {F.shape}")
    idx = monomial_index(n)
    pid = idx.pair_id
    tid = {tuple(t): i for i, t in enumerate(idx.triples.tolist())}
    K2c = np.zeros((n, idx.n_pairs))
    K3c = np.zeros((n, idx.n_triples))
    g = F - plan.points @ K1.T          # nonlinear part of the restoring force
    at = {lab: g[i] for i, lab in enumerate(plan.labels)}
    for j in range(n):
        gp, gm = at[("single", j, 1.0)], at[("single", j, -1.0)]
        K2c[:, pid[j, j]] = 0.5 * (gp + gm) / a[j] ** 2
        K3c[:, tid[(j, j, j)]] = 0.5 * (gp - gm) / a[j] ** 3
    for j, l in itertools.combinations(range(n), 2):
        r = {s: at[("pair", j, l, *s)] for s in ((1, 1), (-1, -1), (1, -1), (-1, 1))}
        q_plus = 0.5 * (r[(1, 1)] + r[(-1, -1)])
        q_minus = 0.5 * (r[(1, -1)] + r[(-1, 1)])
        K2c[:, pid[j, l]] = 0.5 * (q_plus - q_minus) / (a[j] * a[l])
        c_plus = 0.5 * (r[(1, 1)] - r[(-1, -1)])     # a³ terms with signs (+, +)
        c_mixed = 0.5 * (r[(1, -1)] - r[(-1, 1)])    # (+, −)
        jjj, lll = K3c[:, tid[(j, j, j)]], K3c[:, tid[(l, l, l)]]
        K3c[:, tid[(j, l, l)]] = (0.5 * (c_plus + c_mixed) - a[j] ** 3 * jjj) / (a[j] * a[l] ** 2)
        K3c[:, tid[(j, j, l)]] = (0.5 * (c_plus - c_mixed) - a[l] ** 3 * lll) / (a[j] ** 2 * a[l])
    for j, k, l in itertools.combinations(range(n), 3):
        cubic = 0.5 * (at[("triple", j, k, l, 1.0)] - at[("triple", j, k, l, -1.0)])
        q = np.zeros(n)
        q[[j, k, l]] = a[[j, k, l]]
        m3 = np.prod(q[idx.triples], axis=1)
        cubic = cubic - K3c @ m3            # the (j, k, l) column is still zero here
        K3c[:, tid[(j, k, l)]] = cubic / (a[j] * a[k] * a[l])
    sym = cv.symmetric_from_compact(torch.as_tensor(K2c), torch.as_tensor(K3c))
    K2, K3 = sym["K2"].numpy(), sym["K3"].numpy()
    res = {"K2_full": _rel_spread(K2, _full_sym(K2)), "K3_full": _rel_spread(K3, _full_sym(K3))}
    return StiffnessIdentification(0.5 * (K1 + K1.T), K2, K3, "step", a, res, len(plan.points))


def identify_stiffness_step(backend, Phi: np.ndarray, amplitudes: np.ndarray, progress=None
                            ) -> tuple[StiffnessIdentification, StepPlan, np.ndarray]:
    """Run the STEP plan on a backend: returns (StiffnessIdentification, plan, forces)."""
    from .backend import project

    plan = StepPlan(np.asarray(amplitudes, dtype=float))
    P = len(plan.points)
    F = np.empty((P, Phi.shape[1]))
    chunk = max(1, P // 50)
    for start in range(0, P, chunk):
        F[start:start + chunk] = backend.projected_forces(Phi, plan.points[start:start + chunk])
        if progress is not None:
            progress(min(P, start + chunk), P)
    K1 = project(backend.stiffness_matrix(), Phi)
    return stiffness_from_forces(plan, F, K1), plan, F
