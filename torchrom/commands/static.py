"""``torchrom static DECK.bdf``: the deck's own static subcases, and one more of the
``--load GRID:T3=VALUE`` point loads (basic axes), linear (SOL 101) or geometrically
nonlinear (SOL 106/400), with dead loads (:mod:`torchrom.fe.static_cases`); with
``--aoa``/``--velocity``, or a SOL 144 deck, the static aeroelastic equilibrium instead
(:mod:`._static_aero`).

JSON (``--json FILE``, refused when it exists unless ``--force``): an object with ``deck``,
``sol`` (the deck's SOL number, or null), ``analysis`` (``linear`` or ``nonlinear``), ``loads``
(``dead``: not following the deformation), ``units`` (the model's: the deck's own consistent
units unless it states them), ``frame`` (``basic``), ``components`` (``T1 .. R3``) and
``subcases``: one object per subcase with ``subcase``, ``label``, ``load``, ``spc``,
``nlparm`` (set IDs, null when not given), ``point_loads`` (``--load``: [{``grid``,
``component`` (T1..R3), ``value``}] along the basic axes; [] for the deck's subcases, and
``load`` null for the ``--load`` subcase, numbered after the deck's last and labelled
``--load ...``), ``converged``, ``message`` and ``steps``: one
object per load step with ``step``, ``load_factor``, ``converged``, ``iterations``,
``residual`` (norm of the out-of-balance force) and ``displacements``: grid ID (a string) →
[T1, T2, T3, R1, R2, R3] in the basic frame (null for a step that did not converge).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import _static_aero as static_aero
from ._common import (
    add_force_option,
    add_json_option,
    add_unsupported_option,
    check_outputs,
    maybe_write_json,
    positive_int,
)

NAME = "static"
HELP = ("the deck's static subcases (LOAD/SPC/NLPARM in case control) and --load point loads: "
        "linear as SOL 101, nonlinear as SOL 106/400; dead loads; or the static aeroelastic "
        "equilibrium at a root "
        "angle of attack (--aoa, --velocity; SOL 144 TRIM)")


def grid_list(value: str) -> list[int]:
    """``1,2,3`` → [1, 2, 3] (grid IDs, positive integers)."""
    try:
        ids = [int(x) for x in value.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected grid IDs separated by commas, got "
                                         f"{value!r}") from None
    if not ids or min(ids) <= 0:
        raise argparse.ArgumentTypeError(f"expected positive grid IDs, got {value!r}")
    return ids


if TYPE_CHECKING:
    from ..fe.static_cases import PointLoad

#: DOF components of a grid (torchrom.fe.static_cases.COMPONENTS; not imported here: the
#: parser must not import the FE package and torch)
COMPONENTS = ("T1", "T2", "T3", "R1", "R2", "R3")


def point_load(value: str) -> PointLoad:
    """``GRID:COMPONENT=VALUE`` (``4:T3=250``, ``12:R1=-3.5e2``) → :class:`PointLoad`."""
    head, eq, number = value.partition("=")
    grid, colon, comp = head.partition(":")
    if not (eq and colon):
        raise argparse.ArgumentTypeError(f"expected GRID:COMPONENT=VALUE (e.g. 4:T3=250), got "
                                         f"{value!r}")
    try:
        gid = int(grid)
    except ValueError:
        gid = 0
    if gid <= 0:
        raise argparse.ArgumentTypeError(f"{value}: GRID: expected a grid ID (integer > 0), "
                                         f"got {grid!r}")
    comp = comp.strip().upper()
    if comp not in COMPONENTS:
        raise argparse.ArgumentTypeError(f"{value}: COMPONENT: expected one of "
                                         f"{', '.join(COMPONENTS)}, got {comp!r}")
    try:
        x = float(number)
    except ValueError:
        x = float("nan")
    if not np.isfinite(x):
        raise argparse.ArgumentTypeError(f"{value}: VALUE: expected a finite number (force or "
                                         f"moment in the deck's units), got {number!r}")
    from ..fe.static_cases import PointLoad

    return PointLoad(gid, COMPONENTS.index(comp) + 1, x)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", type=Path, help="Nastran deck with static subcases")
    kind = parser.add_mutually_exclusive_group()
    kind.add_argument("--nonlinear", action="store_true",
                      help="geometrically nonlinear solution (Newton, load steps) whatever the "
                           "deck's SOL (default: SOL 106/400 nonlinear, SOL 101 linear)")
    kind.add_argument("--linear", action="store_true",
                      help="linear solution whatever the deck's SOL")
    parser.add_argument("--steps", type=positive_int, default=None, metavar="N",
                        help="load steps of the nonlinear solution (default: the subcase's "
                             "NLPARM NINC, else 10); a step that does not converge is halved, "
                             "then reported as not converged")
    parser.add_argument("--load", type=point_load, action="append", default=None,
                        metavar="GRID:T3=VALUE",
                        help="a force (T1, T2, T3) or moment (R1, R2, R3) at a grid, in the "
                             "deck's units along the basic axes (as FORCE/MOMENT with CID 0 "
                             "and as the displacements are reported); repeatable: all of "
                             "them make one more subcase beside the deck's own (a SOL 103 "
                             "deck: that subcase alone)")
    parser.add_argument("--grids", type=grid_list, default=None, metavar="ID,ID,...",
                        help="print these grids' displacements (T1..R3, basic) at every step")
    add_unsupported_option(parser)
    add_json_option(parser)
    add_force_option(parser)
    static_aero.add_arguments(parser)


def run_records(run) -> dict:
    """The JSON object of a :class:`~torchrom.fe.static_cases.StaticRun` (module docstring)."""
    ids = [str(int(g)) for g in run.grid_ids]
    subcases = []
    for res in run.results:
        sc = res.subcase
        steps = []
        for k, s in enumerate(res.steps):
            disp = None if s.u is None else {g: [float(x) for x in row]
                                             for g, row in zip(ids, s.u)}
            steps.append({"step": k + 1, "load_factor": float(s.load_factor),
                          "converged": bool(s.converged), "iterations": int(s.iterations),
                          "residual": float(s.residual), "displacements": disp})
        subcases.append({"subcase": sc.id, "label": sc.label, "load": sc.load, "spc": sc.spc,
                         "nlparm": sc.nlparm,
                         "point_loads": [p.as_dict() for p in sc.point_loads],
                         "converged": res.converged,
                         "message": res.message, "steps": steps})
    return {"deck": run.deck, "sol": run.sol,
            "analysis": "nonlinear" if run.nonlinear else "linear", "loads": "dead",
            "units": run.units, "frame": "basic", "components": list(COMPONENTS),
            "subcases": subcases}


def grid_table(u: np.ndarray, rows: dict[int, int], grids: list[int]) -> str:
    """Fixed-width table of the chosen grids' T1..R3 (basic) at one step."""
    head = f"    {'grid':>10}" + "".join(f"  {c:>13}" for c in COMPONENTS)
    lines = [head]
    for g in grids:
        lines.append(f"    {g:>10}" + "".join(f"  {x:13.6g}" for x in u[rows[g]]))
    return "\n".join(lines)


