"""``torchrom modes MODEL.bdf``: linear modal analysis of a Nastran deck.

JSON (``--json FILE``, refused when it exists unless ``--force``): a list of records, one per
mode: ``mode``, ``frequency_hz`` (Hz), ``kind`` (bending/torsion/in-plane/axial), ``content_*``
fractions; for a deck written by ``torchrom goland`` also ``paper_hz`` and ``diff_pct`` (Table 2).
An unconstrained or under-constrained deck's rigid-body modes come first, with ``kind``
``rigid-body``, their ``eigenvalue`` ω² (rad²/s², near zero, either sign) and ``frequency_hz`` =
sign(ω²)·√|ω²|/2π; the ``--n`` elastic modes follow.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    add_force_option,
    add_json_option,
    check_outputs,
    maybe_write_json,
    positive_int,
)

NAME = "modes"
HELP = "linear modal analysis table of a Nastran deck (MODEL.bdf)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", type=Path, help="Nastran bulk data deck")
    parser.add_argument("--n", type=positive_int, default=None,
                        help="number of modes (default: EIGR/EIGRL ND of the deck, else 10)")
    parser.add_argument("--unsupported", choices=("error", "warn"), default="error",
                        help="what to do with unsupported structural cards (default error)")
    add_json_option(parser)
    add_force_option(parser)


def run(args: argparse.Namespace) -> int:
    from ..fe import read_bdf
    from ..fe.bdf_read import GOLAND_TITLE, _title
    from ..fe.goland import TABLE2_HZ
    from ..fe.report import mode_table
    from ..fe.solvers import RIGID_BODY_TOL

    check_outputs(args, [])
    fe = read_bdf(args.model, unsupported=args.unsupported)
    s = fe.summary()
    elements = ", ".join(f"{k} {v}" for k, v in s.items()
                         if k not in ("name", "grids", "free_dofs", "autospc") and v)
    print(f"{args.model}: {s['grids']} grids, {s['free_dofs']} free DOFs ({elements})"
          + (f"; {s['autospc']} DOFs without stiffness removed (AUTOSPC)" if s["autospc"] else ""))
    modes = fe.modes(args.n)
    is_goland = _title(fe.bdf).startswith(GOLAND_TITLE)
    records = modes.records(reference_hz=TABLE2_HZ if is_goland else None)
    if modes.n_rigid:
        print(f"{modes.n_rigid} rigid-body mode(s) (ω² at or below {RIGID_BODY_TOL:g} of the "
              f"stiffness-to-mass scale), then the elastic modes:")
    print(mode_table(records))
    maybe_write_json(args, records)
    return 0
