"""Benchmark (d): wall time of ``torchrom paper`` (quick and full) on this machine.

    PYTHONPATH=. python benchmarks/bench_paper.py [--quick-only] [--out benchmarks/results]

Runs the whole study from nothing (fresh folders: FE model, identification, aerodynamics,
flutter, every sweep, figures and report) once per form, with the command's defaults (harmonic
balance, certified; a second process where there are two cores) and records the wall and CPU
time of every stage as ``torchrom paper`` reports it, with the machine's load average, and the
sweeps' solver and certificate seconds (the stages apart from certification) — issue 36's limits
(:data:`LIMITS_S`) are 60 s for ``--quick`` and 150 s for the full study on 2 cores. A second
call of the quick form into the same folder measures the cached rerun. Writes
``benchmarks/results/bench_paper.json`` and ``.csv``. The peer, side by side: the quick study
from nothing in one process (``TORCHROM_PAPER_PROCESSES=1``; ``--no-peer`` skips it).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from results_io import machine_meta  # noqa: E402

from torchrom.paper.beside import ENV  # noqa: E402
from torchrom.paper.study import run_paper  # noqa: E402

#: issue 36's acceptance: --quick <= 60 s, the full study <= 150 s from nothing on a quiet
#: 2-core machine (issue 25's were 180 s and 900 s)
LIMITS_S = {"quick": 60.0, "full": 150.0}


def one_run(folder: Path, quick: bool, label: str) -> dict:
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    summary = run_paper(folder, quick=quick, log=lambda m: print(f"  [{label}] {m}", flush=True))
    wall = time.perf_counter() - t0
    return {"form": label, "wall_s": wall, "limit_s": LIMITS_S["quick" if quick else "full"],
            "within_limit": wall <= LIMITS_S["quick" if quick else "full"],
            "stages_s": summary["seconds"], "cpu_s": summary["cpu_seconds"],
            "lco_cases": summary["lco"]["cases"], "case_steps": summary["lco"]["case_steps"],
            "us_per_case_step": summary["lco"]["us_per_case_step"],
            # the sweeps' solver and certificate seconds (what a cheaper certificate saves)
            "sweeps": summary["sweeps"],
            "sweep_solver_s": sum(v["wall_time_s"] for v in summary["sweeps"].values()),
            "sweep_certificate_s": sum(v.get("certificate_s", 0.0)
                                       for v in summary["sweeps"].values()),
            "method": summary["method"], "processes": summary.get("processes", 1),
            "load_average_1min_start": load0, "load_average_1min_end": os.getloadavg()[0]}


@contextmanager
def one_process():
    """The study in one process (:data:`torchrom.paper.beside.ENV` = 1) for the block."""
    before = os.environ.get(ENV)
    os.environ[ENV] = "1"
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(ENV, None)
        else:
            os.environ[ENV] = before


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick-only", action="store_true", help="skip the full study")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--no-peer", action="store_true",
                    help="skip the one-process quick study (the peer of the two-process one)")
    ap.add_argument("--full-out", type=Path, default=None,
                    help="keep the full study's folder here (default: a temporary folder)")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        quick = Path(tmp) / "quick"
        rows.append(one_run(quick, True, "quick"))
        rows.append(one_run(quick, True, "quick, cached rerun"))
        if not args.no_peer:
            # the peer: the same quick study from nothing in one process (every stage in turn)
            with one_process():
                rows.append(one_run(Path(tmp) / "quick_one", True, "quick, one process"))
        if not args.quick_only:
            rows.append(one_run(args.full_out or Path(tmp) / "full", False, "full"))
    meta = machine_meta(python=platform.python_version())
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_paper.json").write_text(json.dumps({"meta": meta, "runs": rows},
                                                          indent=1))
    pd.DataFrame([{k: v for k, v in r.items() if not isinstance(v, dict)} for r in rows]).to_csv(
        args.out / "bench_paper.csv", index=False)
    for r in rows:
        print(f"{r['form']}: {r['wall_s']:.0f} s (limit {r['limit_s']:.0f} s), "
              f"{r['us_per_case_step']:.0f} us per case-step, sweeps "
              f"{r['sweep_solver_s']:.0f} s of which certificates {r['sweep_certificate_s']:.0f}"
              f" s, load {r['load_average_1min_end']:.1f}")
        for stage, sec in r["stages_s"].items():
            print(f"  {stage}: {sec:.1f} s wall, {r['cpu_s'][stage]:.1f} s CPU")
    print(f"wrote {args.out / 'bench_paper.json'}, {args.out / 'bench_paper.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