def _largest(u: np.ndarray, grid_ids) -> str:
    """``0.1251 at grid 61 (T3)``: the largest translation component of a step."""
    t = np.abs(u[:, :3])
    row, comp = np.unravel_index(int(np.argmax(t)), t.shape)
    return f"{u[row, comp]:.6g} at grid {int(grid_ids[row])} ({COMPONENTS[comp]})"


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..fe.static_cases import plan_static, run_static
    from ..progress import Progress

    if static_aero.is_static_aeroelastic(args):
        if args.load:
            raise InputError("--load: for the deck's structural subcases (not with --aoa, "
                             "--velocity or a SOL 144 deck's static aeroelastic solution)")
        return static_aero.run(args)
    static_aero.refuse_stray_options(args)
    check_outputs(args, [])
    nonlinear = True if args.nonlinear else False if args.linear else None
    job = plan_static(args.model, nonlinear=nonlinear, steps=args.steps,
                      unsupported=args.unsupported, point_loads=args.load or ())
    fe = next(iter(job.models.values()))
    if args.grids:
        missing = [g for g in args.grids if g not in set(fe.grid_ids.tolist())]
        if missing:
            raise InputError(f"--grids: grid {missing[0]} not found in {args.model.name}")
    rows = {int(g): k for k, g in enumerate(fe.grid_ids)}
    kind = "nonlinear (Newton, dead loads)" if job.nonlinear else "linear (dead loads)"
    print(f"{args.model}: SOL {job.model.sol}, {kind}, {len(job.subcases)} subcase(s), "
          f"{fe.n_dof} free DOFs")
    n_steps = [n for n, _ in job.controls]
    with Progress(job.total_steps, f"static {args.model.name}", unit="load steps") as bar:
        def on_step(k: int, lam: float) -> None:
            bar.update_to(sum(n_steps[:k]) + int(round(lam * n_steps[k])))

        result = run_static(job, on_step=on_step)
    failed = 0
    for res in result.results:
        sc = res.subcase
        head = f"SUBCASE {sc.id}" + (f" ({sc.label})" if sc.label else "")
        loads = (f"point loads along the basic axes, SPC {sc.spc}" if sc.point_loads
                 else f"LOAD {sc.load}, SPC {sc.spc}")
        print(f"{head}: {loads}")
        for k, s in enumerate(res.steps):
            if not s.converged:
                failed += 1
                print(f"  step {k + 1}: load factor {s.load_factor:.4g}: NOT CONVERGED "
                      f"(residual {s.residual:.3g}); {res.message}")
                continue
            how = f"converged ({s.iterations} iterations)" if result.nonlinear else "solved"
            print(f"  step {k + 1}: load factor {s.load_factor:.4g}: {how}; largest translation "
                  f"{_largest(s.u, result.grid_ids)}")
            if args.grids:
                print(grid_table(s.u, rows, args.grids))
    for note in result.notes:
        print(f"note: {note}")
    if failed:
        print(f"{failed} subcase(s) stopped at a load step that did not converge (after step "
              f"halving); the converged steps are reported")
    maybe_write_json(args, run_records(result))
    return 0
