"""``torchrom plot TABLE --figure figN --out FILE``: draw one of the paper's figures from a table.

TABLE is a results table written by ``torchrom sweep`` or ``torchrom paper`` (``.parquet`` or
``.csv``). Figures (paper Sec. IV): ``fig9`` α vs γ (a table with columns gamma, alpha, e.g.
``alpha_gamma.csv`` of ``torchrom paper``), ``fig10`` LCO amplitude vs altitude, ``fig11`` time
histories of point A (needs ``histories.parquet``: ``--histories``, default beside TABLE),
``fig12`` LCO frequency vs altitude, ``fig13`` amplitude ratios q1/q2 and q1/q4. The figure's
format follows the suffix of FILE (png, pdf, svg). An existing FILE is kept unless ``--force``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_force_option, write_figure

NAME = "plot"
HELP = "draw a paper figure (fig9 .. fig13) from a results table"
FIGURE_NAMES = ("fig9", "fig10", "fig11", "fig12", "fig13")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("table", type=Path, help="results table (.parquet or .csv)")
    parser.add_argument("--figure", required=True, choices=FIGURE_NAMES, help="which figure")
    parser.add_argument("--out", type=Path, required=True, help="figure file (.png, .pdf, .svg)")
    parser.add_argument("--histories", type=Path, default=None,
                        help="time histories for fig11 (default: histories.parquet beside TABLE)")
    add_force_option(parser)


def read_table(path: Path):
    """A results table from parquet or CSV (InputError when missing or unreadable)."""
    import pandas as pd

    from ..errors import InputError

    if not path.is_file():
        raise InputError(f"{path}: table not found")
    try:
        return pd.read_csv(path) if path.suffix == ".csv" else pd.read_parquet(path)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a user error
        raise InputError(f"{path}: not a readable table ({exc})") from None


def run(args: argparse.Namespace) -> int:
    from ..study import figures

    table = read_table(args.table)
    if args.figure == "fig11":
        hist = args.histories or args.table.parent / "histories.parquet"
        path = write_figure(figures.fig11, table, read_table(hist), args.out, force=args.force)
    else:
        path = write_figure(figures.TABLE_FIGURES[args.figure], table, args.out,
                            force=args.force)
    if path is None:
        return 1  # warned: the plotting library failed on this table
    print(f"wrote {path}")
    return 0
