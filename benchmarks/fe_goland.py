"""Timings of the built-in FE on the heavy Goland wing (360 free DOFs).

Measures one internal-force evaluation (numpy API and differentiable torch API), one tangent
stiffness and one material tangent assembly (scipy.sparse), one nonlinear static solve (uniform
pressure of 500 lbf/ft², tip deflection ≈ 8 % of the span) and a 10-mode modal analysis.
Median of repeated runs; writes a JSON file (``--out``, default fe_goland.json).

    PYTHONPATH=$PWD python benchmarks/fe_goland.py --out fe_goland.json
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np
import torch

from torchrom.fe import goland


def median_ms(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="fe_goland.json")
    ap.add_argument("--repeat", type=int, default=50)
    args = ap.parse_args()
    t0 = time.perf_counter()
    fe = goland()
    build = time.perf_counter() - t0
    modes = fe.modes(9)
    u = modes.shapes @ np.array([2.0, 0.5, 0.2, 0.1, 0.1, 0.05, 0.05, 0.02, 0.02])
    ut = torch.tensor(u)
    F = fe.pressure_load(500.0)
    res = {
        "n_dof": fe.n_dof,
        "build_s": build,
        "internal_force_ms": median_ms(lambda: fe.internal_force(u), args.repeat),
        "internal_force_torch_ms": median_ms(lambda: fe.internal_force_torch(ut), args.repeat),
        "tangent_stiffness_ms": median_ms(lambda: fe.tangent_stiffness(u), args.repeat),
        "material_tangent_ms": median_ms(lambda: fe.material_tangent(u), args.repeat),
        "static_solve_ms": median_ms(lambda: fe.static_solve(F), max(args.repeat // 5, 3)),
        "static_newton_iterations": fe.static_solve(F).iterations,
        "modes_10_ms": median_ms(lambda: fe.modes(10), max(args.repeat // 5, 3)),
        "torch_threads": torch.get_num_threads(),
        "machine": platform.processor() or platform.machine(),
    }
    for k, v in res.items():
        print(f"{k:28s} {v:.4g}" if isinstance(v, float) else f"{k:28s} {v}")
    with open(args.out, "w") as fh:
        json.dump(res, fh, indent=2)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
