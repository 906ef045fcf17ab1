"""Benchmark: one sweep in-process and on a Dask cluster of separate processes (a scheduler and
2 workers), through the command line as a user runs it.

    PYTHONPATH=. python benchmarks/bench_dask_cluster.py [--quick] [--repeat R]

The model is read from a ROM file the script writes: two coupled Van der Pol–Duffing modes
(mode 1 flutters for α < γ; LCOs, decays and a few undecided cases), 256 cases (α × γ, 16 × 16;
``--quick``: 64), time marching at dt = 0.005 s to at most 40 s, every LCO certified. The
default chunking applies (no ``--chunk-size``): 256 cases make 8 chunks of 32
(:func:`torchrom.study.runner.plan_chunks`), enough for both workers.

The cluster is started once, as docs/guide/scale.md shows — ``dask scheduler`` and two ``dask
worker --nworkers 1 --nthreads 1`` processes in a folder of their own, with the guide's
``dask.yaml`` (tests/dask_processes.py) — and its workers warmed up (torch imported). Then, R
times in turn: ``torchrom sweep CFG --out A`` (in-process) and ``torchrom sweep CFG --out B
--scheduler ADDR``, each a fresh process. Recorded per run: the command's wall time
(``wall_s``: start-up, model, connect and version check, sweep, table, figure); the sweep's own
elapsed time from its ``time:`` line (``sweep_s``); the CPU seconds of the command
(``RUSAGE_CHILDREN``) plus, on the cluster, of the two worker processes
(``time.process_time`` in each, before and after); the 1-minute load average. The tables of
every run must be identical (same chunks, same numbers). Per mode the minimum over the repeats
(the run least disturbed by the machine's other load) and the median of the paired ratios
(in-process / cluster of the same round: speed-up > 1 means the cluster is faster).

Writes ``benchmarks/results/bench_dask_cluster.json`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402

from tests.dask_processes import DaskProcesses  # noqa: E402
from torchrom.rom.analytic import van_der_pol_duffing  # noqa: E402

CONFIG = """\
title = "two coupled Van der Pol-Duffing modes, from a ROM file"
[model]
rom = "model.npz"
[initial]
q0 = 0.5
[integrator]
dt = 0.005
t_end = 40.0
iterations = 3
predictor = "quadratic"
[lco]
rtol = 1e-3
[cases]
gamma = {{start = 1.0, stop = 3.0, num = {n}}}
alpha = {{start = 0.0, stop = 2.8, num = 16}}
"""
WORKERS = 2


def write_model(folder: Path, gammas: int) -> Path:
    """The ROM file and the sweep configuration; returns the configuration's path."""
    van_der_pol_duffing(frequencies_hz=[1.0, 2.3], c1=[-1.0, 0.1], d3=[1.0, 1.0],
                        k3=[0.5, 0.0], coupling=[[0.0, 4.0], [4.0, 0.0]]).save(
        folder / "model.npz")
    path = folder / "sweep.toml"
    path.write_text(CONFIG.format(n=gammas))
    return path


def children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def workers_cpu_s(cluster: DaskProcesses | None) -> float:
    if cluster is None:
        return 0.0
    return float(sum(cluster.client().run(time.process_time).values()))


