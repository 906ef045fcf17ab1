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

Shape form (the deformed wing in 3-D, :mod:`torchrom.post.pictures`): TABLE is then a ROM
(``rom.npz``, whose basis on the deck's grids identify stores) or a Nastran deck:
``--mode K`` draws mode K (a deck's linear mode, or the ROM's basis function) with its largest
translation at ``--fraction`` of the span (default 0.1) or magnified by ``--scale``;
``ROM.npz --sweep DIR --row ROW`` draws that sweep row's LCO over one period (``--frames``
instants, from DIR/orbits.parquet or a history with q1..qn; ROW its position in
DIR/results.parquet or its case_id) as a GIF (``--out lco.gif``), at true size unless
``--scale``; ``--view ELEV AZIM`` turns the view. Axes are the basic frame in the deck's length
unit; the title says the magnification. The flutter mode is drawn beside the V-g diagram by
``torchrom flutter ROM.npz AERO.npz --plot``.

The figure's format follows the suffix of ``--out`` (png, pdf, svg; gif for an LCO). An
existing file is kept unless ``--force``. A table with a ``status`` column and no converged LCO
(every case decayed, say) is refused, one line and nothing written, for the general form and
the LCO figures (fig10, fig12, fig13): their axes would be empty or a row of decays at 0.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    add_force_option,
    figure_file,
    finite_float,
    positive_float,
    positive_int,
    write_figure,
)

NAME = "plot"
HELP = ("draw any result table (--x/--y/--hue/--facet), a paper figure (--figure fig9..fig13) "
        "or the deformed wing (--mode K, or --sweep DIR --row ROW as a GIF)")
FIGURE_NAMES = ("fig9", "fig10", "fig11", "fig12", "fig13", "table2")
LCO_FIGURES = ("fig10", "fig12", "fig13")  # figures of the converged LCOs alone


def picture_file(value: str) -> Path:
    """argparse type of ``--out``: a figure file (:func:`figure_file`) or a ``.gif``."""
    return Path(value) if value.lower().endswith(".gif") else figure_file(value)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("table", type=Path,
                        help="results table (.parquet or .csv); shape form: ROM.npz or MODEL.bdf")
    parser.add_argument("--out", type=picture_file, required=True, metavar="FIGURE",
                        help="figure file to write (.png, .pdf, .svg; .gif: an LCO's period)")
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
    parser.add_argument("--mode", type=positive_int, default=None, metavar="K",
                        help="shape form: draw mode K of the deck or basis function K of the ROM")
    parser.add_argument("--sweep", type=Path, default=None, metavar="DIR",
                        help="shape form: the sweep folder whose row --row to draw (GIF)")
    parser.add_argument("--row", default=None,
                        help="shape form: the sweep's row (position in DIR/results.parquet) or "
                             "case_id")
    parser.add_argument("--frames", type=positive_int, default=24,
                        help="shape form, --sweep: instants over the period (default 24)")
    parser.add_argument("--fraction", type=positive_float, default=None,
                        help="shape form, --mode: draw the largest translation at this fraction "
                             "of the span (default 0.1)")
    parser.add_argument("--scale", type=positive_float, default=None,
                        help="shape form: magnify the displacements by this factor (default: "
                             "--fraction for a mode, 1 (true size) for an LCO)")
    parser.add_argument("--view", type=finite_float, nargs=2, default=None,
                        metavar=("ELEV", "AZIM"),
                        help="shape form: view elevation and azimuth in degrees (default 25 -60)")
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


#: options of the shape form
SHAPE_OPTIONS = {"--mode": "mode", "--sweep": "sweep", "--row": "row", "--fraction": "fraction",
                 "--scale": "scale", "--view": "view"}


def _run_shape(args: argparse.Namespace) -> int:
    """The deformed wing: a mode as a picture, or a sweep row's LCO as a GIF."""
    from ..errors import InputError
    from ..io import check_can_write

    table_only = [o for o in ("--x", "--figure", "--hue", "--facet", "--title", "--histories",
                              "--q4-mode", "--flutter-altitude")
                  if getattr(args, o[2:].replace("-", "_")) is not None]
    if table_only:
        raise InputError(f"{table_only[0]}: an option of the table forms, not of --mode/--sweep")
    if args.mode is not None and args.sweep is not None:
        raise InputError("--mode and --sweep: give one of them")
    gif = args.out.suffix.lower() == ".gif"
    if args.mode is not None and gif:
        raise InputError(f"--out {args.out}: a mode is a picture (.png, .pdf, .svg); a GIF is "
                         f"for --sweep DIR --row ROW")
    if args.sweep is not None and not gif:
        raise InputError(f"--out {args.out}: an LCO is drawn as a GIF (--out NAME.gif)")
    if args.sweep is not None and args.fraction is not None:
        raise InputError("--fraction: for --mode (an LCO is drawn at true size, or --scale)")
    check_can_write(args.out, args.force, "output")
    from .export import motion_of

    spec = argparse.Namespace(inputs=[args.table], flutter=False, sweep=args.sweep,
                              row=args.row, density=None, alt_range=None, alpha=None,
                              gamma=None, phases=12, frames=args.frames, n=None,
                              mode=None if args.mode is None else [args.mode])
    if spec.row is None and spec.sweep is not None:
        raise InputError("--sweep: needs --row ROW (a row number or case_id of the sweep)")
    if args.table.suffix == ".npz" and args.mode is not None:
        spec.mode = [args.mode]
    elif args.mode is not None:  # a deck: compute modes up to K
        spec.n = args.mode
    motion, _ = motion_of(spec)
    from ..post.pictures import MODE_FRACTION, lco_gif, mode_picture

    elev, azim = args.view or (25.0, -60.0)
    if gif:
        path = write_figure(lco_gif, args.out, motion, scale=args.scale or 1.0, elev=elev,
                            azim=azim)
    else:
        path = write_figure(mode_picture, args.out, motion, 0,
                            fraction=args.fraction or MODE_FRACTION, scale=args.scale,
                            elev=elev, azim=azim)
    if path is None:
        return 1
    print(f"wrote {path}")
    return 0


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..study import figures
    from ..study.plots import parameter_plot

    if args.mode is not None or args.sweep is not None or args.row is not None:
        return _run_shape(args)
    shape_only = [o for o, a in SHAPE_OPTIONS.items() if getattr(args, a) is not None]
    if shape_only:
        raise InputError(f"{shape_only[0]}: an option of the shape form (--mode K, or --sweep "
                         f"DIR --row ROW)")
    if args.out.suffix.lower() == ".gif":
        raise InputError(f"--out {args.out}: a GIF is for an LCO (--sweep DIR --row ROW); a "
                         f"table figure is .png, .pdf or .svg")
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
