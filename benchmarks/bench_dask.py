"""Benchmark (c): scaling of a sweep from in-process to a local Dask cluster of 1 and 2 workers.

    PYTHONPATH=. python benchmarks/bench_dask.py [--quick] [--cases N] [--t-end T]

The same sweep — the synthetic Goland-like ROM of ``benchmarks/synthetic.py`` (21 modes, 13 lag
states) at ``--cases`` dynamic-pressure scales from 0.05 to 1 (most of them flutter and settle on
an LCO), dt = 1e-3, every case integrated to ``--t-end`` (LCO stop disabled, so that every run
does exactly the same work) — goes through :func:`torchrom.study.runner.run_cases`:

1. in-process, one intra-op thread (the reference);
2. in-process, two intra-op threads (``--threads2``; on a busy machine threads that wait for
   each other at every small kernel can be catastrophically slow);
3. a LocalCluster of 1 single-threaded worker process;
4. a LocalCluster of 2 single-threaded worker processes (one per core).

The chunking is the same in every mode (``run_cases`` splits by cases only), so the tables must
be identical, and they are checked to be. Every row reports its start-up time (cluster and
workers up, torch imported and the ROM built in each process, a few warm-up steps) apart from
the sweep time; speed-up and parallel efficiency are against row 1.
Writes ``benchmarks/results/bench_dask.json`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from synthetic import synthetic_cases, synthetic_rom  # noqa: E402

from torchrom.sim import LCOCriteria, Newmark  # noqa: E402
from torchrom.study.runner import ChunkResult, open_executor, run_cases  # noqa: E402

DT = 1e-3


@functools.lru_cache(maxsize=1)
def benchmark_rom():
    """The synthetic ROM, built once per process (it takes ~0.5 s)."""
    return synthetic_rom()


@dataclass
class SyntheticTask:
    """One chunk of the benchmark sweep: cases {"qbar": ...} of the synthetic ROM."""

    t_end: float
    threads: int | str = 1

    def __call__(self, cases, case_ids, progress=None) -> ChunkResult:
        rom = benchmark_rom()
        qbar = np.array([c["qbar"] for c in cases])
        system = synthetic_cases(rom, qbar)
        q0 = np.zeros((len(cases), rom.n))
        q0[:, 0] = 0.05
        res = Newmark(dt=DT, threads=self.threads).run(
            system, q0, t_end=self.t_end, outputs=["A_Tz"], lco=LCOCriteria(stop=False),
            progress=progress)
        rows = pd.DataFrame({"case_id": case_ids, "qbar": qbar, "status": res.status,
                             "amplitude": res.amplitude[:, 0], "frequency_hz": res.frequency_hz,
                             "steps": res.steps})
        return ChunkResult(rows, res.wall_time_s, res.case_steps)


def warm_up() -> None:
    """Build the ROM and its kernels and take a few steps (imports, caches, allocator)."""
    SyntheticTask(0.02)([{"qbar": 0.5}, {"qbar": 0.6}], ["w0", "w1"])


def run_mode(name: str, cases, ids, t_end: float, workers: int | None, threads) -> dict:
    t0 = time.perf_counter()
    with open_executor(workers=workers) as executor:
        # start-up: cluster up, torch imported and the ROM built in every worker
        if workers:
            executor.client.run(warm_up)
        else:
            warm_up()
        startup = time.perf_counter() - t0
        t1 = time.perf_counter()
        table, stats = run_cases(SyntheticTask(t_end, threads), cases, ids,
                                 executor=executor)
        wall = time.perf_counter() - t1
    return {"mode": name, "workers": workers or 0, "threads_per_process": threads,
            "cases": len(cases), "chunks": stats.chunks, "case_steps": stats.case_steps,
            "startup_s": startup, "wall_s": wall,
            "us_per_case_step_wall": 1e6 * wall / stats.case_steps,
            "load_average_1min": os.getloadavg()[0], "table": table}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="64 cases, t_end 0.5 s")
    parser.add_argument("--cases", type=int, default=256)
    parser.add_argument("--t-end", type=float, default=2.0)
    parser.add_argument("--threads2", action="store_true",
                        help="also run in-process with two intra-op threads")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args(argv)
    if args.quick:
        args.cases, args.t_end = 64, 0.5
    qbar = np.linspace(0.05, 1.0, args.cases)
    cases = [{"qbar": float(q)} for q in qbar]
    ids = [f"q{k:05d}" for k in range(len(cases))]
    torch.set_num_threads(1)
    rows = [run_mode("in-process, 1 thread", cases, ids, args.t_end, None, 1)]
    if args.threads2:
        rows.append(run_mode("in-process, 2 threads", cases, ids, args.t_end, None, 2))
    rows += [run_mode("Dask LocalCluster, 1 worker", cases, ids, args.t_end, 1, 1),
             run_mode("Dask LocalCluster, 2 workers", cases, ids, args.t_end, 2, 1)]
    ref = rows[0]
    for r in rows:
        r["speedup_vs_in_process"] = ref["wall_s"] / r["wall_s"]
        r["parallel_efficiency"] = r["speedup_vs_in_process"] / max(r["workers"], 1)
        r["identical_to_in_process"] = bool(r["table"].equals(ref["table"]))
        r["max_rel_diff_amplitude"] = float(np.max(np.abs(
            r["table"]["amplitude"] / ref["table"]["amplitude"] - 1)))
    statuses = ref["table"]["status"].value_counts().to_dict()
    out = [{k: v for k, v in r.items() if k != "table"} for r in rows]
    meta = {"machine": platform.machine(), "cpus": os.cpu_count(), "torch": torch.__version__,
            "dt": DT, "t_end": args.t_end, "cases": args.cases, "statuses": statuses,
            "date": time.strftime("%Y-%m-%d %H:%M"), "load_average": list(os.getloadavg())}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_dask.json").write_text(json.dumps({"meta": meta, "rows": out},
                                                         indent=2) + "\n")
    pd.DataFrame(out).to_csv(args.out / "bench_dask.csv", index=False)
    for r in out:
        print(f"{r['mode']:32s} wall {r['wall_s']:7.2f} s  start-up {r['startup_s']:5.2f} s  "
              f"{r['us_per_case_step_wall']:6.2f} us/case-step  x{r['speedup_vs_in_process']:.2f}"
              f"  identical {r['identical_to_in_process']}")
    print(f"wrote {args.out / 'bench_dask.json'} and .csv")
    return 0


if __name__ == "__main__":
    # run as the importable module `bench_dask` (not `__main__`) so that Dask workers, which
    # get benchmarks/ on their sys.path, unpickle SyntheticTask by reference
    import bench_dask

    sys.exit(bench_dask.main())
