"""Benchmark: the Newmark integrator's cost per case-step against the batch size B, on the
paper's own model and settings — where the throughput knee is (issue 36, item 4).

    PYTHONPATH=. python benchmarks/bench_batch_knee.py [--model DIR] [--steps N] [--out DIR]

Model: the quick paper pipeline's heavy Goland ROM (9L12D, 13 lag states; built into a
temporary folder, or reused from ``--model``, e.g. ``paper-quick/model``). Settings: the
``paper_lco.toml`` integrator (dt = 1 ms, two Newton iterations, Jacobian refreshed every step)
and outputs. Cases: the quick sweep's 24 cases repeated to B (so every B has the same mix of
linear and nonlinear cases), from the paper's small start, every case kept running for
``--steps`` steps (``LCOCriteria(stop=False)``) at the steady-state iteration count, after a
warm-up run, on one intra-op thread (what ``threads = "auto"`` picks for the study's sweeps
of up to ~80 cases); wall-clock and CPU time (CPU time: less sensitive to a loaded machine).

The knee is the smallest B whose cost per case-step is within :data:`KNEE_FACTOR` of the
cheapest measured (by wall and by CPU time). Writes
``benchmarks/results/bench_batch_knee.json`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402

from torchrom.paper.pipeline import goland_pipeline  # noqa: E402
from torchrom.paper.study import QUICK_PIPELINE, config_path  # noqa: E402
from torchrom.sim import LCOCriteria  # noqa: E402
from torchrom.study.cases import case_system, initial_displacement  # noqa: E402
from torchrom.study.config import load_sweep_config  # noqa: E402

BATCHES = (1, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512)
#: the knee: the smallest B within this factor of the cheapest cost per case-step
KNEE_FACTOR = 1.25


def cost_per_case_step(model, cfg, base, B: int, steps: int) -> tuple[float, float]:
    """(wall, CPU) µs per case-step of B cases (``base``, the system of ``cfg.cases``,
    repeated) over ``steps`` steps (after a 50-step warm-up)."""
    index = [i % len(cfg.cases) for i in range(B)]
    system = base.select(index)
    q0 = initial_displacement(model.rom, cfg.initial, [cfg.cases[i] for i in index])
    run = {"outputs": cfg.outputs, "lco": LCOCriteria(stop=False)}
    # steady state only: the first check interval's extra start-up iterations excluded
    integ = dataclasses.replace(cfg.integrator, startup_iterations=cfg.integrator.iterations,
                                check_every=min(cfg.integrator.check_every, steps), threads=1)
    integ.run(system, q0, t_end=50 * integ.dt, **run)
    c0 = time.process_time()
    res = integ.run(system, q0, t_end=steps * integ.dt, **run)
    cpu = 1e6 * (time.process_time() - c0) / (B * steps)
    return float(res.us_per_case_step), cpu


def knee(rows: list[dict], key: str) -> int:
    best = min(r[key] for r in rows)
    return min(r["B"] for r in rows if r[key] <= KNEE_FACTOR * best)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", type=Path, default=None,
                    help="the quick paper pipeline's folder (default: built in a temporary one)")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--batches", type=int, nargs="+", default=list(BATCHES))
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    cfg = load_sweep_config(config_path("paper_lco.toml"), "quick")
    with tempfile.TemporaryDirectory() as tmp:
        model = goland_pipeline(QUICK_PIPELINE, args.model or Path(tmp) / "model",
                                log=lambda m: None).model
        # the quick sweep's cases once (their matched α solved once), then repeated to B
        base, _ = case_system(model, cfg.cases, torch.device("cpu"), torch.float64)
        rows = []
        for B in args.batches:
            load = os.getloadavg()[0]
            us, cpu = cost_per_case_step(model, cfg, base, B, args.steps)
            rows.append({"kind": "throughput", "B": B, "us_per_case_step": us,
                         "cpu_us_per_case_step": cpu, "ms_per_step": us * B / 1e3,
                         "load_average_1min": load})
            print(f"B = {B:4d}: {us:7.1f} us per case-step ({cpu:7.1f} CPU), "
                  f"{us * B / 1e3:6.2f} ms per step (load {load:.1f})", flush=True)
    k, k_cpu = knee(rows, "us_per_case_step"), knee(rows, "cpu_us_per_case_step")
    print(f"knee: B = {k} by wall time, B = {k_cpu} by CPU time (within {KNEE_FACTOR:g}x of "
          f"the cheapest)")
    write_results(args.out, "bench_batch_knee", rows, [], "runs", "run", knee_batch=k,
                  knee_batch_cpu=k_cpu, knee_factor=KNEE_FACTOR, steps=args.steps, threads=1,
                  settings="paper_lco.toml [variants.quick], heavy Goland quick ROM")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
