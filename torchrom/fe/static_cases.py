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

Loads without editing the deck (``torchrom static DECK --load GRID:T3=VALUE``): point loads
(:class:`PointLoad`) — a force T1..T3 or a moment R1..R3 in the deck's units, along the
**basic** axes (as a FORCE/MOMENT card with CID 0, and as the displacements are reported) —
make one more subcase beside the deck's own (:func:`point_load_subcase`), numbered after the
last, with the SPC set of the deck's first static subcase (else the reader's choice), solved
linearly or nonlinearly as they are (dead loads too). A deck whose SOL is no static solution
(a SOL 103 modes deck) is solved for the point loads alone, linear unless ``nonlinear``. A
load on an unknown grid, or on a grid direction that a support takes (SPC, AUTOSPC), is
refused; one on a grid that is dependent in an RBE/MPC reaches its independent grids, as in
Nastran.
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
#: the components of a grid: forces T1..T3, moments R1..R3 (basic axes for a point load)
COMPONENTS = ("T1", "T2", "T3", "R1", "R2", "R3")
#: a CD component takes part in a basic direction when its direction cosine exceeds this
#: (cosines of a rotated frame are rounded to ~1e-16)
COSINE_TOL = 1e-12


@dataclass(frozen=True)
class PointLoad:
    """A force (component 1..3: T1..T3, force units) or moment (4..6: R1..R3, force x length)
    at ``grid`` along the basic axes: one ``--load GRID:COMPONENT=VALUE``."""

    grid: int
    component: int
    value: float

    @property
    def label(self) -> str:
        return f"{self.grid}:{COMPONENTS[self.component - 1]}={self.value:g}"

    def as_dict(self) -> dict:
        return {"grid": self.grid, "component": COMPONENTS[self.component - 1],
                "value": self.value}


@dataclass(frozen=True)
class StaticSubcase:
    """One static subcase of the case control: its number, LOAD, SPC and NLPARM set IDs
    (None: not given) and its LABEL/SUBTITLE text; or the subcase of the command line's
    ``point_loads`` (LOAD None)."""

    id: int
    load: int | None
    spc: int | None = None
    nlparm: int | None = None
    label: str = ""
    point_loads: tuple[PointLoad, ...] = ()

    def loads(self) -> dict[tuple[int, int], float]:
        """{(grid, component): summed value} of the point loads."""
        out: dict[tuple[int, int], float] = {}
        for p in self.point_loads:
            out[(p.grid, p.component)] = out.get((p.grid, p.component), 0.0) + p.value
        return out


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


def static_subcases(model, fname: str, required: bool = True) -> list[StaticSubcase]:
    """The static subcases of a pyNastran model's case control (module docstring); InputError
    when there is none and ``required``."""
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
    if not out and required:
        raise InputError(f"{fname}: no static subcase: the case control selects no LOAD "
                         f"(expected LOAD = <set ID> in a SUBCASE or above the subcases, or "
                         f"give loads with --load GRID:T3=VALUE)")
    return out


def point_load_subcase(point_loads, subcases: list[StaticSubcase]) -> StaticSubcase:
    """The subcase of the command line's point loads: numbered after the deck's last, with
    the SPC set of its first (None: the reader's choice)."""
    number = max((sc.id for sc in subcases), default=0) + 1
    label = "--load " + " ".join(p.label for p in point_loads)
    return StaticSubcase(number, None, subcases[0].spc if subcases else None, None, label,
                         tuple(point_loads))


