"""Benchmark: the demo sweep (configs/demo_vdp.toml), this tree against a baseline checkout.

    PYTHONPATH=. python benchmarks/bench_demo.py [--baseline DIR | --rev REV] [--repeats 3]
        [--steps 4000] [--out benchmarks/results]

Each tree runs its own ``configs/demo_vdp.toml`` — the baseline's (time marching) and this
tree's (``method = "shooting"``: every LCO the certified discrete orbit) — and this tree runs it
once more with ``--method newmark`` (the same transients as the baseline, now with their
certificates), each as a whole ``python -m torchrom sweep CONFIG --out TMP --force`` process
into a fresh folder (imports, model, solve, certificates, table and figure: what a user waits
for), alternating, ``--repeats`` times; min and median wall seconds per run, the solver seconds
the sweep reports, and the ratios baseline / run.
Then, per tree in a fresh process, the integrator alone: µs per batched step of the demo's
model and integrator settings at B = 1 (the tail of every chunk: a case at a Hopf point runs
to t_end alone) and B = 39 (the whole grid), every case kept running (``LCOCriteria(stop=
False)``), the best of 3 runs of ``--steps`` steps after a warm-up, alternating trees
``--repeats`` times (the best per tree kept, every sample written). The results tables are
compared with the baseline's: statuses, and the largest relative difference of the LCO
amplitudes where both have one.

Baseline: ``--baseline DIR`` (any checkout of torchrom), else ``--rev`` (default fb9d981, the
tree when the certified-LCO issue was filed: its demo took 17–21 s on this 2-core machine, 41 s
in the issue's own measurement) extracted with ``git archive`` into a temporary folder that is
removed afterwards. Writes ``bench_demo.json`` with the machine and its load average: the wall
times move with other work on the machine, the ratio of alternating runs much less.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from results_io import machine_meta  # noqa: E402

#: the demo configuration, relative to a tree
CONFIG = Path("configs") / "demo_vdp.toml"
#: the sweeps timed: (label, tree name, extra command-line arguments)
RUNS = (("baseline", "baseline", ()), ("current", "current", ()),
        ("current-newmark", "current", ("--method", "newmark")))
BATCHES = (1, 39)

#: run in a fresh process with the tree on PYTHONPATH: µs per batched step of the demo's
#: integrator at the batch sizes of argv[3:], argv[1] the config, argv[2] the steps
STEP_TIMER = r"""
import json, sys, time
import numpy as np, torch
from torchrom.sim import LCOCriteria
from torchrom.study.config import load_sweep_config
from torchrom.study.cases import case_system, initial_displacement

cfg = load_sweep_config(sys.argv[1])
steps = int(sys.argv[2])
model = cfg.build_model()
out = {}
for B in map(int, sys.argv[3:]):
    system, _ = case_system(model, cfg.cases[:B], torch.device("cpu"), torch.float64)
    q0 = initial_displacement(model, cfg.initial, cfg.cases[:B])
    crit = LCOCriteria(stop=False)
    run = lambda n: cfg.integrator.run(system, q0=q0, t_end=n * cfg.integrator.dt, lco=crit)
    run(200)  # warm-up
    best = np.inf
    for _ in range(3):
        t = time.perf_counter()
        run(steps)
        best = min(best, time.perf_counter() - t)
    out[f"B{B}"] = 1e6 * best / steps
