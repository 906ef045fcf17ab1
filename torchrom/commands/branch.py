"""``torchrom branch CONFIG.toml --parameter P --range LO HI --out DIR``: LCO branches.

Every distinct case of the configuration (without the parameter P) is one branch, followed
from its Hopf (flutter) point in P over [LO, HI] by pseudo-arclength continuation of periodic
orbits (harmonic balance, :mod:`torchrom.periodic.continuation`), with the stability of every
orbit (Floquet multipliers), folds (limit points: hysteresis, a subcritical LCO) and branch
points flagged. Options may also come from the configuration's ``[branch]`` table (parameter,
bounds, harmonics, amplitude_scale, step, min_step, max_step, max_points, stability).

Writes ``DIR/branch.{parquet,csv}`` (one row per point; columns in
:mod:`torchrom.study.branch`), ``DIR/hopf.csv`` (the Hopf point of every branch) and
``DIR/branch.png`` (amplitude against P: stable solid, unstable dashed, Hopf points and folds
marked). ``--json FILE``: {"parameter", "hopf": [...], "folds": [...], "points": N}.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    OrderedRange,
    add_json_option,
    check_outputs,
    finite_float,
    load_study,
    maybe_write_json,
    positive_int,
)

NAME = "branch"
HELP = "follow LCO branches from the flutter (Hopf) point by continuation, with stability"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", type=Path, help="study configuration (TOML); each distinct "
                        "case without the parameter is one branch")
    parser.add_argument("--parameter", default=None,
                        help="the case parameter to follow (altitude_ft or altitude_m, the run's "
                             "altitude unit; gamma, alpha, ...; default [branch] parameter)")
    parser.add_argument("--range", type=finite_float, nargs=2, action=OrderedRange,
                        metavar=("LO", "HI"),
                        default=None,
                        help="parameter bounds (default [branch] bounds)")
    parser.add_argument("--harmonics", type=positive_int, default=None,
                        help="harmonics H (default 5)")
    parser.add_argument("--max-points", type=positive_int, default=None,
                        help="points per branch (default 60)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR",
                        help="output folder (branch.parquet/.csv, hopf.csv, branch.png)")
    parser.add_argument("--device", default="cpu", help="torch device (default cpu)")
    parser.add_argument("--dtype", default="float64", choices=("float64",),
                        help="harmonic balance runs in float64")
    add_json_option(parser)
    parser.add_argument("--force", action="store_true", help="replace existing outputs")


def run(args: argparse.Namespace) -> int:
    import math

    from ..study.branch import PARAMETER_UNITS, branch_options, run_branches
    from ..study.grid import case_label
    from ..study.plots import amplitude_label, branch_diagram
    from ..study.table import table_paths, write_table

    args.method = None
    device, _, cfg = load_study(args)
    parameter, options = branch_options(cfg, args.parameter, tuple(args.range) if args.range
                                        else None, harmonics=args.harmonics,
                                        max_points=args.max_points)
    out = Path(args.out)
    paths = table_paths(out, "branch")
    figure, hopf_path = out / "branch.png", out / "hopf.csv"
    check_outputs(args, (*paths.values(), figure, hopf_path))
    print(f"torchrom branch: {len(cfg.cases)} cases of '{cfg.title}' ({args.config}), "
          f"parameter {parameter} in [{options.bounds[0]:g}, {options.bounds[1]:g}], "
          f"H = {options.harmonics}")
    from ..progress import Progress

    with Progress(100, f"  {parameter} range covered", unit="%") as bar:
        study = run_branches(cfg, parameter, options, device=device,
                             progress=lambda f: bar.update_to(int(100 * f)), log=bar.write)
    table = study.table
    out.mkdir(parents=True, exist_ok=True)
    written = write_table(table, out, force=args.force, stem="branch")
    from ..io import atomic_path

    with atomic_path(hopf_path) as tmp:
        study.hopf.to_csv(tmp, index=False)
    units = PARAMETER_UNITS[parameter]
    pct = "amplitude_pct_span" in table
    y = "amplitude_pct_span" if pct else "amplitude"
    # label the branches by what differs between them
    others = [k for k in study.hopf.columns if k not in (
        "branch", "parameter", "frequency_hz", "unstable_below", "found", parameter)
        and study.hopf[k].astype(str).nunique() > 1]
    if len(table):
        branch_diagram(table, figure, parameter=parameter, units=units, y=y,
                       y_label=amplitude_label(table, y), title=cfg.title, force=args.force,
                       label_of=lambda row: case_label({k: row[k] for k in others}, others,
                                                       empty=f"branch {row['branch']}"))
    for _, h in study.hopf.iterrows():
        if not h["found"]:
            print(f"branch {h['branch']}: no Hopf point in the bounds")
            continue
        pts = table[table["branch"] == h["branch"]]
        st = pts["stable"].dropna()
        folds = pts[pts["kind"] == "fold"]
        verdict = ("subcritical (unstable orbits leave the Hopf point)"
                   if len(st) and not bool(st.iloc[0]) else "supercritical (stable from the "
                   "Hopf point)")
        print(f"branch {h['branch']}: Hopf at {parameter} = {h['parameter']:.6g} {units}, "
              f"{h['frequency_hz']:.4f} Hz; {len(pts) - 1} orbits, {verdict}"
              + "".join(f"; fold at {parameter} = {f:.6g} {units}"
                        for f in folds["fold_parameter"] if math.isfinite(f)))
    for p in (*written.values(), hopf_path, *([figure] if len(table) else [])):
        print(f"wrote {p}")
    folds = table[table["kind"] == "fold"] if len(table) else table
    maybe_write_json(args, {"parameter": parameter, "hopf": study.hopf.to_dict(orient="records"),
                            "folds": folds.to_dict(orient="records") if len(folds) else [],
                            "points": int(len(table))})
    return 0
