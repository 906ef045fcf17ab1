"""``torchrom modes MODEL.bdf``: linear modal analysis of a Nastran deck.

JSON (``--json FILE``, refused when it exists unless ``--force``): a list of records, one per
mode: ``mode``, ``frequency_hz`` (Hz), ``kind`` (bending/torsion/in-plane/axial), ``content_*``
fractions; for a deck written by ``torchrom goland`` also ``paper_hz`` and ``diff_pct`` (Table 2).
An unconstrained or under-constrained deck's rigid-body modes come first, with ``kind``
``rigid-body``, their ``eigenvalue`` ω² (rad²/s², near zero, either sign) and ``frequency_hz`` =
sign(ω²)·√|ω²|/2π; the ``--n`` elastic modes follow.
With ``--compare RUN.f06`` also ``nastran_hz`` (the f06's first REAL EIGENVALUES table) and
``diff_pct`` (None for rigid-body modes, whose frequency is zero up to round-off: ``diff_hz``
is given instead).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ._common import (
    add_force_option,
    add_json_option,
    add_unsupported_option,
    add_wing_axes_options,
    apply_wing_axes,
    check_outputs,
    maybe_write_json,
    positive_int,
)

NAME = "modes"
#: a model with at least this many free DOFs reports its eigen-solve stage
LARGE_MODEL_DOFS = 50_000
HELP = "linear modal analysis table of a Nastran deck (MODEL.bdf)"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", type=Path, help="Nastran bulk data deck")
    parser.add_argument("--n", type=positive_int, default=None,
                        help="number of modes (default: EIGR/EIGRL ND of the deck, else 10)")
    add_unsupported_option(parser)
    add_wing_axes_options(parser)
    parser.add_argument("--compare", type=Path, metavar="RUN.f06",
                        help="print Nastran's frequencies from this f06 beside torchrom's, with "
                        "the differences (default --n: as many modes as the f06 lists)")
    add_json_option(parser)
    add_force_option(parser)


def compare_records(records: list[dict], nastran_hz) -> list[dict]:
    """Add ``nastran_hz``, ``diff_pct`` (or ``diff_hz`` for a rigid-body mode: Nastran's
    frequency below 1e-4 of its largest, where a relative difference is round-off over
    round-off) to each mode record."""
    ref = np.asarray(nastran_hz, dtype=float)
    floor = 1e-4 * max(float(np.abs(ref).max(initial=0.0)), 1e-300)
    out = []
    for rec in records:
        i = rec["mode"] - 1
        rec = {k: v for k, v in rec.items() if k not in ("paper_hz", "diff_pct")}
        if i < len(ref):
            rec["nastran_hz"] = float(ref[i])
            if abs(ref[i]) > floor:
                rec["diff_pct"] = 100.0 * (rec["frequency_hz"] - ref[i]) / ref[i]
            else:
                rec["diff_pct"] = None
                rec["diff_hz"] = rec["frequency_hz"] - float(ref[i])
        out.append(rec)
    return out


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..fe import read_bdf
    from ..fe.bdf_read import GOLAND_TITLE, _title
    from ..fe.goland import TABLE2_HZ
    from ..fe.report import mode_table
    from ..fe.solvers import RIGID_BODY_TOL
    from ..progress import Stages

    check_outputs(args, [])
    fe = read_bdf(args.model, unsupported=args.unsupported)
    s = fe.summary()
    elements = ", ".join(f"{k} {v}" for k, v in s.items()
                         if k not in ("name", "grids", "free_dofs", "autospc") and v)
    print(f"{args.model}: {s['grids']} grids, {s['free_dofs']} free DOFs ({elements})"
          + (f"; {s['autospc']} DOFs without stiffness removed (AUTOSPC)" if s["autospc"] else ""))
    apply_wing_axes(args, fe)
    nastran_hz = None
    if args.compare is not None:
        from ..f06 import read_real_eigenvalues

        tables = read_real_eigenvalues(args.compare)
        if not tables:
            raise InputError(f"{args.compare}: no REAL EIGENVALUES table")
        nastran_hz = tables[0].cycles
    n = args.n or (len(nastran_hz) if nastran_hz is not None else None)
    stages = Stages(f"modes of {args.model.name}", fe.n_dof >= LARGE_MODEL_DOFS)
    stages.start(f"eigen-solve on {fe.n_dof} DOFs")
    modes = fe.modes(n)
    stages.done()
    is_goland = _title(fe.bdf).startswith(GOLAND_TITLE)
    records = modes.records(reference_hz=TABLE2_HZ if is_goland else None)
    if modes.n_rigid:
        print(f"{modes.n_rigid} rigid-body mode(s) (ω² at or below {RIGID_BODY_TOL:g} of the "
              f"stiffness-to-mass scale), then the elastic modes:")
    if nastran_hz is not None:
        # the f06 lists the rigid-body modes among its n: compare as many modes as it has
        records = compare_records(records[: len(nastran_hz)], nastran_hz)
    print(mode_table(records))
    for note in fe.notes + modes.notes:
        print(f"note: {note}")
    maybe_write_json(args, records)
    return 0
