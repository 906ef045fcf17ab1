"""``torchrom sweep CONFIG.toml --out DIR``: run a TOML-defined grid of LCO simulations.

Writes ``DIR/results.parquet`` and ``DIR/results.csv`` (one row per case; columns in
:mod:`torchrom.study.table`), ``DIR/<y>_vs_<x>.png`` (the ``[plot]`` figure) and, when the
configuration asks for them (``[history]``), ``DIR/histories.parquet`` (case_id, t and one column
per output). With
``--json FILE`` the same rows are written as a JSON list of records (same keys and units as the
table columns; NaN as null). Existing outputs are never replaced without ``--force``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import InputError
from ..io import check_can_write
from ._common import add_force_option, add_json_option, maybe_write_json

NAME = "sweep"
HELP = "run a TOML-defined grid of batched LCO simulations; write a results table and a figure"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", type=Path, help="sweep configuration (TOML)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR",
                        help="output folder (results.parquet, results.csv, figure)")
    parser.add_argument("--device", default="cpu", help="torch device, e.g. cpu or cuda:0")
    parser.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                        help="floating-point precision of the integration (default float64)")
    parser.add_argument("--compile", action="store_true",
                        help="compile the time step with torch.compile (pays off for long runs)")
    parser.add_argument("--threads", type=int, default=None,
                        help="torch intra-op threads (default: automatic)")
    add_json_option(parser)
    add_force_option(parser)


def _device(name: str):
    import torch

    try:
        dev = torch.device(name)
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"--device: not a torch device: {name!r} ({exc})") from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"--device: {name} requested but CUDA is not available")
    return dev


def run(args: argparse.Namespace) -> int:
    # heavy imports here, not at module level: `torchrom --help` must stay fast
    import torch

    from ..study.config import load_sweep_config, with_overrides
    from ..study.plots import parameter_plot
    from ..study.sweep import run_sweep
    from ..study.table import table_paths, write_histories, write_table

    device = _device(args.device)
    dtype = getattr(torch, args.dtype)
    cfg = load_sweep_config(args.config)
    cfg = with_overrides(cfg, compile=True if args.compile else None, threads=args.threads)
    out = Path(args.out)
    paths = table_paths(out)
    figure = out / f"{cfg.plot.y}_vs_{cfg.plot.x}.png"
    hist_path = out / "histories.parquet"
    for p in (*paths.values(), figure, *([hist_path] if cfg.history else [])):
        check_can_write(p, args.force, "output")
    if args.json is not None:
        check_can_write(args.json, args.force, "JSON output")

    print(f"torchrom sweep: {len(cfg.cases)} cases of '{cfg.title}' ({args.config}) on "
          f"{device}/{args.dtype}, dt = {cfg.integrator.dt:g} s, t_end = {cfg.t_end:g} s")
    from tqdm import tqdm

    with tqdm(total=len(cfg.cases), unit="case", desc="cases done", file=sys.stderr,
              disable=None) as bar:
        def progress(done: int, total: int) -> None:
            bar.update(done - bar.n)

        histories = []
        table, timing = run_sweep(cfg, device=device, dtype=dtype, progress=progress,
                                  on_history=histories.append)

    written = write_table(table, out, force=args.force)
    if histories:
        written["histories"] = write_histories(histories, hist_path)
    parameter_plot(table, figure, x=cfg.plot.x, y=cfg.plot.y, hue=cfg.plot.hue,
                   title=cfg.title, force=args.force)
    counts = table["status"].value_counts().to_dict()
    print("status: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    print(f"time: {timing['wall_time_s']:.1f} s integrating, {timing['case_steps']} case-steps, "
          f"{timing['us_per_case_step']:.2f} us per case-step")
    for p in (*written.values(), figure):
        print(f"wrote {p}")
    maybe_write_json(args, table.to_dict(orient="records"))
    return 0
