"""Batched implicit Newmark / HHT-α / generalised-α integration with on-the-fly LCO detection.

Written here (torch only): B cases of a :class:`~torchrom.sim.system.CaseSystem` advance in
lockstep; per step and case the unknown is the new acceleration a_{n+1} (no float32 cancellation
in (q_{n+1} − q̂)/(β dt²)). The RFA lag states are affine in v_{n+1} under the scheme
(:mod:`.schemes`) and are condensed into the iteration matrix, so they never enter the nonlinear
iteration. With S = (1−αm) M_T + (1−αf)(γ dt C_eff + β dt² K_T) inverted once per case,
modified Newton iterates a ← S⁻¹ [b − (1−αf) f_nl(q̂ + β dt² a, v̂ + γ dt a)]; every
``refresh_every`` steps S is refreshed with the nonlinear tangents (Newton), which large LCOs
need. The error left after the last correction is estimated by Aitken's formula from the last
two corrections, and cases above ``tol`` are marked ``unconverged``. Options: per-case
error-controlled steps (``adaptive``, Zienkiewicz & Xie 1991 local error
(β − 1/6) dt² (a_{n+1} − a_n)), amplitude jumps toward a slowly approached LCO (``extrapolate``),
CUDA graphs per check interval. No host synchronisation per step, and no operation mixes cases:
a NaN or diverging case never changes its neighbours.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from ..checks import integer, real, real_array
from ..errors import InputError
from ..rom import NonlinearROM
from ..rom.points import resolve_output
from .forces import NonlinearForces
from .lco import DECAY, FAILED, LCO, RUNNING, STATUS_NAMES, LCOCriteria, PeakTracker
from .metrics import window_metrics
from .result import History, SimulationResult
from .schemes import SchemeParameters
from .system import CaseSystem

Tensor = torch.Tensor

SOLVERS = ("newton", "fixed_point")
#: per-case matrix-vector products below this many matrix entries use one bmm kernel
MV_SMALL = 16384
#: multiply-adds of one batched force evaluation below which 'auto' runs on one thread
AUTO_THREADS_WORK = 4_000_000
PREDICTORS = ("constant", "linear", "quadratic")
#: default tolerance on the last relative acceleration correction, by dtype
DEFAULT_TOL = {torch.float64: 1e-6, torch.float32: 1e-4}


@dataclass(frozen=True)
class HistoryRequest:
    """Keep the outputs of the cases ``cases`` (batch indices) every ``every`` steps."""

    cases: tuple[int, ...]
    every: int = 10


def output_matrix(rom: NonlinearROM, names: Sequence[str] | None = None
                  ) -> tuple[list[str], np.ndarray]:
    """(names, C) for outputs named after the ROM's outputs or generalized coordinates ``q1``…

    Default: every ROM output, then q1 … q4 (as far as the ROM has them).
    """
    if names is None:
        names = list(rom.outputs)
        names += [f"q{i + 1}" for i in range(min(rom.n, 4)) if f"q{i + 1}" not in names]
    rows = []
    for name in names:
        if name in rom.outputs:
            rows.append(rom.outputs[name])
        elif name.startswith("q") and name[1:].isdigit() and 1 <= int(name[1:]) <= rom.n:
            row = np.zeros(rom.n)
            row[int(name[1:]) - 1] = 1.0
            rows.append(row)
        else:
            rows.append(rom.outputs[resolve_output(rom, name)])
    if not rows:
        raise InputError("outputs: expected at least one output to track")
    return list(names), np.stack(rows)


def _mv(A: Tensor, x: Tensor) -> Tensor:
    """Per-case matrix-vector product (B, m, k) · (B, k) -> (B, m).

    Multiply-and-sum streams the B small matrices once (about twice as fast as a batched GEMM
    for 21 x 21 matrices on a CPU); for small batches one bmm kernel is cheaper to launch."""
    if A.shape[0] * A.shape[1] * A.shape[2] < MV_SMALL:
        return torch.bmm(A, x.unsqueeze(-1)).squeeze(-1)
    return torch.linalg.vecdot(A, x.unsqueeze(-2))


def _refreshed_inverse(S: Tensor, K: Tensor | None, D: Tensor | None, s: Tensor | None,
                       g: Tensor | None, bdt2: float, gdt: float, Z: Tensor) -> Tensor:
    """(S + J)⁻¹ per case, J = β dt² s K + γ dt g D the Jacobian of the (scaled) nonlinear force
    at the predicted state without ∂(D q̇)/∂q (O(β dt |q̇|/|q|) smaller: the slow LCO motion);
    all (n, n, B) in the layout of :func:`_cmv`. A case whose matrix cannot be inverted keeps
    its previous iteration matrix Z (the batch never mixes cases: one LAPACK solve each)."""
    SJ = S
    if K is not None:
        SJ = SJ + K * (bdt2 * s)
    if D is not None:
        SJ = SJ + D * (gdt * g)
    Zb, info = torch.linalg.inv_ex(SJ.permute(2, 1, 0))
    Znew = Zb.permute(2, 1, 0)
    ok = (info == 0) & torch.isfinite(Znew).all(0).all(0)
    return torch.where(ok, Znew, Z).contiguous()


def _inverse(A: Tensor) -> tuple[Tensor, Tensor]:
    """Per-case inverse and a (B,) flag of the cases where it exists and is finite."""
    Ainv, info = torch.linalg.inv_ex(A)
    ok = (info == 0) & torch.isfinite(Ainv).flatten(1).all(1)
    return torch.where(ok.view(-1, 1, 1), Ainv, torch.nan), ok


#: Largest number of time steps of one case (t_end / dt): 1e8 steps take minutes to hours even
#: batched; a larger count is a unit slip in dt or t_end (e.g. dt = 1e-12 s), refused up front.
MAX_STEPS = 100_000_000


@dataclass
class Newmark:
    """Batched implicit integrator (see the module docstring).

    Attributes:
        dt: time step (s); the paper uses 1e-3.
        scheme: 'newmark' (average acceleration, default), 'hht' or 'generalized_alpha'.
        rho_inf: spectral radius at infinity for 'hht' / 'generalized_alpha'.
        solver: 'newton' (modified Newton, iteration matrix inverted once per case) or
            'fixed_point' (the paper's iteration on the mass matrix).
        iterations: nonlinear iterations per step (fixed: no host branching).
        startup_iterations: iterations during the first check interval (None: iterations + 2).
            An initial state is rarely on the slow manifold of the stiff modes, whose fast
            transient the extrapolated predictor cannot follow; a few more iterations there
            keep the tolerance without paying for them in the rest of the run.
        tol: tolerance on the estimated error left in the acceleration after the last
            iteration, relative to the largest |a| of the check interval (None: 1e-6 in float64,
            1e-4 in float32 — above rounding; a relative force error ε shifts an LCO amplitude
            by about ε ω/|c|, c the net linear damping); cases above it are 'unconverged'.
        predictor: 'constant' (a_n), 'linear' (2a_n − a_{n−1}) or 'quadratic' extrapolation.
        check_every: steps between host checks (LCO decisions, compaction, progress).
        refresh_every: with ``solver="newton"`` and nonlinear forces, refresh the iteration
            matrix with the tangent of the nonlinear forces at the predicted state every this
            many steps (1: Newton; 0: never, the modified Newton of the linear matrix S).
        sample_every: with ``iterations=1``, every sample_every-th step iterates twice and
            records the ratio of its two corrections (the contraction ratio r of the
            iteration); the error left by the single iteration of the other steps is estimated
            as their correction times r/(1−r) (0: never sample; r = ½ is then assumed, i.e.
            the error is bounded by the correction itself).
        compile: compile the step with torch.compile (needs a C compiler on CPU; opt-in).
        cuda_graphs: on a CUDA device, capture the steps of a check interval in a CUDA graph
            and replay it (True / False / 'auto' = on CUDA devices); True on a CPU runs the
            captured code (the steps writing into static state tensors) eagerly, which is how
            that path is tested without a GPU.
        threads: torch intra-op threads during the run on CPU: an int, 'keep' (leave torch's
            setting) or 'auto' (default: one thread when a nonlinear force evaluation is below
            ~4M multiply-adds — the per-step kernels are then too small to share, and waiting on
            a second thread costs more than it saves, badly so on a busy machine — else keep).
        adaptive: error-controlled per-case steps (see the module docstring): ``dt`` is the
            first step, each case then takes its own step within [dt_min, dt_max].
        step_tol: with ``adaptive``, the local error per step of the tracked outputs, relative
            to their largest magnitude, that the step aims at (default 1e-5).
        dt_min, dt_max: bounds of the adaptive step (default dt/16 and 16 dt).
        extrapolate: amplitude jumps per case (0: none; see the module docstring): a case
            whose amplitude approaches its limit geometrically is moved to the extrapolated
            limit, at most this many times.
    """

    dt: float = 1e-3
    scheme: str = "newmark"
    rho_inf: float = 1.0
    solver: str = "newton"
    iterations: int = 2
    startup_iterations: int | None = None
    tol: float | None = None
    predictor: str = "linear"
    check_every: int = 500
    refresh_every: int = 16
    sample_every: int = 16
    compile: bool = False
    threads: int | str = "auto"
    cuda_graphs: bool | str = "auto"
    adaptive: bool = False
    step_tol: float = 1e-5
    dt_min: float | None = None
    dt_max: float | None = None
    extrapolate: int = 0
    params: SchemeParameters = field(init=False, repr=False)

    def __post_init__(self):
        self.dt = real("integrator.dt", self.dt, positive=True)
        self.rho_inf = real("integrator.rho_inf", self.rho_inf)
        for name in ("iterations", "check_every"):
            integer(f"integrator.{name}", getattr(self, name))
        if self.startup_iterations is not None:
            integer("integrator.startup_iterations", self.startup_iterations)
        if self.tol is not None:
            self.tol = real("integrator.tol", self.tol, positive=True)
        if not isinstance(self.compile, bool):
            raise InputError(f"integrator.compile: expected true or false, got {self.compile!r}")
        if self.solver not in SOLVERS:
            raise InputError(f"integrator.solver: expected one of {SOLVERS}, got {self.solver!r}")
        if self.predictor not in PREDICTORS:
            raise InputError(f"integrator.predictor: expected one of {PREDICTORS}, got "
                             f"{self.predictor!r}")
        if int(self.iterations) < 1:
            raise InputError(f"integrator.iterations: expected >= 1, got {self.iterations}")
        if self.startup_iterations is not None and int(self.startup_iterations) < 1:
            raise InputError(f"integrator.startup_iterations: expected >= 1, got "
                             f"{self.startup_iterations}")
        if int(self.check_every) < 2:
            raise InputError(f"integrator.check_every: expected >= 2, got {self.check_every}")
        for name in ("refresh_every", "sample_every"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (isinstance(value, int) and value >= 0):
                raise InputError(f"integrator.{name}: expected an integer >= 0, got {value!r}")
        if self.cuda_graphs not in (True, False, "auto"):
            raise InputError(f"integrator.cuda_graphs: expected true, false or 'auto', got "
                             f"{self.cuda_graphs!r}")
        if not (self.threads in ("auto", "keep") or (isinstance(self.threads, int)
                                                     and self.threads >= 1)):
            raise InputError(f"integrator.threads: expected 'auto', 'keep' or an integer >= 1, "
                             f"got {self.threads!r}")
        if self.tol is not None and not self.tol > 0:
            raise InputError(f"integrator.tol: expected a positive number, got {self.tol}")
        if isinstance(self.extrapolate, bool) or not (isinstance(self.extrapolate, int)
                                                      and self.extrapolate >= 0):
            raise InputError(f"integrator.extrapolate: expected an integer >= 0, got "
                             f"{self.extrapolate!r}")
        if not isinstance(self.adaptive, bool):
            raise InputError(f"integrator.adaptive: expected true or false, got "
                             f"{self.adaptive!r}")
        if not (self.step_tol > 0 and math.isfinite(self.step_tol)):
            raise InputError(f"integrator.step_tol: expected a positive number, got "
                             f"{self.step_tol}")
        lo, hi = self.step_bounds
        if not (0 < lo <= self.dt <= hi and math.isfinite(hi)):
            raise InputError(f"integrator.dt_min, dt_max: expected 0 < dt_min <= dt = {self.dt}"
                             f" <= dt_max, got {lo}, {hi}")
        self.params = SchemeParameters.from_name(self.scheme, self.rho_inf)

    def step_count(self, t_end) -> int:
        """Number of time steps to ``t_end`` (InputError unless 1 ≤ steps ≤ MAX_STEPS)."""
        t_end = real("t_end", t_end, positive=True)
        steps = int(round(t_end / self.dt))
        if steps < 1:
            raise InputError(f"t_end: expected at least one time step of dt = {self.dt:g} s, got "
                             f"t_end = {t_end:g} s (dt <= t_end)")
        if steps > MAX_STEPS:
            raise InputError(f"integrator.dt: t_end / dt = {t_end:g} / {self.dt:g} = {steps:.3g} "
                             f"steps per case, more than the {MAX_STEPS:.0e} accepted; expected "
                             f"dt >= {t_end / MAX_STEPS:.3g} s")
        return steps

    @property
    def step_bounds(self) -> tuple[float, float]:
        """(dt_min, dt_max) of the adaptive step (default dt/16 and 16 dt)."""
        lo = self.dt / 16 if self.dt_min is None else float(self.dt_min)
        hi = self.dt * 16 if self.dt_max is None else float(self.dt_max)
        return lo, hi

    def tolerance(self, dtype: torch.dtype) -> float:
        return self.tol if self.tol is not None else DEFAULT_TOL.get(dtype, 1e-6)

    # ------------------------------------------------------------------------------------------
    # per-case matrices
    # ------------------------------------------------------------------------------------------
    def case_matrices(self, system: CaseSystem, dt: Tensor | None = None
                      ) -> tuple[dict[str, Tensor], Tensor]:
        """The per-case constant matrices of the step and a (B,) flag of the cases where they
        exist (float64 on the system's device; cast by the caller); ``dt``: (B,) per-case
        steps (default the scalar ``self.dt``)."""
        dev = system.device
        f64 = {"device": dev, "dtype": torch.float64}
        p = self.params
        dt = self.dt if dt is None else dt.to(**f64).view(-1, 1, 1)
        rom = system.rom
        B, n, na = system.batch_size, system.n, system.n_lag
        sysd = system.to(dtype=torch.float64)
        M = rom.M.to(**f64)
        MT = M.expand(B, n, n) + (sysd.M_add if sysd.M_add is not None else 0.0)
        CT = (sysd.alpha.view(B, 1, 1) * M + sysd.gamma.view(B, 1, 1) * rom.D1.to(**f64))
        if sysd.C_add is not None:
            CT = CT + sysd.C_add
        KT = rom.K1.to(**f64).expand(B, n, n) + (sysd.K_add if sysd.K_add is not None else 0.0)
        ok = torch.ones(B, dtype=torch.bool, device=dev)
        mats: dict[str, Tensor] = {}
        Ceff = CT
        if na:
            eye = torch.eye(na, **f64)
            P = (1 - p.alpha_m) * eye - (1 - p.alpha_f) * p.gamma * dt * sysd.lag_R
            Pinv, okP = _inverse(P)
            ok &= okP
            W = (1 - p.alpha_f) * Pinv @ sysd.lag_E
            Ceff = CT + p.gamma * dt * sysd.lag_D @ W
            if p.is_newmark:
                Q = Pinv @ sysd.lag_R
            else:
                Q = torch.cat([(1 - p.alpha_f) * Pinv @ sysd.lag_R, p.alpha_f * Pinv @ sysd.lag_R,
                               -p.alpha_m * Pinv, p.alpha_f * Pinv @ sysd.lag_E], dim=2)
            mats["Q"], mats["W"] = Q, W
        lin = (1 - p.alpha_f) * (p.gamma * dt * Ceff + p.beta * dt * dt * KT)
        S = (1 - p.alpha_m) * MT + lin
        Z, okZ = _inverse(S if self.solver == "newton" else (1 - p.alpha_m) * MT)
        ok &= okZ
        blocks = [Ceff, KT] + ([sysd.lag_D] if na else [])
        # right-hand side b = L x of the acceleration equation S a = b − (1−αf) f_nl, x the
        # predicted state [v̂, q̂, lag term (, a_n, f_int,n)]
        L = -(1 - p.alpha_f) * torch.cat(blocks, dim=2)
        if not p.is_newmark:
            eye = torch.eye(n, **f64).expand(B, n, n)
            L = torch.cat([L, -p.alpha_m * MT, -p.alpha_f * eye], dim=2)
            mats["MT"] = MT
        mats["L"], mats["S"], mats["Z"] = L, S, Z
        mats["ZL"] = Z @ L
        mats["Zf"] = (1 - p.alpha_f) * Z
        if self.solver == "fixed_point":
            mats["ZR"] = Z @ lin
        if sysd.load is not None:
            mats["uF"] = _mv(Z, sysd.load)
            mats["F"] = sysd.load
        Minv, okM = _inverse(MT)
        ok &= okM
        mats["Minv"], mats["CT"], mats["KT"] = Minv, CT, KT
        return mats, ok

    # ------------------------------------------------------------------------------------------
    def contraction_ratio(self, system: CaseSystem, q: Tensor, v: Tensor) -> Tensor:
        """Spectral radius (B,) of the iteration map at states (q, v): the factor by which each
        nonlinear iteration reduces the error near the solution (must be < 1)."""
        p, dt = self.params, self.dt
        mats, _ = self.case_matrices(system)
        sysd = system.to(dtype=torch.float64)
        rom = system.rom
        Kt, Ct = rom.tangents(q.double().cpu(), v.double().cpu(), 0.0, sysd.gamma.cpu(),
                              sysd.stiffness_nl.cpu(), sysd.damping_nl.cpu())
        Knl = (Kt - rom.K1).to(q.device)
        Cnl = (Ct - sysd.gamma.cpu().view(-1, 1, 1) * rom.D1).to(q.device)
        J = mats["Zf"] @ (p.beta * dt * dt * Knl + p.gamma * dt * Cnl)
        if self.solver == "fixed_point":
            J = J + mats["ZR"]
        return torch.linalg.eigvals(J).abs().amax(-1)

    # ------------------------------------------------------------------------------------------
    def run(self, system: CaseSystem, q0, v0=None, xi0=None, *, t_end: float,
            outputs: Sequence[str] | tuple[list[str], np.ndarray] | None = None,
            lco: LCOCriteria | None = None, history: HistoryRequest | None = None,
            progress: Callable[[int, int], None] | None = None) -> SimulationResult:
        """Integrate every case from (q0, v0, ξ0) until it is decided or ``t_end`` is reached.

        Args:
            system: B cases (device and dtype of the run are the system's).
            q0, v0: (B, n) or (n,) initial displacement and velocity (v0 default 0).
            xi0: (B, na) initial lag states (default 0).
            t_end: largest simulated time (s).
            outputs: output names (see :func:`output_matrix`) or (names, C (O, n)).
            lco: stop criteria (default :class:`LCOCriteria`).
            history: cases whose decimated output histories are kept.
            progress: called as progress(cases_done, cases_total) at every check.
        """
        if not isinstance(system, CaseSystem):
            raise InputError(f"system: expected a CaseSystem, got {type(system).__name__}")
        threads = self._threads(system)
        before = torch.get_num_threads()
        try:
            if threads != before:
                torch.set_num_threads(threads)
            with torch.no_grad():
                return _Run(self, system, q0, v0, xi0, t_end, outputs, lco or LCOCriteria(),
                            history, progress).execute()
        finally:
            if torch.get_num_threads() != before:
                torch.set_num_threads(before)

    def _threads(self, system: CaseSystem) -> int:
        current = torch.get_num_threads()
        if system.device.type != "cpu" or self.threads == "keep":
            return current
        if isinstance(self.threads, int):
            return self.threads
        n = system.n
        pairs = n * (n + 1) // 2
        work = system.batch_size * n * (pairs + pairs * (n + 2) // 3 + n + pairs)
        return 1 if work < AUTO_THREADS_WORK else current


def _fm(t: Tensor) -> Tensor:
    """Batch-major per-case tensor -> feature-major: (B,) -> (1, B), (B, m) -> (m, B),
    (B, m, k) -> (k, m, B) (the layout of :func:`_cmv`)."""
    view = t.unsqueeze(0) if t.dim() == 1 else (t.T if t.dim() == 2 else t.permute(2, 1, 0))
    return view.clone(memory_format=torch.contiguous_format)  # never aliases another tensor


def _axpy(x: Tensor, y: Tensor, c: float | Tensor) -> Tensor:
    """x + c y for a scalar c (one kernel, bit-identical to torch.add) or per-case (1, B) c."""
    if isinstance(c, Tensor):
        return torch.addcmul(x, y, c)
    return torch.add(x, y, alpha=c)


def _cmv(A: Tensor, x: Tensor) -> Tensor:
    """Per-case matrix-vector product, feature-major: A (k, m, B), x (k, B) -> (m, B).

    Σ_k A[k] ⊙ x[k] over the leading dimension streams the B small matrices once with unit
    stride (faster than a batched GEMM of B 21 x 21 products on a CPU); one case is one GEMV,
    on A given as that case's (m, k) matrix (:func:`_single`) or taken from A (k, m, 1)."""
    if A.dim() == 2:
        return torch.mm(A, x)
    if x.shape[1] == 1:
        return A.squeeze(2).T @ x
    return (A * x.unsqueeze(1)).sum(0)


def _single(A: Tensor) -> Tensor:
    """The (m, k) matrix of a single case's (k, m, 1) per-case matrix (a view): what
    :func:`_cmv` multiplies without two views per product."""
    return A[:, :, 0].T


#: per-case matrices the step only multiplies vectors by; with a single case left in the batch
#: (the tail of every chunk) it receives them as plain matrices (see _Run._step_mats)
_MV_ONLY = ("LS", "ZL", "Q", "W", "MT")


class _Run:
    """One batched integration: state, per-case matrices, compaction and result assembly.

    The state and the per-case matrices are feature-major (rows = coordinates, columns =
    cases): the force kernel's layout, so no step transposes anything."""

    def __init__(self, integ: Newmark, system: CaseSystem, q0, v0, xi0, t_end, outputs, crit,
                 history, progress):
        steps_total = integ.step_count(t_end)
        if not isinstance(system, CaseSystem):
            raise InputError(f"system: expected a CaseSystem, got {type(system).__name__}")
        system.validate()
        self.integ, self.crit, self.progress = integ, crit, progress
        self.rom = system.rom
        dev, dtype = system.device, system.dtype
        self.kw = {"device": dev, "dtype": dtype}
        B, n, na = system.batch_size, system.n, system.n_lag
        self.B, self.n, self.na = B, n, na
        if isinstance(outputs, tuple):
            names, C = outputs
        else:
            names, C = output_matrix(self.rom, outputs)
        C = np.asarray(C, dtype=float).reshape(len(names), n)
        self.names = list(names)
        if max(crit.decision_outputs) >= len(self.names) or min(crit.decision_outputs) < 0:
            raise InputError(f"lco.decision_outputs: indices must be in 0..{len(self.names) - 1}")
        self.C = torch.as_tensor(C, **self.kw)
        self.steps_total = steps_total
        self.t_end = float(t_end)
        self.history = history
        p = integ.params
        self.p = p

        def per_case(x, width, name):
            if x is None:
                return torch.zeros(B, width, **self.kw)
            t = x if isinstance(x, torch.Tensor) else torch.as_tensor(real_array(name, x))
            t = t.to(**self.kw)
            if tuple(t.shape) == (width,):
                t = t.expand(B, width)
            if tuple(t.shape) != (B, width):
                raise InputError(f"{name}: expected shape ({B}, {width}) or ({width},), got "
                                 f"{tuple(t.shape)}")
            return t.clone()

        q = per_case(q0, n, "q0")
        v = per_case(v0, n, "v0")
        xi = per_case(xi0, na, "xi0")

        # which nonlinear terms the batch needs at all (host decision, once per run)
        s_on = bool((system.stiffness_nl != 0).any())
        g = system.gamma * system.damping_nl
        d_on = bool((g != 0).any())
        self.forces = NonlinearForces(self.rom, dev, dtype, stiffness=s_on, damping=d_on)
        self.nonlinear = self.forces.active

        self.adaptive = bool(integ.adaptive)
        self.system = system
        self.dtc = torch.full((B,), float(integ.dt), device=dev, dtype=torch.float64)
        mats64, ok = integ.case_matrices(system, self.dtc if self.adaptive else None)
        ok &= torch.isfinite(q).all(1) & torch.isfinite(v).all(1) & torch.isfinite(xi).all(1)
        mats = {k: t.to(dtype) for k, t in mats64.items()}
        s = system.stiffness_nl if self.forces.has_stiffness else None
        g = g if self.forces.has_damping else None
        # initial acceleration from the equations of motion at t = 0
        rhs = -_mv(mats["CT"], v) - _mv(mats["KT"], q)
        if self.nonlinear:
            rhs = rhs - self.forces(q, v, None if s is None else s.unsqueeze(0),
                                    None if g is None else g.unsqueeze(0))
        if na:
            rhs = rhs - _mv(system.lag_D, xi)
        if system.load is not None:
            rhs = rhs + system.load
        a = _mv(mats["Minv"], rhs)
        state = {"q": q, "v": v, "a": a, "a1": a, "a2": a}
        if na:
            state["xi"] = xi
            state["xid"] = _mv(system.lag_E, v) + _mv(system.lag_R, xi)
        if not p.is_newmark:
            F = system.load if system.load is not None else torch.zeros_like(q)
            state["fint"] = F - _mv(mats64["MT"].to(dtype), a)
        # the iterative path works on b − S a (correction form, any iteration matrix Z); the
        # linear Newton path needs only the premultiplied Z L
        self.iterative = self.nonlinear or integ.solver == "fixed_point"
        if self.iterative:
            state["Z"] = mats["Z"]
        mats = self._kept(mats)
        # (1−αf) f_nl enters the equation: scale the per-case nonlinearity scales once
        mats["s"] = None if s is None else (1.0 - p.alpha_f) * s
        mats["g"] = None if g is None else (1.0 - p.alpha_f) * g
        self.mats = {k: _fm(t) for k, t in mats.items() if t is not None}
        if self.nonlinear and self.forces.small is not None:
            self.mats["z_scale"], self.mats["sg"] = self.forces.small_scales(
                self.mats.get("s"), self.mats.get("g"))
        if self.adaptive:
            self.mats.update(self._dt_coefficients(self.dtc))
        self.state = {k: _fm(t) for k, t in state.items()}
        # per-case simulated time and steps (the adaptive step moves cases apart in time)
        self.t = torch.zeros(B, device=dev, dtype=torch.float64)
        self.jumps = torch.zeros(B, device=dev, dtype=torch.long)
        power = torch.ones(n, 1, **self.kw)
        power[[i for i, k in enumerate(self.rom.mode_kinds) if k == "dual"]] = 2.0
        self.jump_power = power
        self.case_step_count = np.zeros(B, dtype=np.int64)
        self._reset_error()
        self.solver_rel = torch.zeros(B, device=dev, dtype=torch.float64)
        y0, yd0 = q @ self.C.T, v @ self.C.T
        self.tracker = PeakTracker(y0, yd0, crit.ring)
        self.active = np.arange(B)
        self.step_no = 0
        # results (host)
        O = len(self.names)
        self.res = {
            "status": np.full(B, "", dtype=object), "steps": np.zeros(B, dtype=np.int64),
            "time": np.zeros(B), "amplitude": np.full((B, O), np.nan),
            "frequency_hz": np.full(B, np.nan), "amplitude_change": np.full(B, np.nan),
            "last_amplitude": np.full((B, O), np.nan), "last_frequency_hz": np.full(B, np.nan),
            "solver_error": np.full(B, np.nan), "q": np.full((B, n), np.nan),
            "v": np.full((B, n), np.nan), "xi": np.full((B, na), np.nan),
            "centre": np.full((B, O), np.nan),
        }
        self.hist: dict[int, list] = {}
        if history is not None:
            for c in history.cases:
                if not 0 <= int(c) < B:
                    raise InputError(f"history.cases: {c} is not a case index in 0..{B - 1}")
                self.hist[int(c)] = [(0.0, y0[int(c)].double().cpu().numpy())]
        self.iterations = int(integ.iterations)
        startup = integ.startup_iterations
        self.startup_iterations = self.iterations + 2 if startup is None else int(startup)
        # with one iteration per step, the step before every sample_every-th step iterates
        # twice to measure the contraction ratio that turns the single correction into an
        # error estimate (just before a refresh of the iteration matrix: its largest value)
        self.sampling = self.iterations == 1 and integ.sample_every > 0 and self.iterative
        self.refreshing = (integ.refresh_every > 0 and self.nonlinear
                           and integ.solver == "newton")
        self._step_cache: dict[tuple, Callable] = {}
        self.graphs = integ.cuda_graphs is True or (integ.cuda_graphs == "auto"
                                                    and dev.type == "cuda")
        self._graph = None
        self._inference = not (self.graphs and dev.type == "cuda")
        bad = ~ok
        if bool(bad.any()):
            self._finish(np.nonzero(bad.cpu().numpy())[0], np.full(int(bad.sum()), FAILED))

    def _kept(self, mats: dict[str, Tensor]) -> dict[str, Tensor]:
        """The per-case matrices the step reads (batch-major, from :meth:`Newmark.case_matrices`).

        The iterative path works on b − S a (correction form, any iteration matrix Z); the
        linear Newton path needs only the premultiplied Z L."""
        if self.iterative:
            mats["LS"] = torch.cat([mats["L"], -mats["S"]], dim=2)
            keep = ["LS", "S"]
        else:
            keep = ["ZL", "uF"]
        keep += ["F", "Q", "W"] + ([] if self.p.is_newmark else ["MT"])
        return {k: mats[k] for k in keep if k in mats}

    def _dt_coefficients(self, dt: Tensor) -> dict[str, Tensor]:
        """The step's dt-dependent coefficients per case, (1, B) in the run's dtype, and the
        constant |β − 1/6| dt² of the local error estimate (see :meth:`_adapt_steps`)."""
        p = self.p
        coef = {"dt": dt, "c_qa": dt * dt * (0.5 - p.beta), "c_va": dt * (1.0 - p.gamma),
                "bdt2": p.beta * dt * dt, "gdt": p.gamma * dt,
                "e_dt2": abs(p.beta - 1.0 / 6.0) * dt * dt}
        coef = {k: v.to(self.kw["dtype"]).unsqueeze(0).contiguous() for k, v in coef.items()}
        coef["c_vq"] = torch.stack([coef["gdt"], coef["bdt2"]])  # (2, 1, B), see _make_step
        return coef

    def _adapt_steps(self, shrink: Tensor) -> None:
        """New per-case steps from the interval's local error estimate (adaptive runs).

        Per step the displacement error of the Newmark family is estimated as
        e = (β − 1/6) dt² (a_{n+1} − a_n) (Zienkiewicz & Xie 1991: the difference between the
        corrector and a third-order Taylor predictor); the step reads it on the tracked outputs,
        y = C e, relative to the interval's largest |y|. The new step is
        dt · clip(0.9 (step_tol/err)^(1/3), ½, 2) within [dt_min, dt_max]; steps changing by less
        than 20 % are kept (each change rebuilds the per-case matrices). ``shrink``: (B,) cases
        whose nonlinear iteration missed its tolerance; their step is at least halved."""
        integ = self.integ
        lo, hi = integ.step_bounds
        f64 = torch.float64
        err = self.state["lerr"].to(f64)
        ymax = self.state["ymax"].to(f64).clamp_min(torch.finfo(f64).tiny)
        rel = (err / ymax).clamp_min(1e-300)
        factor = (0.9 * (integ.step_tol / rel) ** (1.0 / 3.0)).clamp(0.5, 2.0)
        factor = torch.where(shrink, factor.clamp(max=0.5), factor)
        new = (self.dtc * factor).clamp(lo, hi)
        change = ((new / self.dtc - 1.0).abs() > 0.2) | (shrink & (new < self.dtc))
        if not bool(change.any()):
            return
        self.dtc = torch.where(change, new, self.dtc)
        mats64, ok = integ.case_matrices(self.system, self.dtc)
        mats = self._kept({k: t.to(self.kw["dtype"]) for k, t in mats64.items()})
        for k, t in mats.items():
            self.mats[k] = _fm(t)
        self.mats.update(self._dt_coefficients(self.dtc))
        if self.iterative:
            self.state["Z"] = _fm(mats64["Z"].to(self.kw["dtype"]))
        self._graph = None

    def _jump(self, status: Tensor) -> None:
        """Amplitude jumps of the running cases that approach their limit geometrically (see
        the module docstring; in place, so a captured CUDA graph keeps its addresses)."""
        crit, tr = self.crit, self.tracker
        out = crit.decision_outputs[0]
        A, valid = tr.amplitudes([out], 4)
        A, valid = A[:, 0], valid[:, 0, 3]
        d = A[:, :-1] - A[:, 1:]  # newer minus older
        tiny = torch.finfo(torch.float64).tiny
        r0 = d[:, 0] / torch.where(d[:, 1] != 0, d[:, 1], tiny)
        r1 = d[:, 1] / torch.where(d[:, 2] != 0, d[:, 2], tiny)
        one_sign = (d[:, 0] * d[:, 1] > 0) & (d[:, 1] * d[:, 2] > 0)
        steady = (r0 > 0.2) & (r0 < 0.98) & ((r0 - r1).abs() <= 0.15 * r0)
        A0 = A[:, 0]
        remaining = d[:, 0] * r0 / (1.0 - r0)
        jump = (valid & one_sign & steady & (A0 > 0) & (status == RUNNING)
                & (remaining.abs() > 10 * crit.rtol * A0) & (self.jumps < self.integ.extrapolate))
        if not bool(jump.any()):
            return
        lam = torch.where(jump, ((A0 + remaining) / A0.clamp_min(tiny)).clamp(0.5, 2.0), 1.0)
        lam = lam.to(self.kw["dtype"]).unsqueeze(0)
        factor = lam ** self.jump_power  # (n, B): λ linear, λ² dual
        st = self.state
        for k in ("q", "v", "a", "a1", "a2", "fint"):
            if k in st:
                st[k].mul_(factor)
        for k in ("xi", "xid"):
            if k in st:
                st[k].mul_(lam)
        self.jumps += jump.long()
        tr.count[jump] = 0
        tr.amp_max = torch.where(jump, A0 * lam[0].double(), tr.amp_max)
        y, yd = (self.C @ st["q"]).T.double(), (self.C @ st["v"]).T.double()
        tr.last_y = torch.where(jump.unsqueeze(1), y, tr.last_y)
        tr.last_yd = torch.where(jump.unsqueeze(1), yd, tr.last_yd)

    def _reset_error(self):
        """Zero the per-interval solver accumulators (in place: a captured graph reads them)."""
        B = self.state["q"].shape[1]
        for k in ("err", "amax", "c1", "rho") + (("lerr", "ymax") if self.adaptive else ()):
            if k in self.state:
                self.state[k].zero_()
            else:
                self.state[k] = torch.zeros(B, **self.kw)

    # ------------------------------------------------------------------------------------------
    def _make_step(self, iters: int, refresh: bool = False, rho: bool = False):
        """The step as a pure function of (state, mats) with every branch decided here.

        ``iters``: nonlinear iterations; ``refresh``: evaluate the Jacobian at the predicted
        state and make (S + J)⁻¹ the iteration matrix from this step on; ``rho``: also record
        the ratio of the last two corrections (the measured contraction ratio, used by the
        error estimate of single-iteration steps).

        Returns (new state, outputs C q and C q̇ (O, B), diagnostics (k, B)): the largest
        |correction| of the last two iterations (one with one iteration, none on the linear
        path) and the largest |a|, folded into the interval's error estimate once per check
        interval (:meth:`_fold_diagnostics`), not once per step."""
        integ, p, dt = self.integ, self.p, self.integ.dt
        c_qa, c_va = dt * dt * (0.5 - p.beta), dt * (1.0 - p.gamma)
        bdt2, gdt = p.beta * dt * dt, p.gamma * dt
        # [q̇; q] advance together, x + c a with c = (γ dt, β dt²): one kernel for both
        c_vq = torch.tensor([gdt, bdt2], **self.kw).view(2, 1, 1)
        adaptive = self.adaptive
        am, af = p.alpha_m, p.alpha_f
        lag, newmark, nonlinear = self.na > 0, p.is_newmark, self.nonlinear
        predictor, forces, C = integ.predictor, self.forces, self.C
        small = nonlinear and forces.small is not None
        has_load = "F" in self.mats
        iterative = self.iterative
        n, n2 = self.n, 2 * self.n
        tiny = torch.finfo(self.kw["dtype"]).tiny

        def step(st: dict, m: dict):
            # written for a small number of kernels per step: eager CPU time is op overhead
            # for small batches
            q, v, a = st["q"], st["v"], st["a"]
            one = q.shape[1] == 1
            if adaptive:
                # per-case steps: the coefficients are (1, B) rows of the per-case matrices
                h, h_qa, h_va, h_b, h_g = (m[k] for k in ("dt", "c_qa", "c_va", "bdt2", "gdt"))
                cz = m["c_vq"]
            else:
                h, h_qa, h_va, h_b, h_g, cz = dt, c_qa, c_va, bdt2, gdt, c_vq
            qh = _axpy(_axpy(q, v, h), a, h_qa)
            vh = _axpy(v, a, h_va)
            parts = [vh, qh]
            if lag:
                xih = _axpy(st["xi"], st["xid"], h_va)
                lag_in = xih if newmark else torch.cat([xih, st["xi"], st["xid"], v])
                xid_star = _cmv(m["Q"], lag_in)
                parts.append(_axpy(xih, xid_star, h_g))
            if not newmark:
                parts += [a, st["fint"]]
            new = dict(st)
            corrs = []
            if not iterative:
                # linear, modified Newton: S is the exact Jacobian, one solve is exact
                x = torch.cat(parts)
                zh = x[:n2].view(2, n, -1)  # the predicted [q̇; q]
                ak = _cmv(m["ZL"], x)
                if has_load:
                    ak = ak.add_(m["uF"])
            else:
                if predictor == "constant":
                    ak = a
                elif predictor == "linear":
                    ak = torch.lerp(st["a1"], a, 2.0)  # 2 a_n − a_{n−1}
                else:
                    ak = torch.sub(a, st["a1"]).mul_(3.0).add_(st["a2"])
                # residual of the linear part at the predictor: b − S a_p in one product
                x = torch.cat(parts + [ak])
                res_lin = _cmv(m["LS"], x)
                if has_load:
                    res_lin = res_lin.add_(m["F"])
                a_p, Z = ak, st["Z"]
                Zmv = _single(Z) if one else Z
                s, g = m.get("s"), m.get("g")
                zh = x[:n2].view(2, n, -1)  # the predicted [q̇; q]
                for it in range(iters):
                    r = res_lin if it == 0 else res_lin - _cmv(m["S_mv"], ak - a_p)
                    if nonlinear:
                        zk = torch.addcmul(zh, ak, cz)
                        if refresh and it == 0:
                            f, K, D = forces.evaluate_T(zk[1], zk[0], s, g, jacobian=True)
                            Z = _refreshed_inverse(m["S"], K, D, s, g, h_b, h_g, Z)
                            new["Z"] = Z
                            Zmv = _single(Z) if one else Z
                        elif small:
                            f = forces.evaluate_small(zk.view(n2, -1), m["z_scale"], m["sg"])
                        else:
                            f = forces.evaluate_T(zk[1], zk[0], s, g)
                        r = r - f
                    corr = _cmv(Zmv, r)
                    ak = ak + corr
                    corrs = corrs[-1:] + [corr]
            # rows: the last two corrections' and a_{n+1}'s largest magnitudes (abs().amax():
            # vector_norm(ord=inf) is several times slower on CPU)
            diag = torch.stack(corrs + [ak]).abs_().amax(1)
            if rho:
                # the contraction ratio of the last two corrections (Newmark.sample_every)
                new["rho"] = torch.maximum(st["rho"], diag[1] / diag[0].clamp_min(tiny))
            z1 = torch.addcmul(zh, ak, cz)  # [q̇; q] at t_{n+1}
            v1, q1 = z1[0], z1[1]
            new.update(q=q1, v=v1, a=ak, a1=a, a2=st["a1"])
            if lag:
                xid1 = xid_star + _cmv(m["W"], v1)
                new["xid"] = xid1
                new["xi"] = _axpy(xih, xid1, h_g)
            if not newmark:
                # internal force at t_{n+1} recovered from the equation of motion (exact at
                # convergence; an error in it is multiplied by αf/(1−αf) ≤ ½ per step)
                fint = _cmv(m["MT"], torch.add(ak, a, alpha=am / (1.0 - am))).mul_(am - 1.0)
                fint = fint.sub_(st["fint"], alpha=af)
                if has_load:
                    fint = fint.add_(m["F"])
                new["fint"] = fint.div_(1.0 - af)
            y = torch.mm(C, q1)
            if adaptive:
                # local error estimate on the outputs (see _Run._adapt_steps)
                e = (C @ (ak - a)).abs().amax(0) * m["e_dt2"][0]
                new["lerr"] = torch.maximum(st["lerr"], e)
                new["ymax"] = torch.maximum(st["ymax"], y.abs().amax(0))
            return new, y, torch.mm(C, v1), diag

        return step

    def _fold_diagnostics(self, st: dict, diags: list[Tensor]) -> dict:
        """The state with the interval accumulators updated from the steps' diagnostics (see
        :meth:`_make_step`): the largest |a|; for steps of two or more iterations the error
        left after the last correction, Aitken |Δa_K|²/(|Δa_{K−1}|−|Δa_K|) = |Δa_K| r/(1−r), r
        the contraction ratio, capped at r = 0.99 (≈ 100|Δa_K|); for single-iteration steps
        their largest correction (:meth:`_solver_error` multiplies it by r/(1−r), r measured on
        the sampled steps, see Newmark.sample_every). Elementwise and max operations only: the
        numbers the steps accumulated one by one before, bit for bit, for fewer kernels."""
        st = dict(st)
        tiny = torch.finfo(self.kw["dtype"]).tiny
        by_rows: dict[int, list[Tensor]] = {}
        for d in diags:
            by_rows.setdefault(d.shape[0], []).append(d)
        for rows, ds in by_rows.items():
            D = torch.stack(ds)  # (steps, rows, B)
            st["amax"] = torch.maximum(st["amax"], D[:, -1].amax(0))
            if rows == 3:
                prev, last = D[:, 0], D[:, 1]
                err = last * last / torch.maximum(prev - last, 0.01 * prev).clamp_min(tiny)
                st["err"] = torch.maximum(st["err"], err.amax(0))
            elif rows == 2:
                st["c1"] = torch.maximum(st["c1"], D[:, 0].amax(0))
        return st

    def _step_mats(self, B: int) -> dict[str, Tensor]:
        """The per-case matrices as the step reads them: S also as ``S_mv``, the form it
        multiplies vectors by; with a single case, the matrices of _MV_ONLY and ``S_mv`` as
        that case's (m, k) matrices (one GEMV per product, no views; once per chunk)."""
        m = self.mats
        if B != 1:
            return {**m, "S_mv": m["S"]} if "S" in m else m
        single = {k: _single(m[k]) for k in _MV_ONLY if k in m}
        if "S" in m:
            single["S_mv"] = _single(m["S"])
        return {**m, **single}

    def _step_function(self, step_no: int):
        """The step function of global step ``step_no`` (host decision, no synchronisation)."""
        integ = self.integ
        startup = step_no < integ.check_every
        iters = self.startup_iterations if startup else self.iterations
        refresh = self.refreshing and step_no % integ.refresh_every == 0
        rho = self.sampling and not startup and (step_no + 1) % integ.sample_every == 0
        key = (max(iters, 2) if rho else iters, refresh, rho)
        fn = self._step_cache.get(key)
        if fn is None:
            fn = self._make_step(*key)
            if integ.compile:
                fn = torch.compile(fn, dynamic=True)
            self._step_cache[key] = fn
        return fn

    def _steps(self, st: dict, step0: int, N: int) -> tuple[dict, Tensor, Tensor]:
        """Advance N steps from ``st``: the new state and the outputs Y, Ẏ (N, O, B)."""
        ys, yds, diags = [], [], []
        m = self._step_mats(st["q"].shape[1])
        for i in range(N):
            st, y, yd, diag = self._step_function(step0 + i)(st, m)
            ys.append(y)
            yds.append(yd)
            diags.append(diag)
        return self._fold_diagnostics(st, diags), torch.stack(ys), torch.stack(yds)

    def _steps_in_place(self, step0: int, N: int) -> tuple[Tensor, Tensor]:
        """:meth:`_steps` writing the new state into the current state tensors: the form a CUDA
        graph can capture (static input and output addresses), run eagerly elsewhere."""
        st, Y, Yd = self._steps(self.state, step0, N)
        # a step passes some inputs through (a_n becomes a_{n-1}): copy those first
        inputs = {id(t) for t in self.state.values()}
        st = {k: t.clone() if id(t) in inputs else t for k, t in st.items()}
        for k, t in self.state.items():
            t.copy_(st[k])
        return Y, Yd

    def _advance(self, step0: int, N: int) -> tuple[Tensor, Tensor]:
        """N steps of the whole batch; on CUDA (``cuda_graphs``) by replaying a captured graph
        of the chunk (captured again when the batch or the chunk's step pattern changes)."""
        if not self.graphs:
            self.state, Y, Yd = self._steps(self.state, step0, N)
            return Y, Yd
        if self.state["q"].device.type != "cuda":
            # the code a graph records, run eagerly: how the CUDA path is tested on a CPU
            return self._steps_in_place(step0, N)
        pattern = tuple(id(self._step_function(step0 + i)) for i in range(N))
        key = (pattern, self.state["q"].shape[1])
        if self._graph is None or self._graph[0] != key:
            self._graph = (key, *self._capture(step0, N))
        _, graph, Y, Yd = self._graph
        graph.replay()
        return Y.clone(), Yd.clone()

    def _capture(self, step0: int, N: int):
        """CUDA-graph capture of :meth:`_steps_in_place` (after a warm-up on a side stream, as
        torch.cuda.graphs requires); the state is saved and restored around the warm-up."""
        saved = {k: t.clone() for k, t in self.state.items()}
        stream = torch.cuda.Stream()
        stream.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(stream):
            self._steps_in_place(step0, min(N, 2))
        torch.cuda.current_stream().wait_stream(stream)
        for k, t in self.state.items():
            t.copy_(saved[k])
        graph = torch.cuda.CUDAGraph()
        with torch.cuda.graph(graph):  # records the kernels without running them
            Y, Yd = self._steps_in_place(step0, N)
        return graph, Y, Yd

    # ------------------------------------------------------------------------------------------
    def execute(self) -> SimulationResult:
        t0 = time.perf_counter()
        case_steps = 0
        tol = self.integ.tolerance(self.kw["dtype"])
        while len(self.active) and (self.adaptive or self.step_no < self.steps_total):
            # inference mode: no version counters nor view records on the thousands of small
            # tensors of an interval (about a fifth of a small batch's step); what leaves the
            # run is host arrays, and the state tensors never leave it. Not around CUDA graph
            # capture (replays have no per-op overhead to save; capture is left as it was)
            with torch.inference_mode(self._inference):
                case_steps += self._check_interval(tol)
            if self.progress is not None:
                self.progress(self.B - len(self.active), self.B)
        res = self.res
        return SimulationResult(
            output_names=self.names, status=res["status"].astype(str), steps=res["steps"],
            time=res["time"], amplitude=res["amplitude"], frequency_hz=res["frequency_hz"],
            amplitude_change=res["amplitude_change"], solver_error=res["solver_error"],
            last_amplitude=res["last_amplitude"], last_frequency_hz=res["last_frequency_hz"],
            q=res["q"], v=res["v"],
            histories={c: History(np.array([s[0] for s in h]), np.stack([s[1] for s in h]),
                                  self.names) for c, h in self.hist.items()},
            wall_time_s=time.perf_counter() - t0, case_steps=case_steps, xi=res["xi"],
            centre=res["centre"])

    def _check_interval(self, tol: float) -> int:
        """One check interval: advance the batch, track its extrema, decide, compact; returns
        the case-steps computed."""
        integ, crit = self.integ, self.crit
        dt = integ.dt
        adaptive = self.adaptive
        N = (integ.check_every if adaptive
             else min(integ.check_every, self.steps_total - self.step_no))
        Bc = len(self.active)
        step0 = self.step_no
        Y, Yd = self._advance(step0, N)
        st = self.state
        self.step_no += N
        Y, Yd = Y.transpose(1, 2), Yd.transpose(1, 2)  # (N, B, O) for the tracker
        if adaptive:
            # each case at its own time and step: the tracker times its extrema per case
            t_start = self.t.clone()
            self.t += N * self.dtc
            self.tracker.update(Y, Yd, t_start, self.dtc)
            self._record_history(Y, step0, t_start)
            final = self.t >= self.t_end * (1.0 - 1e-12)
        else:
            self.tracker.update(Y, Yd, step0, dt)
            self._record_history(Y, step0)
            final = self.step_no >= self.steps_total
        # per-case checks: one host synchronisation per chunk
        rel = self._solver_error(st)
        shrink = None
        if adaptive:
            # a nonlinear iteration that did not meet its tolerance asks for a smaller step
            # (until dt_min): such a case is judged from its next interval on, and no LCO
            # is accepted on this one
            shrink = (rel > tol) & (self.dtc > integ.step_bounds[0] * (1 + 1e-9))
            rel = torch.where(shrink, 0.0, rel)
        self.solver_rel = torch.maximum(self.solver_rel, rel)
        solver_ok = rel <= tol
        finite = torch.isfinite(st["q"]).all(0) & torch.isfinite(st["v"]).all(0)
        status = self.tracker.decide(crit, finite, solver_ok, final)
        if adaptive:
            status = torch.where(shrink & (status == LCO), RUNNING, status)
            self._adapt_steps(shrink)
        if integ.extrapolate:
            self._jump(status)
        status = status.cpu().numpy()
        self._reset_error()
        done = np.nonzero(status != RUNNING)[0]
        if len(done):
            self._finish(done, status[done])
        return N * Bc

    def _solver_error(self, st: dict) -> Tensor:
        """(B,) estimated error left in the acceleration, relative to the largest |a| of the
        check interval: the Aitken estimate of multi-iteration steps, and for single-iteration
        steps their largest correction times r/(1−r), r the largest contraction ratio measured
        on the sampled steps (r = ½ — the correction itself — where none was measured)."""
        f64 = torch.float64
        tiny = torch.finfo(f64).tiny
        r = st["rho"].to(f64)
        r = torch.where(r > 0, r.clamp(max=0.99), 0.5)
        err = torch.maximum(st["err"].to(f64), st["c1"].to(f64) * r / (1.0 - r))
        amax = st["amax"].to(f64)
        return torch.where(err > 0, err / amax.clamp_min(tiny), 0.0)

    def _record_history(self, Y: Tensor, step0: int, t_start: Tensor | None = None) -> None:
        """Keep the requested cases' outputs every ``every`` steps; ``t_start``: (B,) times at
        the chunk's start of an adaptive run (else the fixed step gives the times)."""
        if not self.hist:
            return
        every = self.history.every
        pos = {int(c): i for i, c in enumerate(self.active)}
        first = (-(step0 + 1)) % every  # index of the first sample with (step % every == 0)
        idx = torch.arange(first, Y.shape[0], every, device=Y.device)
        if len(idx) == 0:
            return
        for c, h in self.hist.items():
            if c in pos:
                ys = Y.index_select(0, idx)[:, pos[c]].double().cpu().numpy()
                if t_start is None:
                    ts = (step0 + 1 + idx.cpu().numpy()) * self.integ.dt
                else:
                    k = pos[c]
                    ts = (float(t_start[k]) + (1 + idx.cpu().numpy()) * float(self.dtc[k]))
                h.extend(zip(ts.tolist(), ys))

    def _finish(self, done: np.ndarray, codes: np.ndarray) -> None:
        """Record the results of the batch positions ``done`` and drop them from the batch."""
        cases = self.active[done]
        tr = self.tracker
        dev = self.state["q"].device
        di = torch.as_tensor(done, device=dev)

        def rows(name):
            return self.state[name].index_select(1, di).T.double().cpu().numpy()

        vals = tr.values.index_select(0, di).cpu().numpy()
        times = tr.times.index_select(0, di).cpu().numpy()
        count = tr.count.index_select(0, di).cpu().numpy()
        q, v = rows("q"), rows("v")
        xi = rows("xi") if "xi" in self.state else np.zeros((len(done), 0))
        rel = self.solver_rel.index_select(0, di).cpu().numpy()
        times_end = self.t.index_select(0, di).cpu().numpy()
        primary = self.crit.decision_outputs[0]
        C_out = self.C.double().cpu().numpy()
        for k, c in enumerate(cases):
            met = window_metrics(vals[k], times[k], count[k], self.crit.cycles, primary)
            r = self.res
            r["status"][c] = STATUS_NAMES[int(codes[k])]
            r["steps"][c] = self.step_no
            r["time"][c] = times_end[k] if self.adaptive else self.step_no * self.integ.dt
            # an LCO's amplitude and frequency; a decay has amplitude 0 and no frequency; any
            # other status has neither (NaN: never plotted as a value) — what the last cycle
            # measured is kept apart, in last_amplitude / last_frequency_hz
            code = int(codes[k])
            r["last_amplitude"][c] = met["amplitude"]
            r["last_frequency_hz"][c] = met["frequency_hz"]
            r["amplitude"][c] = met["amplitude"] if code == LCO else (0.0 if code == DECAY
                                                                      else np.nan)
            r["frequency_hz"][c] = met["frequency_hz"] if code == LCO else np.nan
            r["amplitude_change"][c] = met["amplitude_change"]
            if code == LCO:
                r["centre"][c] = met["centre"]
            elif code == DECAY:  # the equilibrium it settled on
                r["centre"][c] = q[k] @ C_out.T
            r["solver_error"][c] = rel[k]
            r["q"][c], r["v"][c], r["xi"][c] = q[k], v[k], xi[k]
        keep = np.setdiff1d(np.arange(len(self.active)), done)
        self.active = self.active[keep]
        ki = torch.as_tensor(keep, device=dev, dtype=torch.long)
        self.state = {k: t.index_select(-1, ki) for k, t in self.state.items()}
        self.mats = {k: t.index_select(-1, ki) for k, t in self.mats.items()}
        self.solver_rel = self.solver_rel.index_select(0, ki)
        self.t, self.dtc = self.t.index_select(0, ki), self.dtc.index_select(0, ki)
        self.jumps = self.jumps.index_select(0, ki)
        self.system = self.system.select(ki)
        self._graph = None
        tr.select(ki)
