"""JAX/diffrax peer benchmark: Kvaerno5 under ``vmap`` on the Goland cases (not run by the tests).

    PYTHONPATH=. python benchmarks/bench_diffrax.py --rom ROM.npz --aero AERO.npz [--batch 64]

Needs the optional ``bench`` extra (jax, diffrax); exits with a message when they are absent.
Runs after ``bench_goland.py``: it takes that run's SciPy Radau reference amplitudes (rtol 1e-10)
and torchrom's ``newton-1`` errors from ``results/bench_goland.json``, rebuilds the same initial
states near the LCO (deterministic), and integrates ``--batch`` copies of each SciPy case with
diffrax's Kvaerno5 (ESDIRK, order 5, Newton with the autodiff Jacobian) under one ``jax.vmap``
at rtol 1e-4 … 1e-9 (atol = 1e-3 rtol, the SciPy setting). Reported per case: the loosest rtol
at least as accurate as torchrom, its wall time per case (compilation excluded) and the ratio
to torchrom's time per case. The right-hand side is the first-order form of
``first_order.FirstOrderCase`` (same force coefficients) in float64.

On a 2-core CPU the full 3-s windows of this script take hours (Kvaerno5 needs thousands of
steps per 0.2 s of this stiff system); run it where time allows.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))


def jax_rhs(case):
    """ẋ = F(x, p) of one case in jax.numpy; p holds the per-case matrices."""
    import jax.numpy as jnp

    n, nd = case.n, case.nd
    W, K3 = jnp.asarray(case.W), jnp.asarray(case.K3)
    pi, pj, p3, k3 = (jnp.asarray(a) for a in (case.pi, case.pj, case.p3, case.k3))
    expand = None if case.expand is None else jnp.asarray(case.expand)

    def rhs(t, x, p):
        q, v, xi = x[:n], x[n:2 * n], x[2 * n:]
        m2 = q[pi] * q[pj]
        U = W @ jnp.concatenate([q, m2])
        Dm = U[:nd] if expand is None else U[:nd][expand]
        f = p["gd"] * (v @ Dm.reshape(n, n)) + p["s"] * (U[nd:nd + n] + K3 @ (m2[p3] * q[k3]))
        acc = -p["Minv"] @ (p["C"] @ v + p["K"] @ q + f + p["D"] @ xi)
        return jnp.concatenate([v, acc, p["E"] @ v + p["R"] @ xi])

    return rhs


def batched_solver(term, T: float, ts, n: int, c_out, rtol: float):
    """jit(vmap) of Kvaerno5 from 0 to T: the output c_out·q at ``ts`` and the step count."""
    import diffrax
    import jax
    import jax.numpy as jnp

    ctrl = diffrax.PIDController(rtol=rtol, atol=rtol * 1e-3)
    save = diffrax.SaveAt(ts=jnp.asarray(ts))

    def solve(x, pp):
        sol = diffrax.diffeqsolve(term, diffrax.Kvaerno5(), 0.0, T, 1e-4, x, args=pp,
                                  saveat=save, stepsize_controller=ctrl, max_steps=2_000_000)
        return sol.ys[:, :n] @ c_out, sol.stats["num_steps"]

    return jax.jit(jax.vmap(solve))


def params(case) -> dict:
    return {"Minv": case.Minv, "C": case.C, "K": case.K, "D": case.D, "E": case.E, "R": case.R,
            "s": np.float64(case.s), "gd": np.float64(case.gamma * case.d)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rom", type=Path, required=True)
    ap.add_argument("--aero", type=Path, required=True)
    ap.add_argument("--batch", type=int, default=64, help="vmapped copies of each case")
    ap.add_argument("--results", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    try:
        import diffrax
        import jax
    except ImportError as exc:
        print(f"bench_diffrax: skipped, JAX/diffrax not installed ({exc}); "
              f"pip install -c constraints.txt -e '.[bench]'")
        return 0
    jax.config.update("jax_enable_x64", True)
    jax.config.update("jax_platforms", "cpu")
    import bench_goland as bg
    import jax.numpy as jnp
    import torch
    from first_order import FirstOrderCase

    from torchrom.aero.files import load_aero
    from torchrom.rom import NonlinearROM
    from torchrom.sim import LCOCriteria
    from torchrom.sim.metrics import history_metrics

    torch.set_num_threads(1)
    prior = json.loads((args.results / "bench_goland.json").read_text())
    scipy_rows = [r for r in prior["accuracy"] if r.get("kind") == "scipy"]
    if not scipy_rows:
        print("bench_diffrax: no SciPy rows in bench_goland.json: run bench_goland.py first")
        return 1
    meta = prior["meta"]
    model = bg.AeroelasticModel(NonlinearROM.load(args.rom), load_aero(args.aero))
    n_cases = len(bg.ACCURACY_CASES)
    cases = [{**c, "alpha": "matched"} for c in bg.ACCURACY_CASES[:n_cases]]
    system = bg.goland_cases(model, cases)
    warm = 10.0 if meta.get("quick") else 30.0
    pre = bg.newmark("paper").run(system, bg.initial_state(n_cases, model.rom.n), t_end=warm,
                                  lco=LCOCriteria(stop=False))
    us_b512 = next(r["us_per_case_step"] for r in prior["throughput"]
                   if r["B"] == 512 and r["dtype"] == "float64" and r["setting"] == "newton-1")
    out = []
    for row in scipy_rows:
        i = next(k for k, c in enumerate(cases)
                 if c["altitude_ft"] == row["altitude_ft"] and c["gamma"] == row["gamma"])
        case = FirstOrderCase(system, i)
        T, window = row["window_s"], 2.5
        ts = np.arange(T - window, T, bg.DT)
        x0 = np.concatenate([pre.q[i], pre.v[i], pre.xi[i]])
        p = params(case)
        B = args.batch
        pB = {k: jnp.asarray(np.broadcast_to(v, (B, *np.shape(v))).copy()) for k, v in p.items()}
        xB = jnp.asarray(np.broadcast_to(x0, (B, len(x0))).copy())
        term = diffrax.ODETerm(jax_rhs(case))
        c_out = jnp.asarray(np.asarray(model.rom.outputs["A_Tz"], dtype=float))
        target = row["error_newton-1"]
        tried = []
        for rtol in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9):
            fn = batched_solver(term, T, ts, case.n, c_out, rtol)
            t0 = time.perf_counter()
            jax.block_until_ready(fn(xB, pB))  # compilation
            compile_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            y, steps = jax.block_until_ready(fn(xB, pB))
            wall = time.perf_counter() - t0
            amp = history_metrics(ts, np.asarray(y[0]), cycles=4)["amplitude"]
            err = abs(amp / row["reference_amplitude"] - 1)
            tried.append({"rtol": rtol, "amplitude_error": err, "wall_s_per_case": wall / B,
                          "compile_s": compile_s, "steps": int(np.asarray(steps)[0])})
            print(f"  {cases[i]} rtol {rtol:g}: error {err:.1e} (torchrom {target:.1e}), "
                  f"{wall / B:.3f} s per case (B = {B}), {tried[-1]['steps']} steps, "
                  f"compile {compile_s:.0f} s", flush=True)
            if err <= target:
                break
        chosen = tried[-1] if tried[-1]["amplitude_error"] <= target else None
        ours = us_b512 * 1e-6 * row["steps"]
        out.append({**cases[i], "batch": B, "torchrom_newton1_error": target,
                    "torchrom_s_per_case_B512": ours,
                    "diffrax_rtol_matching": chosen["rtol"] if chosen else None,
                    "diffrax_s_per_case": chosen["wall_s_per_case"] if chosen else None,
                    "ratio_diffrax_over_torchrom": (chosen["wall_s_per_case"] / ours
                                                    if chosen else None),
                    "runs": tried})
    (args.results / "bench_diffrax.json").write_text(json.dumps(
        {"meta": {"jax": jax.__version__, "diffrax": diffrax.__version__, "batch": args.batch,
                  "date": time.strftime("%Y-%m-%d %H:%M")}, "cases": out},
        indent=2, default=float) + "\n")
    print(f"wrote {args.results / 'bench_diffrax.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
