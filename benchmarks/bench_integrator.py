"""Benchmark of the batched Newmark integrator against SciPy (not run by the test suite).

    PYTHONPATH=. python benchmarks/bench_integrator.py [--quick] [--compile] [--no-scipy]

Model: the synthetic Goland-like ROM of ``benchmarks/synthetic.py`` (21 modes: 9 linear + 12 dual,
energy-consistent K2/K3, exact Kelvin–Voigt D̄ tensors, 13 lag states; cases differ by a
dynamic-pressure scale, those above ≈ 0.4 flutter and settle on an LCO).

1. Throughput: µs per case-step for B ∈ {1, 64, 512}, float64 and float32, a fixed number of steps
   with every case active (dt = 1e-3, modified Newton, the default iteration count); for B = 512
   also one intra-op thread vs two, two worker processes with one thread each (the cases split
   in halves), and optionally torch.compile.
2. Against SciPy: a few flutter cases to their LCO. torchrom's amplitude (dt = 1e-3) and SciPy
   ``solve_ivp`` (Radau with the analytic Jacobian) at rtol 1e-3 … 1e-8 are compared with a tight
   reference (Radau, rtol 1e-10) on the same window; SciPy's time is the time of the loosest
   tolerance that is at least as accurate as torchrom. torchrom's time per case is its batched
   µs per case-step (B = 512, float64, one thread, with the 4 iterations these strongly
   nonlinear LCOs need; the throughput rows use the default 2) times the steps the case needs.

Writes ``benchmarks/results/bench_integrator.json`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from first_order import FirstOrderCase, scipy_amplitude  # noqa: E402
from results_io import write_results  # noqa: E402
from synthetic import synthetic_cases, synthetic_rom  # noqa: E402

from torchrom.sim import HistoryRequest, LCOCriteria, Newmark  # noqa: E402
from torchrom.sim.metrics import history_metrics  # noqa: E402

DT = 1e-3


def qbar_grid(B: int) -> np.ndarray:
    return np.linspace(0.05, 1.0, B)


def initial_state(B: int, amp: float = 0.05) -> np.ndarray:
    q0 = np.zeros((B, 21))
    q0[:, 0] = amp
    return q0


# ----------------------------------------------------------------------------------------------
# 1. throughput
# ----------------------------------------------------------------------------------------------
def throughput(B: int, dtype, steps: int, threads, compile_=False, qbar=None,
               iterations: int = 2) -> float:
    """µs per case-step over ``steps`` steps after a warm-up run (every case kept running)."""
    rom = synthetic_rom()
    qbar = qbar_grid(B) if qbar is None else qbar
    system = synthetic_cases(rom, qbar, dtype=dtype)
    integ = Newmark(dt=DT, threads=threads, compile=compile_, check_every=min(500, steps),
                    iterations=iterations, startup_iterations=iterations)
    run = {"q0": initial_state(len(qbar)), "lco": LCOCriteria(stop=False)}
    integ.run(system, t_end=min(steps, 200) * DT, **run)  # warm-up (and compilation)
    res = integ.run(system, t_end=steps * DT, **run)
    return res.us_per_case_step


def _worker(args):
    B, dtype_name, steps, lo, hi = args
    torch.set_num_threads(1)
    qbar = qbar_grid(B)[lo:hi]
    return throughput(hi - lo, getattr(torch, dtype_name), steps, 1, qbar=qbar)


def two_processes(B: int, dtype_name: str, steps: int) -> float:
    """Two single-thread worker processes, half the cases each, run at the same time."""
    ctx = mp.get_context("spawn")
    halves = [(B, dtype_name, steps, 0, B // 2), (B, dtype_name, steps, B // 2, B)]
    with ctx.Pool(2) as pool:
        t0 = time.perf_counter()
        per = pool.map(_worker, halves)
        wall = time.perf_counter() - t0
    # each worker's own µs/case-step covers its half; they ran concurrently
    return float(np.mean(per)) / 2, wall


# ----------------------------------------------------------------------------------------------
# 2. SciPy comparison
# ----------------------------------------------------------------------------------------------
def scipy_comparison(cases_qbar, quick: bool):
    rom = synthetic_rom()
    # torchrom's cost per case-step with the settings these LCOs need (4 iterations), batched
    us_per_case_step = throughput(512, torch.float64, 500, 1, iterations=4)
    print(f"  torchrom: {us_per_case_step:.2f} us per case-step (B = 512, float64, 1 thread, "
          f"4 iterations)", flush=True)
    rows = []
    for qb in cases_qbar:
        system = synthetic_cases(rom, np.array([qb]))
        q0 = initial_state(1, amp=0.1)
        # the LCO is strongly nonlinear (A_Tz ≈ 1.4): four iterations keep the default tol
        integ = Newmark(dt=DT, iterations=4)
        res = integ.run(system, q0, t_end=80.0, outputs=["A_Tz"],
                        lco=LCOCriteria(rtol=1e-3), history=HistoryRequest((0,), every=1))
        T = float(res.time[0])
        h = res.histories[0]
        window = min(4.0, T / 2)
        sel = h.t >= T - window
        ours = history_metrics(h.t[sel], h.y[sel, 0], cycles=4)["amplitude"]
        case = FirstOrderCase(system, 0)
        x0 = np.concatenate([q0[0], np.zeros(case.n + case.na)])
        ref, ref_wall, _ = scipy_amplitude(case, x0, T, 1e-10, window, DT)
        our_err = abs(ours / ref - 1)
        tried = []
        chosen = None
        for rtol in ([1e-3, 1e-4, 1e-6] if quick else [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]):
            amp, wall, nfev = scipy_amplitude(case, x0, T, rtol, window, DT)
            err = abs(amp / ref - 1)
            tried.append({"rtol": rtol, "amplitude_error": err, "wall_s": wall, "nfev": nfev})
            if err <= our_err and chosen is None:
                chosen = tried[-1]
        ours_s = us_per_case_step * 1e-6 * res.steps[0]
        scipy_s = chosen["wall_s"] if chosen else float("nan")
        rows.append({"qbar": qb, "status": str(res.status[0]), "t_lco_s": T,
                     "steps": int(res.steps[0]), "reference_amplitude": ref,
                     "torchrom_amplitude_error": our_err, "torchrom_s_per_case": ours_s,
                     "scipy_rtol_matching": chosen["rtol"] if chosen else None,
                     "scipy_s_per_case": scipy_s, "ratio_scipy_over_torchrom": scipy_s / ours_s,
                     "reference_wall_s": ref_wall, "scipy_runs": tried})
        print(f"  qbar {qb:.2f}: LCO at {T:.1f} s, torchrom error {our_err:.2e}, "
              f"SciPy {scipy_s:.1f} s (rtol {rows[-1]['scipy_rtol_matching']}), torchrom "
              f"{ours_s:.3f} s per case -> {scipy_s / ours_s:.0f}x", flush=True)
    return rows


# ----------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps and tolerances")
    ap.add_argument("--compile", action="store_true", help="also time torch.compile")
    ap.add_argument("--no-scipy", action="store_true", help="skip the SciPy comparison")
    ap.add_argument("--scipy-only", action="store_true",
                    help="keep the throughput rows of an earlier run in --out, redo SciPy")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    steps = {1: 200, 64: 500, 512: 500} if args.quick else {1: 1000, 64: 2000, 512: 2000}
    cpu = torch.get_num_threads()
    rows = []

    def record(**kw):
        kw["load_average_1min"] = os.getloadavg()[0]  # other processes distort timings
        rows.append(kw)
        print(f"  {kw}", flush=True)

    print(f"throughput (torch {torch.__version__}, {cpu} threads available)", flush=True)
    if args.scipy_only:
        rows = json.loads((args.out / "bench_integrator.json").read_text())["throughput"]
    for dtype in (torch.float64, torch.float32) if not args.scipy_only else ():
        name = str(dtype).split(".")[-1]
        for B in (1, 64, 512):
            us = throughput(B, dtype, steps[B], "auto")
            record(kind="throughput", B=B, dtype=name, mode="in-process, threads auto",
                   us_per_case_step=us)
        for th in (1, 2):
            us = throughput(512, dtype, steps[512], th)
            record(kind="throughput", B=512, dtype=name, mode=f"in-process, {th} thread(s)",
                   us_per_case_step=us)
        us, wall = two_processes(512, name, steps[512])
        record(kind="throughput", B=512, dtype=name, mode="2 processes x 1 thread",
               us_per_case_step=us, wall_s=wall)
        if args.compile:
            us = throughput(512, dtype, steps[512], 2, compile_=True)
            record(kind="throughput", B=512, dtype=name, mode="torch.compile, 2 threads",
                   us_per_case_step=us)

    scipy_rows = []
    if not args.no_scipy:
        print("SciPy comparison")
        scipy_rows = scipy_comparison([0.7, 1.0] if not args.quick else [1.0], args.quick)

    write_results(args.out, "bench_integrator", rows, scipy_rows, "scipy", "scipy", dt=DT)
    return 0


if __name__ == "__main__":
    sys.exit(main())
