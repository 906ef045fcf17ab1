"""The static subcases of a Nastran deck, solved as Nastran's SOL 101 (linear) or SOL 106/400
(geometrically nonlinear).

Case control (MSC QRG, case control): every SUBCASE with a LOAD is a static subcase; LOAD, SPC
and NLPARM given above the first SUBCASE hold for every subcase that does not give its own
(pyNastran copies them down); a deck without SUBCASE whose case control has a LOAD is one
subcase, numbered 1 (as Nastran). A subcase without SPC uses the reader's choice
(:func:`torchrom.fe.bdf_read.read_bdf`: the case control's first SPC, else the only SPC set).
The load set is the deck's FORCE/MOMENT/PLOAD2/PLOAD4/GRAV/LOAD cards of that ID
(:mod:`torchrom.fe.loads`); all loads are **dead loads**: their direction and size do not
follow the deformation (also in the nonlinear solution).

Linear (SOL 101, or ``nonlinear=False``): u = K⁻¹ F with the model's linear stiffness, one
factorisation per SPC set. Nonlinear (SOL 106/400, or ``nonlinear=True``): Newton–Raphson on
f(u) = λ F from λ = 0 to 1 in equal load steps (:func:`torchrom.fe.solvers.static_solve`), as
many as the subcase's NLPARM NINC (else ``steps``, default 10, Nastran's NINC default), at
most NLPARM MAXITER iterations each (default 25); a step that does not converge is halved (up to
``max_cuts`` times in all), then the subcase ends with the step reported as not converged. The
nonlinearity is whatever the FE model's internal force f(u) and tangent K_T(u) have
(:class:`~torchrom.fe.model.FEModel`); this module knows nothing of element types.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

#: SOL numbers (pyNastran maps SESTATIC to 101, NLSTATIC to 106) and their analysis
LINEAR_SOLS = (101,)
NONLINEAR_SOLS = (106, 400)
#: Nastran's NLPARM defaults: NINC 10 load increments, MAXITER 25 iterations
DEFAULT_STEPS = 10
DEFAULT_MAX_ITER = 25
#: step halvings allowed in one subcase before it is reported as not converged
DEFAULT_MAX_CUTS = 10


@dataclass(frozen=True)
class StaticSubcase:
    """One static subcase of the case control: its number, LOAD, SPC and NLPARM set IDs
    (None: not given) and its LABEL/SUBTITLE text."""

    id: int
    load: int
    spc: int | None = None
    nlparm: int | None = None
    label: str = ""


@dataclass
class StaticStep:
    """One load step: load factor λ, whether it converged, its Newton iterations and residual
    norm, and the displacements ``u`` (n_grid, 6: T1..R3 in basic axes; None for a step that
    did not converge)."""

    load_factor: float
    converged: bool
    iterations: int = 0
    residual: float = 0.0
    u: np.ndarray | None = None


@dataclass
class SubcaseResult:
    subcase: StaticSubcase
    steps: list[StaticStep] = field(default_factory=list)
    message: str = ""

    @property
    def converged(self) -> bool:
        return bool(self.steps) and all(s.converged for s in self.steps) and \
            self.steps[-1].load_factor >= 1.0 - 1e-12


@dataclass
class StaticRun:
    """The solution of a deck's static subcases: ``sol`` (the deck's SOL number or None),
    ``nonlinear``, ``grid_ids`` (rows of every ``StaticStep.u``), ``units`` (the model's),
    ``results`` (one per subcase, in case-control order), ``notes`` (the reader's)."""

    deck: str
    sol: int | None
    nonlinear: bool
    grid_ids: np.ndarray
    units: dict[str, str]
    results: list[SubcaseResult]
    notes: list[str] = field(default_factory=list)


def static_subcases(model, fname: str) -> list[StaticSubcase]:
    """The static subcases of a pyNastran model's case control (module docstring); InputError
    when there is none."""
    cc = model.case_control_deck
    subcases = {} if cc is None else cc.subcases

    def value(sub, key):
        return sub.get_parameter(key)[0] if key in sub.params else None

    numbered = sorted(i for i in subcases if i > 0)
    chosen = [(i, subcases[i]) for i in numbered] if numbered else \
        [(1, subcases[0])] if 0 in subcases else []
    out = []
    for i, sub in chosen:
        load = value(sub, "LOAD")
        if load is None:
            continue
        label = value(sub, "LABEL") or value(sub, "SUBTITLE") or ""
        ids = []
        for key, v in (("LOAD", load), ("SPC", value(sub, "SPC")),
                       ("NLPARM", value(sub, "NLPARM"))):
            if v is not None and not (isinstance(v, int) and v > 0):
                raise InputError(f"{fname}: SUBCASE {i}: {key} = {v}: expected a set ID "
                                 f"(integer > 0)")
            ids.append(v)
        out.append(StaticSubcase(i, ids[0], ids[1], ids[2], str(label).strip()))
    if not out:
        raise InputError(f"{fname}: no static subcase: the case control selects no LOAD "
                         f"(expected LOAD = <set ID> in a SUBCASE or above the subcases)")
    return out


def analysis_is_nonlinear(sol, fname: str, nonlinear: bool | None) -> bool:
    """Whether to solve nonlinearly: ``nonlinear`` when given, else by the deck's SOL (101:
    linear; 106, 400: nonlinear); InputError for a SOL that is not a static solution."""
    if sol is not None and sol not in LINEAR_SOLS + NONLINEAR_SOLS:
        raise InputError(f"{fname}: SOL {sol}: not a static solution (expected SOL 101, 106 "
                         f"or 400)")
    if nonlinear is not None:
        return bool(nonlinear)
    return sol in NONLINEAR_SOLS


def nlparm_controls(model, subcase: StaticSubcase, fname: str,
                    steps: int | None) -> tuple[int, int]:
    """(load steps, Newton iterations per step) of a nonlinear subcase: ``steps`` if given,
    else its NLPARM's NINC, else :data:`DEFAULT_STEPS`; MAXITER, else 25."""
    n, iters = DEFAULT_STEPS, DEFAULT_MAX_ITER
    if subcase.nlparm is not None:
        card = model.nlparms.get(subcase.nlparm)
        if card is None:
            raise InputError(f"{fname}: SUBCASE {subcase.id}: NLPARM = {subcase.nlparm}: no "
                             f"NLPARM card with that ID")
        n = int(card.ninc) if card.ninc else DEFAULT_STEPS
        iters = int(card.max_iter) if card.max_iter and card.max_iter > 0 else iters
    return (int(steps) if steps else n), iters


@dataclass
class StaticJob:
    """A deck read and checked, ready to solve: the pyNastran ``model``, its ``subcases``, an
    FE model per SPC set (``models``), whether the analysis is ``nonlinear`` and each subcase's
    (load steps, iterations per step) ``controls``."""

    path: Path
    model: object
    subcases: list[StaticSubcase]
    models: dict
    nonlinear: bool
    controls: list[tuple[int, int]]

    @property
    def total_steps(self) -> int:
        """Load steps planned over all subcases (step halvings add to them)."""
        return sum(n for n, _ in self.controls)


def plan_static(path, *, nonlinear: bool | None = None, steps: int | None = None,
                unsupported: str = "error") -> StaticJob:
    """Read the deck at ``path`` and check its static subcases (module docstring): SOL, LOAD,
    SPC and NLPARM sets; one FE model per SPC set."""
    from .bdf_read import _read_pynastran, from_pynastran

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such deck")
    model = _read_pynastran(path)
    fname = path.name
    # subcases first: a bulk-data-only deck (read as SOL 103 without case control) has none
    subcases = static_subcases(model, fname)
    is_nl = analysis_is_nonlinear(model.sol, fname, nonlinear)
    models = {}
    for sc in subcases:
        if sc.spc not in models:
            models[sc.spc] = from_pynastran(model, source=str(path), name=path.stem,
                                            spc_id=sc.spc, unsupported=unsupported)
        fe = models[sc.spc]
        if sc.load not in fe.loads:
            raise InputError(f"{fname}: SUBCASE {sc.id}: LOAD = {sc.load}: no load set "
                             f"{sc.load} (FORCE, MOMENT, PLOAD2, PLOAD4, GRAV or LOAD cards; "
                             f"the deck has {sorted(fe.loads) or 'none'})")
    controls = [nlparm_controls(model, sc, fname, steps) if is_nl else (1, 1) for sc in subcases]
    return StaticJob(path, model, subcases, models, is_nl, controls)


def run_static(job: StaticJob, *, max_cuts: int = DEFAULT_MAX_CUTS,
               on_step: Callable[[int, float], None] | None = None) -> StaticRun:
    """Solve every subcase of ``job`` (module docstring). ``on_step`` (subcase index, load
    factor) is called after each converged step (progress)."""
    from .solvers import solve_symmetric

    subcases = job.subcases
    results = [SubcaseResult(sc) for sc in subcases]
    if not job.nonlinear:
        for spc, fe in job.models.items():
            rows = [k for k, sc in enumerate(subcases) if sc.spc == spc]
            K = fe.stiffness_matrix()
            F = np.column_stack([fe.load_vector(subcases[k].load) for k in rows])
            U = solve_symmetric(K, F).reshape(fe.n_dof, len(rows))
            for j, k in enumerate(rows):
                residual = float(np.linalg.norm(F[:, j] - K @ U[:, j]))
                results[k].steps.append(StaticStep(1.0, True, 1, residual, fe.expand(U[:, j])))
                if on_step is not None:
                    on_step(k, 1.0)
    else:
        for k, sc in enumerate(subcases):
            fe = job.models[sc.spc]
            n, iters = job.controls[k]
            saved = []

            def record(lam, u, k=k, saved=saved):
                saved.append(np.array(u, dtype=float))
                if on_step is not None:
                    on_step(k, lam)

            # dead loads: their moments and turned RBE2 arms follow the large rotations
            out = fe.static_solve(fe.dead_load(sc.load), n_steps=n, max_iter=iters,
                                  max_cuts=max_cuts, callback=record)
            res = results[k]
            res.steps = [StaticStep(h["load_factor"], True, h["iterations"], h["residual"],
                                    fe.expand(u, large=True))
                         for h, u in zip(out.history, saved)]
            if not out.converged:
                res.steps.append(StaticStep(float(out.failed_load_factor), False, 0,
                                            float(out.residual_norm)))
            res.message = out.message
    fe = next(iter(job.models.values()))
    return StaticRun(str(job.path), job.model.sol, job.nonlinear, fe.grid_ids.copy(),
                     dict(fe.units), results, list(fe.notes))


def solve_static(path, *, nonlinear: bool | None = None, steps: int | None = None,
                 max_cuts: int = DEFAULT_MAX_CUTS, unsupported: str = "error") -> StaticRun:
    """:func:`plan_static` then :func:`run_static`: the static subcases of a deck, solved."""
    job = plan_static(path, nonlinear=nonlinear, steps=steps, unsupported=unsupported)
    return run_static(job, max_cuts=max_cuts)