def run_sweep(config: Path, out: Path, cluster: DaskProcesses | None) -> dict:
    """One ``torchrom sweep`` process (see the module docstring)."""
    cmd = [sys.executable, "-m", "torchrom", "sweep", str(config), "--out", str(out)]
    if cluster is not None:
        cmd += ["--scheduler", cluster.address]
    load = os.getloadavg()[0]
    cpu0, wcpu0 = children_cpu_s(), workers_cpu_s(cluster)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=out.parent)
    wall = time.perf_counter() - t0
    cpu = children_cpu_s() - cpu0 + workers_cpu_s(cluster) - wcpu0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{done.stdout}\n{done.stderr}")
    sweep = float(re.search(r"time: ([\d.]+) s elapsed", done.stdout).group(1))
    chunks = int(re.search(r"computed in (\d+) chunk", done.stdout).group(1))
    return {"mode": "in-process" if cluster is None else f"Dask cluster, {WORKERS} workers",
            "wall_s": wall, "sweep_s": sweep, "cpu_s": cpu, "chunks": chunks,
            "load_average_1min": load, "table": pd.read_parquet(out / "results.parquet")}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="64 cases (4 γ), not 256")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each mode, in turn")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args(argv)
    gammas = 4 if args.quick else 16
    with tempfile.TemporaryDirectory(prefix="bench_dask_cluster_") as tmp:
        work = Path(tmp)
        config = write_model(work, gammas)
        t0 = time.perf_counter()
        with DaskProcesses(work / "cluster") as cluster:
            cluster.start_scheduler()
            for k in range(WORKERS):
                cluster.start_worker(f"worker-{k + 1}")
            cluster.wait_for_workers(WORKERS)
            cluster.client().run(lambda: bool(__import__("torchrom.study.sweep")))
            startup = time.perf_counter() - t0
            runs = []
            for rep in range(args.repeat):
                for mode in (None, cluster):
                    r = run_sweep(config, work / f"out-{rep}-{'cluster' if mode else 'local'}",
                                  mode)
                    r["repeat"] = rep + 1
                    runs.append(r)
                    print(f"  repeat {rep + 1}/{args.repeat} {r['mode']}: command {r['wall_s']:.1f}"
                          f" s, sweep {r['sweep_s']:.1f} s, CPU {r['cpu_s']:.1f} s, load "
                          f"{r['load_average_1min']:.1f}", flush=True)
    reference = runs[0]["table"]
    identical = all(r["table"].equals(reference) for r in runs)
    statuses = reference["status"].value_counts().to_dict()
    local = [r for r in runs if r["mode"] == "in-process"]
    remote = [r for r in runs if r["mode"] != "in-process"]
    summary = []
    for rows in (local, remote):
        summary.append({
            "mode": rows[0]["mode"], "workers": 0 if rows is local else WORKERS,
            "chunks": rows[0]["chunks"], "repeats": len(rows),
            "wall_s": min(r["wall_s"] for r in rows), "sweep_s": min(r["sweep_s"] for r in rows),
            "cpu_s": min(r["cpu_s"] for r in rows),
            "speedup_wall_min": min(r["wall_s"] for r in local) / min(r["wall_s"] for r in rows),
            "speedup_sweep_min": (min(r["sweep_s"] for r in local)
                                  / min(r["sweep_s"] for r in rows)),
            "speedup_sweep_paired_median": float(np.median(
                [a["sweep_s"] / b["sweep_s"] for a, b in zip(local, rows, strict=True)])),
            "cpu_ratio_paired_median": float(np.median(
                [b["cpu_s"] / a["cpu_s"] for a, b in zip(local, rows, strict=True)])),
            "identical_to_in_process": identical,
            "load_average_1min_runs": [r["load_average_1min"] for r in rows]})
    per_run = [{k: v for k, v in r.items() if k != "table"} for r in runs]
    write_results(args.out, "bench_dask_cluster", summary, per_run, "runs", "run",
                  cases=len(reference), statuses=statuses, repeats=args.repeat,
                  cluster_startup_s=startup, workers=WORKERS,
                  command="PYTHONPATH=. python benchmarks/bench_dask_cluster.py"
                          + (" --quick" if args.quick else ""))
    for s in summary:
        print(f"{s['mode']:24s} {s['chunks']} chunks  command {s['wall_s']:6.1f} s  sweep "
              f"{s['sweep_s']:6.1f} s  CPU {s['cpu_s']:6.1f} s  speed-up (sweep, min) "
              f"{s['speedup_sweep_min']:.2f}x, paired median "
              f"{s['speedup_sweep_paired_median']:.2f}x  identical {s['identical_to_in_process']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
