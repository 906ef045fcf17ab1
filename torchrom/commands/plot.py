"""``torchrom plot TABLE``: a figure of any result table, or one of the paper's figures.

TABLE is a table written by ``torchrom sweep``, ``paper``, ``calibrate``, ``bifurcation`` (or any
``.parquet`` / ``.csv`` with one row per case).

General form: ``--x COL --y COL [--hue COL] [--facet COL]``: y against x, one line per value of
``hue``, one panel per value of ``facet``; status markers when the table has a ``status`` column.
Axis labels carry units from the table's column metadata (parquet; the known columns are
labelled from a CSV too, :mod:`torchrom.study.units`).

Paper form: ``--figure NAME`` (paper Sec. IV): ``fig9`` α vs γ (a table with columns gamma,
alpha, e.g. ``tables/alpha_gamma.csv`` of ``torchrom paper``), ``fig10`` LCO amplitude vs
altitude, ``fig11`` time histories of point A (needs ``histories.parquet``: ``--histories``,
default beside TABLE), ``fig12`` LCO frequency vs altitude (with the paper's Table 3 and flutter
point), ``fig13`` amplitude ratios q1/q2 and q1/qN (``--q4-mode N``: our mode matched to the
paper's mode 4, default 4), ``table2`` natural frequencies against the paper's Table 2 (a table
with columns mode, frequency_hz[, kind]). ``--flutter-altitude FT`` marks our flutter altitude
(the paper's is always marked).

The figure's format follows the suffix of ``--out`` (png, pdf, svg). An existing file is kept
unless ``--force``. A table with a ``status`` column and no converged LCO (every case decayed,
say) is refused, one line and nothing written, for the general form and the LCO figures
(fig10, fig12, fig13): their axes would be empty or a row of decays at 0.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    add_force_option,
    figure_file,
    finite_float,
    positive_int,
    write_figure,
)

NAME = "plot"
HELP = "draw any result table (--x/--y/--hue/--facet) or a paper figure (--figure fig9..fig13)"
FIGURE_NAMES = ("fig9", "fig10", "fig11", "fig12", "fig13", "table2")
LCO_FIGURES = ("fig10", "fig12", "fig13")  # figures of the converged LCOs alone


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("table", type=Path, help="results table (.parquet or .csv)")
    parser.add_argument("--out", type=figure_file, required=True, metavar="FIGURE",
                        help="figure file to write (.png, .pdf, .svg)")
    parser.add_argument("--x", help="general form: column on the x axis")
    parser.add_argument("--y", default="amplitude",
                        help="general form: column on the y axis (default amplitude)")
    parser.add_argument("--hue", help="general form: one line per value of this column")
    parser.add_argument("--facet", help="general form: one panel per value of this column")
    parser.add_argument("--title", help="general form: figure title")
    parser.add_argument("--figure", choices=FIGURE_NAMES, help="paper form: which figure")
    parser.add_argument("--histories", type=Path, default=None,
                        help="time histories for fig11 (default: histories.parquet beside TABLE)")
    parser.add_argument("--q4-mode", type=positive_int, default=None, metavar="N",
                        help="fig13: our mode compared with the paper's mode 4 (default 4)")
    parser.add_argument("--flutter-altitude", type=finite_float, default=None, metavar="FT",
                        help="fig10/12/13: mark our flutter altitude (ft)")
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


#: options of one form or some figures only: option -> (attribute, the --figure values it
#: serves; None: the general form, --x)
ONLY_WITH = {"--histories": ("histories", ("fig11",)), "--q4-mode": ("q4_mode", ("fig13",)),
             "--flutter-altitude": ("flutter_altitude", ("fig10", "fig12", "fig13")),
             "--hue": ("hue", None), "--facet": ("facet", None), "--title": ("title", None)}


def _check_applies(args: argparse.Namespace) -> None:
    """An option the chosen form does not read is refused (it would be ignored silently)."""
    from ..errors import InputError

    for option, (attr, figures) in ONLY_WITH.items():
        if getattr(args, attr) is None:
            continue
        if figures is None and args.figure is not None:
            raise InputError(f"{option}: used by the general form (--x) only, not by --figure "
                             f"{args.figure}")
        if figures is not None and args.figure not in figures:
            raise InputError(f"{option}: used with --figure {' or '.join(figures)} only")


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..study import figures
    from ..study.plots import parameter_plot

    if (args.figure is None) == (args.x is None):
        raise InputError("plot: give either --x (and --y, --hue, --facet) for any table or "
                         "--figure NAME for a paper figure")
    _check_applies(args)
    table = read_table(args.table)
    if (args.figure in (None, *LCO_FIGURES) and "status" in table.columns
            and not (table["status"] == "lco").any()):
        raise InputError(f"no case with an LCO in {args.table}: nothing to plot")
    if args.figure is None:
        path = parameter_plot(table, args.out, x=args.x, y=args.y, hue=args.hue,
                              facet=args.facet, title=args.title, force=args.force)
    elif args.figure == "fig11":
        hist = args.histories or args.table.parent / "histories.parquet"
        path = write_figure(figures.fig11, table, read_table(hist), args.out, force=args.force)
    else:
        kw = {}
        if args.figure in ("fig10", "fig12", "fig13"):
            kw["flutter_altitude_ft"] = args.flutter_altitude
        if args.figure == "fig13":
            kw["q4_mode"] = 4 if args.q4_mode is None else args.q4_mode
        draw = figures.table2 if args.figure == "table2" else figures.TABLE_FIGURES[args.figure]
        path = write_figure(draw, table, args.out, force=args.force, **kw)
    if path is None:
        return 1  # warned: the plotting library failed on this table
    print(f"wrote {path}")
    return 0
