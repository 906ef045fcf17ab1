"""``torchrom calibrate CONFIG.toml --target A --out DIR``: the γ that gives an LCO amplitude.

For every case of the configuration's ``[cases]`` (its γ ignored: e.g. one per altitude or α)
finds the Kelvin–Voigt factor γ (s) whose LCO amplitude equals ``--target`` (in the units of
``--column``, default the first output's amplitude) by batched bracketing — a log-spaced scan of
``--num`` values over ``--gamma LO HI``, then ``--num`` new values inside every bracket per
round until the bracket is narrower than ``--rtol`` — and reports the sensitivity dA/dγ
(:mod:`torchrom.study.calibrate`). α is the case's (fixed). Every root is simulated once more as
a check.

Writes ``DIR/calibration.{parquet,csv}`` (one row per base case and root: gamma, bracket,
damplitude_dgamma (output units per s), sensitivity (dlnA/dlnγ), check_value, check_error,
status), ``DIR/calibration_runs.{parquet,csv}`` (every simulation) and ``DIR/calibration.png``;
``--json FILE``: the calibration rows as a list of records (same keys and units).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import InputError
from ..progress import info, note
from ._common import (
    OrderedRange,
    add_study_options,
    check_outputs,
    load_study,
    maybe_write_json,
    nonnegative_int,
    positive_float,
    positive_int,
    write_figure,
)

NAME = "calibrate"
HELP = "find the Kelvin-Voigt factor gamma that produces a target LCO amplitude (batched)"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", type=Path, help="sweep configuration (TOML); its cases are "
                        "the base cases (their gamma is ignored)")
    parser.add_argument("--target", type=positive_float, required=True,
                        help="target LCO amplitude (units of --column)")
    parser.add_argument("--column", default="amplitude",
                        help="table column to match (default amplitude: the first output)")
    parser.add_argument("--gamma", type=positive_float, nargs=2, action=OrderedRange,
                        metavar=("LO", "HI"), default=None,
                        help="gamma range scanned (s; default: the configuration's gamma / 10 "
                             "to x 10)")
    parser.add_argument("--num", type=positive_int, default=16,
                        help="values of gamma per bracket and round (default 16)")
    parser.add_argument("--rtol", type=positive_float, default=2e-3,
                        help="relative width of the final bracket (default 2e-3)")
    parser.add_argument("--rounds", type=nonnegative_int, default=6,
                        help="largest number of refinement rounds (default 6)")
    add_study_options(parser, "calibration.parquet/.csv/.png")


def run(args: argparse.Namespace) -> int:

    from ..study.calibrate import calibrate_gamma
    from ..study.config import check_work
    from ..study.grid import case_label, distinct_cases
    from ..study.plots import calibration_plot
    from ..study.runner import open_executor
    from ..study.sweep import case_evaluator
    from ..study.table import table_paths, write_table

    device, dtype, cfg = load_study(args)
    # harmonic balance: Newton on γ with dA/dγ from the implicit-function theorem
    cfg = cfg.solver.with_gamma_sensitivity(cfg)
    bases = distinct_cases(cfg.cases, ("gamma", "sample"))
    # every round scans --num values of γ per base case (and per open bracket: at most one)
    check_work(cfg, (args.rounds + 1) * args.num * max(len(bases), 1),
               "cases of all rounds (--rounds + 1) x --num x base cases")
    if args.gamma is None:
        gammas = [float(c["gamma"]) for c in cfg.cases if float(c.get("gamma", 0.0)) > 0]
        if not gammas:
            raise InputError("--gamma LO HI: required when the configuration's cases have no "
                             "positive gamma")
        args.gamma = (min(gammas) / 10.0, max(gammas) * 10.0)
    out = Path(args.out)
    paths = {**{f"calibration {k}": p for k, p in table_paths(out, "calibration").items()},
             **{f"runs {k}": p for k, p in table_paths(out, "calibration_runs").items()},
             "figure": out / "calibration.png"}
    check_outputs(args, paths.values())

    with open_executor(args.workers, args.scheduler) as executor:
        info(f"torchrom calibrate: gamma for {args.column} = {args.target:g} in "
              f"{len(bases)} base case(s) of '{cfg.title}', gamma in [{args.gamma[0]:g}, "
              f"{args.gamma[1]:g}] s, {executor.description}")
        evaluate = case_evaluator(cfg, device=device, dtype=dtype, executor=executor,
                                  chunk_size=args.chunk_size)
        result = calibrate_gamma(evaluate, bases, args.target, gamma_range=tuple(args.gamma),
                                 column=args.column, num=args.num, rtol=args.rtol,
                                 max_rounds=args.rounds,
                                 log=note)
    table = result.table
    written = [*write_table(table, out, force=args.force, stem="calibration").values(),
               *write_table(result.evaluations, out, force=args.force,
                            stem="calibration_runs").values(),
               write_figure(calibration_plot, result.evaluations, table, paths["figure"],
                            column=args.column, target=args.target, title=cfg.title,
                            force=args.force)]
    for _, row in table.iterrows():
        base = case_label(row, bases[int(row["base_case"])])
        if row["status"] != "ok":
            print(f"[{base}] not bracketed: {row['note']}")
            continue
        print(f"[{base}] gamma = {row['gamma']:.6g} s (bracket {row['gamma_low']:.6g} .. "
              f"{row['gamma_high']:.6g}), d{args.column}/dgamma = "
              f"{row['damplitude_dgamma']:.4g} per s, dln/dln = {row['sensitivity']:.4g}; "
              f"check: {row['check_status']} {row['check_value']:.6g} "
              f"({100 * row['check_error']:+.3f} %)")
    figures_ok = written[-1] is not None
    written = [p for p in written if p is not None]
    for p in written:
        print(f"wrote {p}")
    maybe_write_json(args, table.to_dict(orient="records"))
    return 0 if figures_ok and (table["status"] == "ok").all() else 1
