"""Cost of the co-rotational internal force and tangent on a Pazy-size model (not run by the
test suite).

    PYTHONPATH=. python benchmarks/bench_corotational.py [--steps 0] [--out benchmarks/results]

The model is synthetic, about the size of the Pazy wing (3,079 grids against its 3,152; 1,960
CQUAD4, 70 CTRIA3 against 168, 990 CBEAM). It has a 56 × 35 CQUAD4 plate, a tip strip of
70 CTRIA3, and a 990-element CBEAM spar on grids of its own, clamped at the root. The benchmark
times the model build, one internal force and one tangent (the least of three of each) at a
random state with rotations of about 0.01 rad.
With ``--steps N`` it also times a nonlinear static solve in N load steps under a tip load that
bends the plate to large rotations. Writes ``bench_corotational.json`` and ``.csv`` with the load
average.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import least_of, write_results  # noqa: E402

from tests.fe_decks import grid_lattice, model_of, new_deck  # noqa: E402

NX, NY, SPAN, CHORD, N_BEAM = 56, 35, 0.55, 0.1, 990


def pazy_size_deck():
    """The synthetic deck (SI units: aluminium plate 1 mm thick, a steel-like spar)."""
    m = new_deck()
    nid = grid_lattice(m, NX, NY, SPAN, CHORD)
    m.add_mat1(1, 7e10, None, 0.33, rho=2700.0)
    m.add_pshell(1, mid1=1, t=1e-3, mid2=1, mid3=1)
    eid = 1
    for i in range(NX):
        for j in range(NY):
            m.add_cquad4(eid, 1, [nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)])
            eid += 1
    tip = 100000
    for j in range(NY + 1):
        m.add_grid(tip + j, [SPAN + 0.01, CHORD * j / NY, 0.0])
    for j in range(NY):
        m.add_ctria3(eid, 1, [nid(NX, j), tip + j, tip + j + 1])
        m.add_ctria3(eid + 1, 1, [nid(NX, j), tip + j + 1, nid(NX, j + 1)])
        eid += 2
    m.add_pbeam(2, 1, [0.0], ["C"], [1e-4], [1e-8], [1e-8], [0.0], [2e-8])
    spar = 200000
    for i in range(N_BEAM + 1):
        m.add_grid(spar + i, [SPAN * i / N_BEAM, CHORD / 2, 0.01])
    for i in range(N_BEAM):
        m.add_cbeam(eid, 2, [spar + i, spar + i + 1], [0.0, 0.0, 1.0], None)
        eid += 1
    m.add_spc1(1, "123456", [nid(0, j) for j in range(NY + 1)] + [spar])
    return m, [tip + j for j in range(NY + 1)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=0, help="load steps of a static solve (0: none)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    deck, tip = pazy_size_deck()
    t = time.perf_counter()
    fe = model_of(deck, name="pazy_size")
    build = time.perf_counter() - t
    s = fe.summary()
    u = np.random.default_rng(0).normal(size=fe.n_dof) * 1e-2
    rows = [{"what": "build", "seconds": build},
            {"what": "internal_force", "seconds": least_of(lambda: fe.internal_force(u), 3)},
            {"what": "tangent_stiffness",
             "seconds": least_of(lambda: fe.tangent_stiffness(u), 3)}]
    runs = []
    if args.steps:
        # tip load of a few times the linear load for a tip deflection of a tenth of the span
        F = fe.nodal_load({(g, 3): 1.0 for g in tip})
        scale = 0.1 * SPAN / np.abs(fe.expand(fe.linear_static(F))[:, 2]).max()
        t = time.perf_counter()
        res = fe.static_solve(3.0 * scale * F, n_steps=args.steps)
        runs.append({"steps": args.steps, "seconds": time.perf_counter() - t,
                     "iterations": res.iterations, "converged": res.converged,
                     "tip_rotation_deg": float(np.degrees(np.abs(fe.expand(res.u)[:, 4]).max()))})
    for r in rows + runs:
        print(r)
    write_results(args.out, "bench_corotational", rows, runs, "static_runs", "static",
                  grids=s["grids"], free_dofs=s["free_dofs"], cquad4=s["CQUAD4"],
                  ctria3=s["CTRIA3"], cbeam=s["CBAR"])


if __name__ == "__main__":
    main()
