"""``torchrom paper [--out DIR] [--quick] [--force]``: the paper's post-flutter study end to end.

Builds the heavy Goland FE model (the default, updated wing), identifies the 9L12D ROM
(decomposition damping), computes the
aerodynamics on its basis (Mach 0.70, 9 modes, 13 lags), finds flutter, checks the batched
simulator against the eigenvalues, runs the LCO sweep and writes into DIR (default ``paper``, or
``paper-quick`` with ``--quick``):

- ``figures/fig09_alpha_gamma.png`` … ``fig13_amplitude_ratios.png`` (paper Figs. 9–13);
- ``report.md``: Table 2, the flutter point, Table 3, the Fig. 9–13 values and every finding of
  the paper with our verdict (agree / differ, with numbers and causes);
- ``paper.json``: the same numbers machine-readably (keys: version, quick, seconds, flutter,
  linear, lco, alpha_gamma, findings, figures, figures_failed (figures that could not be drawn:
  a warning and exit status 1; the tables and the report are written), identification, sweeps
  (per sweep: cases, case_steps, wall_time_s and, of it, certificate_s), processes (2: the
  stages that need only the model ran in a second process, :mod:`torchrom.paper.beside`;
  ``TORCHROM_PAPER_PROCESSES=1`` keeps one));
- ``model/`` (goland.bdf, rom.npz, basis.npz, aero.npz, flutter.json), ``model_exact/`` (the same
  with the exact Kelvin–Voigt damping, for the report's damping cause check and the band over
  admissible damping decompositions, ``sweeps/lco_damping_theta_*``), ``model_calibrated/``
  (the calibrated wing, whose LCO sweep ``sweeps/lco_calibrated/`` and findings the report
  shows beside the study's: paper.json keys ``variant``, ``variants``,
  ``decomposition_band``), ``tables/``
  (alpha_gamma, table3, linear_check) and ``sweeps/lco/``, ``sweeps/lco_exact_damping/``
  (results, histories): cached by the hash of their inputs and the package version and reused
  on the next run; ``--force`` rebuilds everything (a cached file edited by hand is refused
  without it). A sweep keeps its finished chunks in ``sweeps/<name>/parts/``: an interrupted
  study resumes it where it stopped. The folder is locked for the run: a second study into it
  exits with status 2, naming the first one's PID (:mod:`torchrom.locks`).
``--quick``: coarser grids and shorter runs (minutes instead of a quarter of an hour).
``--method``: ``hb`` (the default) computes the LCOs as periodic orbits by harmonic balance,
each certified as an orbit of the continuous-time equations (the Fourier certificate, or
shooting where it refuses; :mod:`torchrom.paper.hb`): Figs. 10, 12, 13 from the orbits, Fig. 11
and a side-by-side table from Newmark runs started on a subset of them, the LCO branches in
altitude from the flutter point with their stability (``figures/lco_branches.png``).
``newmark`` runs the paper's own time marching (dt = 1 ms until the amplitude converges; its
Sec. IV step-count finding needs it), default folder ``paper-newmark``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_force_option, add_json_option, check_outputs, maybe_write_json

#: the study's LCO solvers (names of torchrom.study.solvers.SOLVERS; the default first):
#: harmonic balance with a Newmark confirmation of a subset, or the paper's time marching
#: (the first is torchrom.paper.study.PAPER_METHOD, which this module does not import: the
#: command line parses without torch; tests/test_paper_study.py checks they agree)
PAPER_METHODS = ("hb", "newmark")

NAME = "paper"
HELP = "the paper's whole post-flutter LCO study: model, flutter, sweeps, figures, report.md"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="output folder (default: paper, or paper-quick with --quick)")
    parser.add_argument("--quick", action="store_true",
                        help="reduced study: coarser grids, shorter runs (a few minutes)")
    parser.add_argument("--method", choices=PAPER_METHODS, default=PAPER_METHODS[0],
                        help="LCOs by harmonic balance (hb, the default: certified periodic "
                             "orbits, a Newmark confirmation of a subset and the branches from "
                             "the flutter point) or by the paper's time marching (newmark)")
    parser.add_argument("--device", default="cpu", help="torch device of the LCO sweep")
    add_json_option(parser)
    add_force_option(parser)


def run(args: argparse.Namespace) -> int:
    import time

    from ..paper.study import FIGURE_FILES, run_paper
    from ..progress import info
    from ._common import torch_device

    out = args.out or Path(("paper-quick" if args.quick else "paper")
                           + ("" if args.method == PAPER_METHODS[0] else f"-{args.method}"))
    check_outputs(args, [])  # --json; the folder itself is checked by run_paper
    device = torch_device(args.device)
    t0 = time.perf_counter()
    info(f"torchrom paper{' --quick' if args.quick else ''} (method {args.method}): heavy "
         f"Goland wing study into {out}")
    summary = run_paper(out, quick=args.quick, force=args.force, device=str(device), log=info,
                        method=args.method)
    verdicts = [f["verdict"] for f in summary["findings"]]
    print(f"findings: {verdicts.count('agree')} agree, {verdicts.count('differ')} differ, "
          f"{len(verdicts) - verdicts.count('agree') - verdicts.count('differ')} not assessable")
    for name in FIGURE_FILES:
        if name in summary["figures"]:
            print(f"wrote {summary['figures'][name]}")
    print(f"wrote {out / 'report.md'}, {out / 'paper.json'} ({time.perf_counter() - t0:.0f} s)")
    maybe_write_json(args, summary)
    return 1 if summary["figures_failed"] else 0  # a figure failed: warned, the rest is kept
