"""Benchmark: the demo sweep (configs/demo_vdp.toml), this tree against a baseline checkout.

    PYTHONPATH=. python benchmarks/bench_demo.py [--baseline DIR | --rev REV] [--repeats 3]
        [--steps 4000] [--out benchmarks/results]

Both trees run the same configuration (this tree's ``configs/demo_vdp.toml``), each as a whole
``python -m torchrom sweep CONFIG --out TMP --force`` process into a fresh folder (imports,
model, integration, certificates, table and figure: what a user waits for), alternating
baseline and current, ``--repeats`` times; min and median wall seconds per tree, the seconds
of integration the sweep reports, and the ratios baseline / current.
Then, per tree in a fresh process, the integrator alone: µs per batched step of the demo's
model and integrator settings at B = 1 (the tail of every chunk: a case at a Hopf point runs
to t_end alone) and B = 39 (the whole grid), every case kept running (``LCOCriteria(stop=
False)``), the best of 3 runs of ``--steps`` steps after a warm-up, alternating trees
``--repeats`` times (the best per tree kept, every sample written). The two results tables are
compared column by column (the largest relative difference of the numeric columns other than
timings; 0 when the numbers are the same bit for bit).

Baseline: ``--baseline DIR`` (any checkout of torchrom), else ``--rev`` (default cff45cc, the
commit before the per-step work) extracted with ``git archive`` into a temporary folder that is
removed afterwards (no git worktree is left behind). Writes ``bench_demo.json`` with the
machine and its load average: the wall times move with other work on the machine, the ratio
of alternating runs much less.
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

CONFIG = ROOT / "configs" / "demo_vdp.toml"
BATCHES = (1, 39)
#: table columns that are not results (timings, identities) and are left out of the comparison
NOT_COMPARED = {"case_id", "config_hash", "version", "precision"}

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


def sweep_wall(tree: Path, out: Path) -> tuple[float, float | None]:
    """(wall seconds, seconds integrating as the sweep reports them) of one demo sweep process
    running the code of ``tree``."""
    cmd = [sys.executable, "-m", "torchrom", "sweep", str(CONFIG), "--out", str(out), "--force"]
    t = time.perf_counter()
    proc = subprocess.run(cmd, env=_env(tree), cwd=tree, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(f"demo sweep of {tree} failed:\n{proc.stderr[-3000:]}")
    m = re.search(r"([\d.]+) s integrating", proc.stdout + proc.stderr)
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
    """Largest relative difference of the numeric result columns of two results tables, and
    whether the statuses agree."""
    ta, tb = pd.read_csv(a), pd.read_csv(b)
    diff = 0.0
    for col in ta.columns.intersection(tb.columns):
        if col in NOT_COMPARED or not pd.api.types.is_numeric_dtype(ta[col]):
            continue
        x, y = ta[col].to_numpy(float), tb[col].to_numpy(float)
        both = np.isfinite(x) & np.isfinite(y)
        if (np.isfinite(x) != np.isfinite(y)).any():
            diff = np.inf
        scale = np.abs(x[both]).max(initial=0.0) or 1.0
        diff = max(diff, float(np.abs(x[both] - y[both]).max(initial=0.0) / scale))
    return {"max_relative_difference": diff,
            "same_status": bool((ta["status"] == tb["status"]).all())}


def summary(walls: list[float]) -> dict:
    return {"runs_s": walls, "min_s": min(walls), "median_s": statistics.median(walls)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, default=None, help="a baseline checkout")
    ap.add_argument("--rev", default="cff45cc", help="baseline commit (without --baseline)")
    ap.add_argument("--repeats", type=int, default=3, help="sweeps per tree (alternating)")
    ap.add_argument("--steps", type=int, default=4000, help="steps per step-cost run")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args()
    if args.repeats < 1:
        ap.error("--repeats: expected >= 1")
    scratch = Path(tempfile.mkdtemp(prefix="bench_demo_"))
    try:
        base = args.baseline.resolve() if args.baseline else extract(args.rev, scratch / "base")
        trees = {"baseline": base, "current": ROOT}
        walls: dict[str, list[float]] = {k: [] for k in trees}
        integrating: dict[str, list[float]] = {k: [] for k in trees}
        for r in range(args.repeats):
            for name, tree in trees.items():
                # a fresh folder each time: a sweep reuses the finished parts of its --out
                out = scratch / f"out_{name}"
                shutil.rmtree(out, ignore_errors=True)
                wall, integ = sweep_wall(tree, out)
                walls[name].append(wall)
                if integ is not None:
                    integrating[name].append(integ)
                print(f"repeat {r + 1}: {name} {wall:.2f} s (integrating {integ} s)", flush=True)
        same = table_difference(scratch / "out_baseline" / "results.csv",
                                scratch / "out_current" / "results.csv")
        # the step costs alternate too; the best of the repeats per tree and batch size
        samples: dict[str, list[dict[str, float]]] = {k: [] for k in trees}
        for _ in range(args.repeats):
            for name, tree in trees.items():
                samples[name].append(step_costs(tree, args.steps))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    wall = {name: summary(w) | {"integrating_s": integrating[name]} for name, w in walls.items()}
    steps = {name: {b: min(x[b] for x in xs) for b in xs[0]} for name, xs in samples.items()}
    result = {
        "meta": machine_meta(config=str(CONFIG.relative_to(ROOT)), repeats=args.repeats,
                             baseline=str(args.baseline) if args.baseline else args.rev,
                             steps=args.steps),
        "wall": wall,
        "wall_ratio": {"min": wall["baseline"]["min_s"] / wall["current"]["min_s"],
                       "median": wall["baseline"]["median_s"] / wall["current"]["median_s"]},
        "integrating_ratio_min": (min(integrating["baseline"], default=np.nan)
                                  / min(integrating["current"], default=np.nan)),
        "us_per_step": steps,
        "us_per_step_samples": samples,
        "step_ratio": {b: steps["baseline"][b] / steps["current"][b] for b in steps["current"]},
        "tables": same,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "bench_demo.json"
    path.write_text(json.dumps(result, indent=1, default=float) + "\n")
    print(json.dumps({k: result[k] for k in ("wall_ratio", "integrating_ratio_min",
                                             "us_per_step", "step_ratio", "tables")}, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