print(json.dumps(out))
"""


def extract(rev: str, into: Path) -> Path:
    """The tree of commit ``rev`` of this repository, written into ``into``."""
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def _env(tree: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(tree)}


def sweep_wall(tree: Path, out: Path, extra: tuple[str, ...] = ()) -> tuple[float, float | None]:
    """(wall seconds, solver seconds as the sweep reports them) of one demo sweep process
    running the code and the demo configuration of ``tree``."""
    cmd = [sys.executable, "-m", "torchrom", "sweep", str(CONFIG), "--out", str(out), "--force",
           *extra]
    t = time.perf_counter()
    proc = subprocess.run(cmd, env=_env(tree), cwd=tree, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(f"demo sweep of {tree} failed:\n{proc.stderr[-3000:]}")
    m = re.search(r"time: [\d.]+ s elapsed, ([\d.]+) s", proc.stdout + proc.stderr)
    return wall, float(m.group(1)) if m else None


def step_costs(tree: Path, steps: int) -> dict[str, float]:
    """µs per batched step at :data:`BATCHES` of the code of ``tree`` (fresh process)."""
    proc = subprocess.run([sys.executable, "-c", STEP_TIMER, str(CONFIG), str(steps),
                           *map(str, BATCHES)], env=_env(tree), cwd=tree, capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"step timing of {tree} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def table_difference(a: Path, b: Path) -> dict:
    """How the results table ``b`` differs from ``a``: the cases whose status differs, and the
    largest relative difference of the amplitudes where both found an LCO."""
    ta, tb = pd.read_csv(a), pd.read_csv(b)
    both = (ta["status"] == "lco") & (tb["status"] == "lco")
    x, y = ta.loc[both, "amplitude"].to_numpy(float), tb.loc[both, "amplitude"].to_numpy(float)
    changed = ta["status"] != tb["status"]
    return {"lco_cases_compared": int(both.sum()),
            "max_relative_amplitude_difference": float(np.max(np.abs(y / x - 1), initial=0.0)),
            "status_changes": [f"{ta.loc[i, 'alpha']:g}/{ta.loc[i, 'gamma']:g}: "
                               f"{ta.loc[i, 'status']} -> {tb.loc[i, 'status']}"
                               for i in np.flatnonzero(changed)]}


def summary(walls: list[float]) -> dict:
    return {"runs_s": walls, "min_s": min(walls), "median_s": statistics.median(walls)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, default=None, help="a baseline checkout")
    ap.add_argument("--rev", default="fb9d981", help="baseline commit (without --baseline)")
    ap.add_argument("--repeats", type=int, default=3, help="sweeps per run (alternating)")
    ap.add_argument("--steps", type=int, default=4000, help="steps per step-cost run")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args()
    if args.repeats < 1:
        ap.error("--repeats: expected >= 1")
    scratch = Path(tempfile.mkdtemp(prefix="bench_demo_"))
    try:
        base = args.baseline.resolve() if args.baseline else extract(args.rev, scratch / "base")
        trees = {"baseline": base, "current": ROOT}
        walls: dict[str, list[float]] = {label: [] for label, _, _ in RUNS}
        solving: dict[str, list[float]] = {label: [] for label, _, _ in RUNS}
        for r in range(args.repeats):
            for label, tree, extra in RUNS:
                # a fresh folder each time: a sweep reuses the finished parts of its --out
                out = scratch / f"out_{label}"
                shutil.rmtree(out, ignore_errors=True)
                wall, solver_s = sweep_wall(trees[tree], out, extra)
                walls[label].append(wall)
                if solver_s is not None:
                    solving[label].append(solver_s)
                print(f"repeat {r + 1}: {label} {wall:.2f} s (solver {solver_s} s)", flush=True)
        tables = {label: table_difference(scratch / "out_baseline" / "results.csv",
                                          scratch / f"out_{label}" / "results.csv")
                  for label, _, _ in RUNS[1:]}
        # the step costs alternate too; the best of the repeats per tree and batch size
        samples: dict[str, list[dict[str, float]]] = {k: [] for k in trees}
        for _ in range(args.repeats):
            for name, tree in trees.items():
                samples[name].append(step_costs(tree, args.steps))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    wall = {label: summary(w) | {"solver_s": solving[label]} for label, w in walls.items()}
    steps = {name: {b: min(x[b] for x in xs) for b in xs[0]} for name, xs in samples.items()}
    result = {
        "meta": machine_meta(config=str(CONFIG), repeats=args.repeats,
                             baseline=str(args.baseline) if args.baseline else args.rev,
                             steps=args.steps),
        "wall": wall,
        "wall_ratio": {label: {"min": wall["baseline"]["min_s"] / wall[label]["min_s"],
                               "median": wall["baseline"]["median_s"] / wall[label]["median_s"]}
                       for label, _, _ in RUNS[1:]},
        "us_per_step": steps,
        "us_per_step_samples": samples,
        "step_ratio": {b: steps["baseline"][b] / steps["current"][b] for b in steps["current"]},
        "tables_vs_baseline": tables,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "bench_demo.json"
    path.write_text(json.dumps(result, indent=1, default=float) + "\n")
    print(json.dumps({k: result[k] for k in ("wall_ratio", "us_per_step", "step_ratio",
                                             "tables_vs_baseline")}, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
