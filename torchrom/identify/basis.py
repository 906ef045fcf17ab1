"""The ROM basis: mass-normalised linear modes plus dual modes (DIGEST Sec. 6, Eqs. 47–48).

Dual modes capture what the linear modes cannot: mostly the in-plane (membrane) displacements a
large transverse deflection drags along. For each combination (j, l) of linear modes the static
loads F = α K U^(j) (Eq. 47) or F = α (K U^(j) + K U^(l)) (Eq. 48) are solved nonlinearly for a
range of α; the residuals outside the span of the linear modes are decomposed by POD and the
dominant vectors, mass-orthonormalised, are the dual modes. The options of
:class:`DualModeOptions` — amplitudes set by the FE response (not the linear prediction, which
overloads softening combinations), a stiffness-norm POD (the energy norm that bounds a Galerkin
ROM's static error), relative snapshot weights, and the combinations
(:func:`transverse_combinations` by the modes' kinds, or the paper's nine) — were chosen by the
static and free-decay errors at point A of the Goland wing (``experiments/goland_validation.py``,
``experiments/results/goland_validation*.md``). The same FE gives the same basis bit for bit. A
load the FE cannot carry is recorded as "failed" and the larger loads of that combination and
sign are skipped. The static solves are the backend's, the eigen-solvers scipy's.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..eigen import orient_columns
from ..errors import ConvergenceError, InputError

#: the paper's combinations (j, l), 1-based mode numbers (DIGEST Sec. 6)
PAPER_COMBINATIONS: tuple[tuple[int, int], ...] = (
    (1, 1), (1, 2), (1, 3), (1, 4), (1, 5), (2, 2), (2, 3), (2, 4), (2, 5))
#: combinations of the first bending, torsion and second bending modes only (the default of the
#: built-in Goland pipeline, see the module docstring)
BENDING_TORSION_COMBINATIONS: tuple[tuple[int, int], ...] = (
    (1, 1), (1, 2), (1, 3), (2, 2), (2, 3))
#: named combination sets (``torchrom identify --combinations NAME``)
NAMED_COMBINATIONS = {"paper": PAPER_COMBINATIONS,
                      "bending-torsion": BENDING_TORSION_COMBINATIONS}


#: the rule :func:`transverse_combinations` (``torchrom identify --combinations transverse``)
TRANSVERSE_RULE = "transverse"


def transverse_combinations(kinds: Sequence[str]) -> tuple[tuple[int, int], ...]:
    """Dual-mode combinations chosen from the linear modes' kinds (:mod:`torchrom.fe.kinds`):
    the first two transverse (bending or torsion) modes t1, t2, each loaded alone and together
    with the next transverse modes up to the third transverse mode or the second bending mode,
    whichever comes later — (t1,t1), (t1,t2), (t1,t3)…, (t2,t2), (t2,t3)….
    In-plane and axial modes are left out: the loads along them push a wing box towards its
    lateral–torsional instability (module docstring, "Combinations"). The second bending mode is
    reached even when a torsion mode lies below it (the updated heavy Goland wing: modes 1
    bending, 2-3 torsion, 4 bending): without it the uniform-pressure A_Ty error at 25 % of span
    is 2.03 % instead of 1.58 % (9L12D, ``experiments/goland_validation.py --wing updated``).
    On the calibrated Goland wing (1 bending, 2 torsion, 3 bending) this is
    :data:`BENDING_TORSION_COMBINATIONS`."""
    t = [i + 1 for i, k in enumerate(kinds) if k in ("bending", "torsion")]
    if not t:
        rigid = list(kinds).count("rigid-body")
        raise InputError(f"dual modes: no transverse (bending or torsion) mode among the "
                         f"{len(kinds)} linear modes ({', '.join(sorted(set(kinds)))}) to load: "
                         + ("raise --linear past the rigid-body modes, " if rigid else "")
                         + "give pairs of elastic modes with --combinations J:L,... or identify "
                           "the linear modes only with --dual 0")
    bending = [i for i, m in enumerate(t) if kinds[m - 1] == "bending"]
    last = max(min(3, len(t)), bending[1] + 1 if len(bending) > 1 else 0)
    return tuple((t[a], t[b]) for a in range(min(2, len(t))) for b in range(a, last))


def parse_combinations(text: str, where: str = "--combinations",
                       kinds: Sequence[str] | None = None) -> tuple[tuple[int, int], ...]:
    """A named set (``paper``, ``bending-torsion``), the rule ``transverse`` (needs the linear
    modes' ``kinds``) or pairs ``J:L,J:L,...`` (1-based)."""
    if text in NAMED_COMBINATIONS:
        return NAMED_COMBINATIONS[text]
    if text == TRANSVERSE_RULE:
        if kinds is None:
            raise InputError(f"{where}: the rule {TRANSVERSE_RULE!r} needs the mode kinds")
        return transverse_combinations(kinds)
    pairs = []
    for item in text.split(","):
        try:
            j, l = (int(x) for x in item.split(":"))
        except ValueError:
            raise InputError(f"{where}: expected one of "
                             f"{sorted(NAMED_COMBINATIONS) + [TRANSVERSE_RULE]} or pairs "
                             f"J:L,J:L,... of 1-based mode numbers, got {text!r}") from None
        pairs.append((j, l))
    return tuple(pairs)


AMPLITUDE_CONTROLS = ("response", "linear")
POD_NORMS = ("stiffness", "mass")
SNAPSHOT_WEIGHTS = ("relative", "unit", "none")


def _check_choice(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise InputError(f"dual modes: {name}: expected one of {allowed}, got {value!r}")


@dataclass
class DualModeOptions:
    """Options of the dual-mode generation (DIGEST Sec. 6; see the module docstring).

    combinations: (j, l) pairs of 1-based linear-mode numbers (j == l: single mode, Eq. 47);
    n_amplitudes: loads per combination (half positive, half negative);
    tip_range: tip transverse displacement range as fractions of the span;
    amplitude_control: "response" (the FE's tip deflection spread over the range, α never
    beyond its linear prediction) or "linear" (the linear prediction spread over the range);
    response_tolerance: relative tolerance on the FE tip deflection of each target ("response");
    pod_norm: inner product of the POD, "stiffness" (strain energy) or "mass";
    snapshot_weights: how each residual enters the POD: "relative" (divided by the norm of
    the response's linear-mode part), "unit" (scaled to unit norm) or "none".
    """

    combinations: Sequence[tuple[int, int]] = PAPER_COMBINATIONS
    n_amplitudes: int = 20
    tip_range: tuple[float, float] = (0.001, 0.15)
    amplitude_control: str = "response"
    response_tolerance: float = 0.03
    pod_norm: str = "stiffness"
    snapshot_weights: str = "relative"

    def validate(self, n_linear: int) -> None:
        for (j, l) in self.combinations:
            if not (1 <= j <= n_linear and 1 <= l <= n_linear):
                raise InputError(f"dual modes: combination ({j}, {l}) refers to a linear mode "
                                 f"outside 1..{n_linear}")
        if self.n_amplitudes < 1 or not (0 < self.tip_range[0] <= self.tip_range[1]):
            raise InputError(f"dual modes: need n_amplitudes >= 1 and 0 < tip_range[0] <= "
                             f"tip_range[1], got {self.n_amplitudes}, {self.tip_range}")
        _check_choice("amplitude_control", self.amplitude_control, AMPLITUDE_CONTROLS)
        _check_choice("snapshot_weights", self.snapshot_weights, SNAPSHOT_WEIGHTS)
        _check_choice("pod_norm", self.pod_norm, POD_NORMS)
        if not 0 < self.response_tolerance < 1:
            raise InputError(f"dual modes: response_tolerance: expected 0 < value < 1, got "
                             f"{self.response_tolerance}")


@dataclass
class Basis:
    """Basis Φ (n_dof, n) = [linear modes | dual modes], mass-orthonormal.

    Attributes: kinds ("linear"/"dual" per column), frequencies_hz (NaN for dual modes),
    pod_values (normalised POD spectrum, descending), snapshots (one record per static solve:
    combination, α, predicted and achieved tip displacement / span), seconds, n_rigid (the
    first n_rigid linear modes are a free structure's rigid-body modes, at 0 Hz).
    """

    Phi: np.ndarray
    kinds: list[str]
    frequencies_hz: np.ndarray
    pod_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    snapshots: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    n_rigid: int = 0

    @property
    def n(self) -> int:
        return self.Phi.shape[1]


def linear_basis(backend, n_linear: int) -> Basis:
    """The n_linear lowest mass-normalised linear modes of the backend (InputError when the
    model has fewer finite modes: a basis cannot hold more modes than the model's DOFs)."""
    t0 = time.perf_counter()
    f, V = backend.modes(n_linear)
    found = np.asarray(V).shape[1] if np.ndim(V) == 2 else 0
    if found < n_linear:
        raise InputError(f"basis: {n_linear} linear modes asked for (--linear), but the model "
                         f"has {found} finite modes ({getattr(backend, 'n_dof', '?')} DOFs); "
                         f"expected at most {found}")
    return Basis(V, ["linear"] * n_linear, np.asarray(f, float), seconds=time.perf_counter() - t0,
                 n_rigid=int(getattr(backend, "n_rigid", 0)))


def _m_project_out(R: np.ndarray, Phi: np.ndarray, M) -> np.ndarray:
    """Remove the components along the M-orthonormal columns of Φ (twice, for rounding)."""
    for _ in range(2):
        R = R - Phi @ (Phi.T @ np.asarray(M @ R))
    return R


#: relative POD eigenvalue (a squared singular value) below which a snapshot direction is
#: rounding: 1e-14 is a singular value 1e-7 of the largest, far above float64's 1e-16 and far
#: below the smallest direction a dual mode is made of (3.7e-3 on the clamped BAH wing, whose
#: 8th eigenvalue is 1.7e-16)
POD_RANK_RTOL = 1e-14
#: relative size of a static response's part outside the linear modes (to its linear part,
#: in the POD norm) at or below which it is rounding, not a nonlinear response: a linear
#: structure's responses measured 5e-15 and 9e-15 (the clamped BAH and ExportNastranKM beams),
#: a geometrically nonlinear wing's 1e-4 and more at the smallest identification amplitude
LINEAR_RESPONSE_RTOL = 1e-9
#: relative mass norm below which a direction of the snapshots carries no mass (it lies in
#: massless DOFs, e.g. the rotations of a stick model whose mass is on CONM2 points): such a
#: direction cannot be mass-normalised
MASSLESS_RTOL = 1e-6


def pod_rank(spectrum: np.ndarray) -> int:
    """Independent directions of POD eigenvalues ``spectrum`` (descending):
    those above :data:`POD_RANK_RTOL` of the largest."""
    lam = np.asarray(spectrum, dtype=float)
    return int(np.sum(lam > POD_RANK_RTOL * lam[0])) if lam.size and lam[0] > 0 else 0


def pod(snapshots: np.ndarray, W, n_keep: int | None) -> tuple[np.ndarray, np.ndarray]:
    """POD (method of snapshots) in the inner product ⟨a, b⟩ = aᵀ W b (W = M or K):
    (W-orthonormal vectors (n_dof, n_keep), normalised eigenvalues of all snapshots, descending,
    summing to 1). Eigenvectors in decreasing eigenvalue order, signs by
    :func:`~torchrom.eigen.orient_columns`. ``n_keep`` None: every independent direction
    (:func:`pod_rank`)."""
    C = snapshots.T @ np.asarray(W @ snapshots)
    lam, V = scipy.linalg.eigh(0.5 * (C + C.T))
    lam, V = lam[::-1], V[:, ::-1]
    lam = np.clip(lam, 0.0, None)
    rank = pod_rank(lam)
    if n_keep is None:
        n_keep = rank
    if n_keep > rank:
        raise InputError(f"dual modes: asked for {n_keep} but the {snapshots.shape[1]} snapshots "
                         f"span only {rank} independent directions")
    Wv = orient_columns(snapshots @ V[:, :n_keep] / np.sqrt(lam[:n_keep]))
    return Wv, lam / max(lam.sum(), np.finfo(float).tiny)


def mass_orthonormal_prefix(V: np.ndarray, M, n_keep: int) -> tuple[np.ndarray, int]:
    """(Q, massless): up to ``n_keep`` mass-orthonormal vectors from V's columns (W-orthonormal
    POD vectors, energy order), and how many independent combinations of them carry no mass.

    Those combinations (the eigenvectors of VᵀMV below :data:`MASSLESS_RTOL`² of its largest
    eigenvalue: parts in massless DOFs alone, e.g. the rotations of a stick model whose mass is
    on CONM2 points) are removed from every column first, as they cannot be mass-normalised;
    then Gram–Schmidt in the M inner product (twice, for rounding) keeps the columns in their
    order, skipping one that the kept ones already span (what a Cholesky factor of VᵀMV does
    when it exists)."""
    G = V.T @ np.asarray(M @ V)
    g, E = np.linalg.eigh(0.5 * (G + G.T)) if V.shape[1] else (np.zeros(0), np.zeros((0, 0)))
    null = g <= MASSLESS_RTOL**2 * g.max(initial=0.0)
    massless = int(null.sum())
    if massless:
        N = E[:, null]
        V = V - V @ N @ N.T
    norms = _norms(M, V)
    ref = float(norms.max(initial=0.0))
    kept: list[np.ndarray] = []
    for v, own in zip(V.T, norms):
        if len(kept) == n_keep:
            break
        if not own > MASSLESS_RTOL * ref:
            continue
        w = v.copy()
        for _ in range(2):
            for q in kept:
                w -= q * float(q @ np.asarray(M @ w))
        nrm = float(np.sqrt(max(float(w @ np.asarray(M @ w)), 0.0)))
        if nrm > MASSLESS_RTOL * own:
            kept.append(w / nrm)
    Q = np.stack(kept, axis=1) if kept else np.zeros((V.shape[0], 0))
    return Q, massless


def _combination(Phi_L: np.ndarray, KU: np.ndarray, j: int, l: int):
    """(U, F): the linear displacement U^(j) (+ U^(l)) and the load K U^(j) (+ K U^(l))."""
    cols = [j - 1] if j == l else [j - 1, l - 1]
    return Phi_L[:, cols].sum(axis=1), KU[:, cols].sum(axis=1)


def _tip_fractions(opts: DualModeOptions) -> tuple[np.ndarray, np.ndarray]:
    """Target tip deflections (fractions of the span) of the positive and the negative loads."""
    half = opts.n_amplitudes // 2
    fr = np.linspace(opts.tip_range[0], opts.tip_range[1], half)
    return fr, fr[: opts.n_amplitudes - half]


def _tip(backend, u: np.ndarray) -> float:
    """Tip transverse displacement: the largest |transverse displacement| of the backend
    (:meth:`~torchrom.identify.backend.FEBackend.transverse_displacements`), over its
    translational DOFs when it knows none, as :func:`_transverse_peak`."""
    values = np.abs(backend.transverse_displacements(u))
    if not values.size:
        values = np.abs(u[backend.translational_dofs])
    return float(values.max()) if values.size else 0.0


def _transverse_peak(backend, U: np.ndarray) -> float:
    """The largest |transverse displacement| of U, else over the translational DOFs (a model
    whose free DOFs hold no transverse, or no translation at all, is refused)."""
    for values in (backend.transverse_displacements(U), U[backend.translational_dofs]):
        values = np.abs(values)
        if values.size and values.max() > 0:
            return float(values.max())
    raise InputError("dual modes: the linear modes move no free translational DOF (a model "
                     "without free translations: its loads cannot be scaled to a tip "
                     "deflection); use --dual 0")


@dataclass
class DualLoad:
    """One static load of the dual-mode generation: F = α Σ K U^(j) (Eqs. 47–48)."""

    combination: tuple[int, int]
    alpha: float
    load: np.ndarray
    tip_linear_pct_span: float


def dual_loads(backend, linear: Basis, options: DualModeOptions | None = None) -> list[DualLoad]:
    """The dual-mode loads with α from the linear prediction (``amplitude_control="linear"``,
    the plan written to Nastran decks), in solution order: per combination and sign, increasing
    |α| (so each solve can start from the previous one — and a SOL 106 run can continue)."""
    opts = options or DualModeOptions()
    Phi_L = linear.Phi
    opts.validate(Phi_L.shape[1])
    KU = np.asarray(backend.stiffness_matrix() @ Phi_L)
    span = backend.reference_length
    out = []
    for (j, l) in opts.combinations:
        U, F = _combination(Phi_L, KU, j, l)
        peak = _transverse_peak(backend, U)
        for sign, fractions in zip((1.0, -1.0), _tip_fractions(opts)):
            for t in fractions:
                a = sign * t * span / peak
                out.append(DualLoad((int(j), int(l)), float(a), a * F, float(100 * t)))
    return out


def _norms(W, X: np.ndarray) -> np.ndarray:
    return np.sqrt(np.clip(np.einsum("ij,ij->j", X, np.asarray(W @ X)), 0.0, None))


def dual_modes_from_responses(linear: Basis, M, responses: np.ndarray, n_dual: int, *,
                              K=None, pod_norm: str = "stiffness", weights: str = "relative"
                              ) -> tuple[Basis, np.ndarray]:
    """Dual modes from nonlinear static responses (rows of ``responses``): residuals outside the
    linear modes, weighted (``weights``, see :class:`DualModeOptions`), POD in the ``pod_norm``
    inner product (K needed for "stiffness"), mass-orthonormalised. Returns (basis, relative
    residuals: residual norm / norm of the linear-mode part, in the POD inner product)."""
    _check_choice("pod_norm", pod_norm, POD_NORMS)
    _check_choice("snapshot_weights", weights, SNAPSHOT_WEIGHTS)
    if pod_norm == "stiffness" and K is None:
        raise InputError("dual modes: the stiffness-norm POD needs the linear stiffness K")
    W = M if pod_norm == "mass" else K
    Phi_L = linear.Phi
    U = np.atleast_2d(responses).T
    R = _m_project_out(U, Phi_L, M)
    norms, linear_norms = _norms(W, R), _norms(W, U - R)
    relative = norms / np.where(linear_norms > 0, linear_norms, 1.0)
    if not relative.max(initial=0.0) > LINEAR_RESPONSE_RTOL:
        raise InputError(f"dual modes: the {U.shape[1]} static responses have no part outside "
                         f"the linear modes above rounding (at most {relative.max(initial=0.0):.1e}"
                         f" of their linear part): the FE model responds linearly (e.g. linear "
                         f"CBAR/CELAS elements only), so there is nothing for dual modes to "
                         f"capture; use --dual 0")
    scale = {"relative": linear_norms, "unit": norms, "none": np.ones_like(norms)}[weights]
    R = R / np.where(scale > 0, scale, 1.0)
    V, spectrum = pod(R, W, None)  # every independent direction, in energy order
    V = _m_project_out(V, Phi_L, M)
    # mass-orthonormalise the dual vectors among themselves (order-preserving), skipping the
    # directions without mass; the count follows what the snapshots hold, and says why
    V, massless = mass_orthonormal_prefix(V, M, n_dual)
    V = orient_columns(V)
    n_found = V.shape[1]
    if n_found < n_dual:
        why = (f"the {U.shape[1]} snapshots span {pod_rank(spectrum)} independent "
               f"directions outside the linear modes"
               + (f", {massless} of them without mass (massless DOFs)" if massless else ""))
        if n_found == 0:
            raise InputError(f"dual modes: {why}: no dual mode can be made; use --dual 0 (the "
                             f"structure's nonlinear response adds nothing to its linear modes)")
        warnings.warn(f"dual modes: {n_dual} asked for, but {why}: using {n_found} dual modes "
                      f"(--dual {n_found} gives the same ROM without this warning)", stacklevel=2)
    basis = Basis(np.concatenate([Phi_L, V], axis=1), linear.kinds + ["dual"] * n_found,
                  np.concatenate([linear.frequencies_hz, np.full(n_found, np.nan)]), spectrum)
    return basis, relative


@dataclass
class _Point:
    """A solved dual-mode load: |α|, FE tip deflection (length units), displacement."""

    alpha: float
    tip: float
    u: np.ndarray | None


class _Walk:
    """The loads of one combination and sign, in increasing order, each solved from the
    previous solution scaled to the new α (continuation)."""

    def __init__(self, backend, F: np.ndarray, sign: float, peak: float, opts: DualModeOptions):
        self.be, self.F, self.sign, self.peak, self.opts = backend, F, sign, peak, opts
        self.span = backend.reference_length
        self.last = _Point(0.0, 0.0, None)
        self.solves = 0
        self.failures = 0
        self.at_limit = False  # a target gave up on failed solves: the larger ones are skipped
        self.why = ""  # the last static solve's reason for failing

    def _solve(self, alpha: float, start: _Point) -> _Point:
        u0 = None if start.u is None else start.u * (alpha / start.alpha)
        self.solves += 1
        try:
            sol = self.be.static_solve(self.sign * alpha * self.F, u0=u0)
        except ConvergenceError as err:
            self.failures += 1
            self.why = str(err)
            return _Point(alpha, np.inf, None)
        return _Point(alpha, _tip(self.be, sol.u), sol.u)

    def linear(self, t: float) -> _Point | None:
        """α from the linear prediction of the target tip deflection t (fraction of span)."""
        p = self._solve(t * self.span / self.peak, self.last)
        return None if p.u is None else p

    def response(self, t: float, max_solves: int = 12, max_failures: int = 3) -> _Point | None:
        """α ≤ the linear-prediction α whose FE tip deflection is t (± the tolerance), or that
        α itself when the response stiffens: secant steps, then the Illinois variant of regula
        falsi once bracketed (bisection across a load the FE cannot carry, at most
        ``max_failures`` failed solves per target: each costs a static solve's whole step
        cutting, and past a limit load the bisection only creeps towards it)."""
        target, tol = t * self.span, self.opts.response_tolerance
        a_lin = target / self.peak
        lo, hi = self.last, None
        f_lo, f_hi, side = lo.tip - target, np.inf, 0
        a = a_lin if lo.tip <= 0 else min(a_lin, lo.alpha * target / lo.tip)
        solved, failures = [], self.failures
        for _ in range(max_solves):
            if self.failures - failures >= max_failures:
                break
            p = self._solve(a, lo)
            if p.u is not None:
                solved.append(p)
                if p.tip <= target * (1 + tol) and (p.tip >= target * (1 - tol)
                                                    or a >= a_lin * (1 - 1e-12)):
                    return p
            f = p.tip - target
            if f > 0:
                f_lo *= 0.5 if side == 1 else 1.0  # Illinois: the end kept twice weighs less
                hi, f_hi, side = p, f, 1
            else:
                f_hi *= 0.5 if side == -1 else 1.0
                lo, f_lo, side = p, f, -1
            if hi is None:
                a = min(a_lin, a * target / p.tip)
            elif not np.isfinite(f_hi):
                a = 0.5 * (lo.alpha + hi.alpha)
            else:
                a = (lo.alpha * f_hi - hi.alpha * f_lo) / (f_hi - f_lo)
        # not within the tolerance after max_solves (or past the FE's limit load): the solved
        # load closest to the target
        self.at_limit = self.failures - failures >= max_failures
        return min(solved, key=lambda p: abs(p.tip - target)) if solved else None


def _check_elastic(combinations, n_rigid: int) -> None:
    """InputError for a combination that loads a rigid-body mode (modes 1..n_rigid): its load
    K U is zero, so it gives no dual mode."""
    bad = [c for c in combinations if min(c) <= n_rigid]
    if bad:
        raise InputError(f"dual modes: combination {tuple(bad[0])} loads a rigid-body mode "
                         f"(modes 1..{n_rigid} of this free structure are rigid-body modes, "
                         f"whose load K U is zero); expected elastic modes "
                         f"{n_rigid + 1}.. (e.g. --combinations transverse)")


def dual_basis(backend, linear: Basis, n_dual: int, options: DualModeOptions | None = None,
               progress: Callable[[int, int], None] | None = None) -> Basis:
    """Linear modes + n_dual dual modes (DIGEST Sec. 6, Eqs. 47–48), solved by the backend."""
    opts = options or DualModeOptions()
    t0 = time.perf_counter()
    Phi_L = linear.Phi
    opts.validate(Phi_L.shape[1])
    KU = np.asarray(backend.stiffness_matrix() @ Phi_L)
    span = backend.reference_length
    responses, records = [], []
    total, done = len(opts.combinations) * opts.n_amplitudes, 0
    _check_elastic(opts.combinations, linear.n_rigid)
    for (j, l) in opts.combinations:
        U, F = _combination(Phi_L, KU, j, l)
        peak = _transverse_peak(backend, U)
        for sign, fractions in zip((1.0, -1.0), _tip_fractions(opts)):
            walk = _Walk(backend, F, sign, peak, opts)
            stopped = False
            for t in fractions:
                done += 1
                if progress is not None:
                    progress(done, total)
                rec = {"combination": [int(j), int(l)], "target_pct_span": float(100 * t)}
                if stopped:
                    # past a load the FE could not carry, the larger ones are skipped too
                    records.append({**rec, "status": "skipped"})
                    continue
                before = walk.solves
                p = walk.response(t) if opts.amplitude_control == "response" else walk.linear(t)
                if p is None:
                    stopped = True
                    records.append({**rec, "status": "failed", "solves": walk.solves - before,
                                    "message": f"no converged static solution ({walk.why})"})
                    continue
                walk.last = p
                stopped = walk.at_limit
                responses.append(p.u)
                records.append({**rec, "status": "ok", "alpha": float(sign * p.alpha),
                                "tip_linear_pct_span": float(100 * p.alpha * peak / span),
                                "tip_pct_span": float(100 * p.tip / span),
                                "solves": walk.solves - before,
                                **({"message": f"the larger loads skipped: {walk.why}"}
                                   if stopped else {})})
    if not responses:
        raise ConvergenceError("dual modes: the FE carried none of the dual-mode loads (no "
                               "static solve converged; under inertia relief a free structure "
                               "needs mass on each of its rigid-body motions): try "
                               "a smaller --amplitude or other --combinations, or identify "
                               "the linear modes only with --dual 0")
    basis, norms = dual_modes_from_responses(
        linear, backend.mass_matrix(), np.array(responses), n_dual,
        K=backend.stiffness_matrix(), pod_norm=opts.pod_norm, weights=opts.snapshot_weights)
    ok = [r for r in records if r["status"] == "ok"]
    for r, nrm in zip(ok, norms):
        r["relative_residual"] = float(nrm)
    basis.snapshots = records
    basis.n_rigid = linear.n_rigid
    basis.seconds = linear.seconds + time.perf_counter() - t0
    return basis