def check_point_loads(fe, subcase: StaticSubcase, fname: str) -> None:
    """InputError (one line naming the ``--load``) for a point load on a grid the model has
    not, or along a basic direction that has a part on a supported DOF of the grid (SPC or
    AUTOSPC, in its CD frame): the support would take it and nothing would move. A DOF that
    is dependent in an RBE/MPC passes the load to its independent DOFs (Tᵀ f, as Nastran)."""
    rows = fe.mesh.grid_row()
    supported = set(map(tuple, fe.mesh.spc))
    for p in subcase.point_loads:
        where = f"--load {p.label}"
        row = rows.get(int(p.grid))
        if row is None:
            raise InputError(f"{where}: grid {p.grid} not found in {fname}")
        cd = fe.mesh.cd_axes[row]
        base = 0 if p.component <= 3 else 3
        for c in range(3):  # the CD components of this grid that the basic direction has
            if abs(cd[p.component - 1 - base, c]) <= COSINE_TOL:
                continue
            key = (row, base + c)
            reason = fe.constraints.status.get(key)
            if key in supported or reason == "AUTOSPC":
                frame = "" if np.allclose(cd, np.eye(3)) else (
                    f" of its displacement frame (CD), which basic "
                    f"{COMPONENTS[p.component - 1]} loads,")
                raise InputError(f"{where}: grid {p.grid} component {COMPONENTS[base + c]}"
                                 f"{frame} is constrained ({reason or 'SPC'}): the support "
                                 f"would take this load; load a free component or another "
                                 f"grid")


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
    notes: list[str] = field(default_factory=list)

    @property
    def total_steps(self) -> int:
        """Load steps planned over all subcases (step halvings add to them)."""
        return sum(n for n, _ in self.controls)


def plan_static(path, *, nonlinear: bool | None = None, steps: int | None = None,
                unsupported: str = "error", point_loads=()) -> StaticJob:
    """Read the deck at ``path`` and check its static subcases (module docstring): SOL, LOAD,
    SPC and NLPARM sets; one FE model per SPC set. ``point_loads`` (:class:`PointLoad`): one
    more subcase of them, after the deck's."""
    from .bdf_read import _read_pynastran, from_pynastran

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such deck")
    model = _read_pynastran(path)
    fname = path.name
    notes = []
    if point_loads and model.sol not in (None, *LINEAR_SOLS, *NONLINEAR_SOLS):
        # its case control is another solution's: the point loads alone
        subcases, is_nl = [], bool(nonlinear)
        notes.append(f"SOL {model.sol} is not a static solution: only the --load subcase is "
                     f"solved ({'nonlinear' if is_nl else 'linear; --nonlinear for SOL 106'})")
    else:
        # subcases first: a bulk-data-only deck (read as SOL 103 without case control) has
        # none
        subcases = static_subcases(model, fname, required=not point_loads)
        is_nl = analysis_is_nonlinear(model.sol, fname, nonlinear)
    if point_loads:
        subcases = [*subcases, point_load_subcase(point_loads, subcases)]
    models = {}
    for sc in subcases:
        if sc.spc not in models:
            models[sc.spc] = from_pynastran(model, source=str(path), name=path.stem,
                                            spc_id=sc.spc, unsupported=unsupported)
        fe = models[sc.spc]
        if sc.point_loads:
            check_point_loads(fe, sc, fname)
        elif sc.load not in fe.loads:
            raise InputError(f"{fname}: SUBCASE {sc.id}: LOAD = {sc.load}: no load set "
                             f"{sc.load} (FORCE, MOMENT, PLOAD2, PLOAD4, GRAV or LOAD cards; "
                             f"the deck has {sorted(fe.loads) or 'none'})")
    controls = [nlparm_controls(model, sc, fname, steps) if is_nl else (1, 1) for sc in subcases]
    return StaticJob(path, model, subcases, models, is_nl, controls, notes)


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
            F = np.column_stack([fe.nodal_load(subcases[k].loads()) if subcases[k].point_loads
                                 else fe.load_vector(subcases[k].load) for k in rows])
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
            load = (fe.nodal_dead_load(sc.loads()) if sc.point_loads
                    else fe.dead_load(sc.load))
            out = fe.static_solve(load, n_steps=n, max_iter=iters,
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
                     dict(fe.units), results, [*fe.notes, *job.notes])


def solve_static(path, *, nonlinear: bool | None = None, steps: int | None = None,
                 max_cuts: int = DEFAULT_MAX_CUTS, unsupported: str = "error",
                 point_loads=()) -> StaticRun:
    """:func:`plan_static` then :func:`run_static`: the static subcases of a deck (and of the
    ``point_loads``), solved."""
    job = plan_static(path, nonlinear=nonlinear, steps=steps, unsupported=unsupported,
                      point_loads=point_loads)
    return run_static(job, max_cuts=max_cuts)
