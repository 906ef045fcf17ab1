"""``torchrom bifurcation CONFIG.toml --out DIR``: supercritical or subcritical LCOs?

Each case of the configuration's ``[cases]`` is a *control* (e.g. an altitude around flutter,
or a value of α); at every control the ``[initial]`` displacement pattern is started at
``--num`` amplitudes q0 log-spaced over ``--q0 LO HI`` (all in one batch), the boundaries between
basins of attraction are refined in ``--refine`` more batches, and the LCOs are classified
(:mod:`torchrom.study.bifurcation`): subcritical when attractors coexist (a stable rest state
beside an LCO or unbounded growth, i.e. hysteresis), supercritical when every initial amplitude
reaches the same LCO.

Writes ``DIR/bifurcation.{parquet,csv}`` (one row per control: local picture, attractors with
their q0 ranges, counts by status, LCO amplitude range, threshold_q0 with its bracket and
threshold_amplitude in output units), ``DIR/bifurcation_runs.{parquet,csv}`` (every run) and
``DIR/bifurcation.png`` (bifurcation diagram and final vs initial amplitude). ``--json FILE``:
{"character", "evidence", "controls": [the summary rows]}.
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

NAME = "bifurcation"
HELP = "classify LCOs as supercritical or subcritical by a batched sweep of initial amplitudes"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", type=Path, help="sweep configuration (TOML); its cases are "
                        "the control values (their q0 is replaced)")
    parser.add_argument("--q0", type=positive_float, nargs=2, action=OrderedRange,
                        metavar=("LO", "HI"), default=None,
                        help="range of initial amplitudes (scale of the [initial] pattern; "
                             "default: [initial] q0 / 100 to x 10)")
    parser.add_argument("--num", type=positive_int, default=12,
                        help="initial amplitudes of the first batch, log-spaced (default 12)")
    parser.add_argument("--refine", type=nonnegative_int, default=2,
                        help="refinement rounds of the basin boundaries (default 2)")
    parser.add_argument("--points", type=positive_int, default=8,
                        help="new initial amplitudes per boundary and round (default 8)")
    parser.add_argument("--same-rtol", type=positive_float, default=0.02,
                        help="LCO amplitudes closer than this (relative) are one attractor")
    parser.add_argument("--x", default=None, metavar="PARAM",
                        help="control parameter on the diagram's axis (default: the first "
                             "that varies between the control cases)")
    add_study_options(parser, "bifurcation.parquet/.csv/.png")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ..sim import output_matrix
    from ..study.bifurcation import bifurcation_sweep
    from ..study.config import check_work
    from ..study.grid import case_label, distinct_cases
    from ..study.models import model_rom
    from ..study.plots import bifurcation_plot
    from ..study.runner import open_executor
    from ..study.sweep import case_evaluator, initial_displacement
    from ..study.table import table_paths, write_table

    device, dtype, cfg = load_study(args)
    model = cfg.build_model()
    rom = model_rom(model)
    controls = distinct_cases(cfg.cases, ("q0", "sample"))
    varying = [k for k in dict.fromkeys(k for c in controls for k in c)
               if len({repr(c.get(k)) for c in controls}) > 1]
    x = args.x or (varying[0] if varying else None)
    if x is not None and x not in varying and len(controls) > 1:
        raise InputError(f"--x: expected a parameter that varies between the control cases "
                         f"{varying}, got {x!r}")
    q0 = cfg.initial.get("q0", 1e-3)
    if args.q0 is None:
        if not isinstance(q0, (int, float)) or q0 <= 0:
            raise InputError("--q0 LO HI: required when [initial] q0 is not a positive number")
        args.q0 = (q0 / 100.0, q0 * 10.0)
    lo, hi = args.q0
    if not (0 < lo < hi) or args.num < 2:
        raise InputError(f"--q0 {lo} {hi} --num {args.num}: expected 0 < LO < HI and at least "
                         f"2 initial amplitudes")
    # at least one boundary refined per round: the fewest cases the command runs
    check_work(cfg, len(controls) * (args.num + args.refine * args.points),
               "cases (control cases x (--num + --refine x --points))")
    # the decision output's initial value per unit q0: thresholds in the LCO amplitude's units
    _, C = output_matrix(rom, cfg.outputs)
    scale = float(abs(C[cfg.lco.decision_outputs[0]]
                      @ initial_displacement(rom, cfg.initial, [{"q0": 1.0}])[0]))
    out = Path(args.out)
    paths = {**table_paths(out, "bifurcation"), **{f"runs {k}": p for k, p in
                                                   table_paths(out, "bifurcation_runs").items()},
             "figure": out / "bifurcation.png"}
    check_outputs(args, paths.values())

    with open_executor(args.workers, args.scheduler) as executor:
        info(f"torchrom bifurcation: {len(controls)} control case(s) of '{cfg.title}' x "
              f"{args.num} initial amplitudes q0 in [{lo:g}, {hi:g}], {executor.description}")
        evaluate = case_evaluator(cfg, model, device=device, dtype=dtype, executor=executor,
                                  chunk_size=args.chunk_size)
        result = bifurcation_sweep(evaluate, controls, np.geomspace(lo, hi, args.num),
                                   refine=args.refine, points=args.points,
                                   same_rtol=args.same_rtol, initial_scale=scale,
                                   log=note)
    summary = result.summary
    written = [*write_table(summary, out, force=args.force, stem="bifurcation").values(),
               *write_table(result.runs, out, force=args.force,
                            stem="bifurcation_runs").values(),
               write_figure(bifurcation_plot, result.runs, summary, paths["figure"], x=x,
                            title=f"{cfg.title}: {result.character}", force=args.force)]
    for _, row in summary.iterrows():
        label = case_label(row, varying, empty="case")
        print(f"[{label}] {row['local']}: {row['attractors']}")
    print(f"character: {result.character}")
    print(f"evidence: {result.evidence}")
    figures_ok = written[-1] is not None
    written = [p for p in written if p is not None]
    for p in written:
        print(f"wrote {p}")
    maybe_write_json(args, {"character": result.character, "evidence": result.evidence,
                            "controls": summary.to_dict(orient="records")})
    return 0 if figures_ok else 1
