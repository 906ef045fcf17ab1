"""Benchmark of the Goland wing aeroelastic ROM step (not run by the test suite).

    PYTHONPATH=. python benchmarks/bench_goland.py --rom ROM.npz --aero AERO.npz [--quick]
        [--no-scipy] [--compile] [--out benchmarks/results]

Model: the heavy Goland wing 9L12D ROM (n = 21: 9 linear + 12 dual modes) with the minimum-state
RFA (aerodynamics on the first 9 modes, 13 lag states), as the paper study builds it (the
``rom.npz`` and ``aero.npz`` of ``torchrom paper``'s Goland cache), assembled by
:func:`torchrom.study.cases.case_system` exactly as ``configs/paper_lco.toml`` does: altitudes
4000–11000 ft at Mach 0.70, γ ∈ {0, 1e-5, 1e-4, 5e-4, 1e-3} with the matched α(γ).

1. Throughput: µs per case-step for B ∈ {1, 64, 512, 2048}, float64 and float32, every case kept
   running (fixed work per step), one torch thread (a shared 2-core machine), for the settings
   of ``SETTINGS``:
   - ``paper-8``: the paper study's first setting, 8 modified-Newton iterations on the linear
     iteration matrix (it does not converge on the large-amplitude cases; B ≤ 64 only);
   - ``paper``: configs/paper_lco.toml, 2 Newton iterations, Jacobian refreshed every step;
   - ``newton-1``: one Newton correction per step, Jacobian refreshed every step, quadratic
     predictor (converges on every paper case);
   - ``fast``: one correction, Jacobian refreshed every 16 steps, quadratic predictor (accurate
     up to moderate amplitudes; where it is not, its error estimate flags the case).
   In the same run, the per-case time of one K3-sized GEMM (the (n, N3) cubic coefficients
   times B monomial vectors, N3 = 1771) and the ratio of the ``paper`` step to it
   (``kind = "k3_gemm"`` rows), with the step's dense multiply-adds in the same unit
   (``paper_dense_gemm_equivalents``, :func:`paper_step_gemm_equivalents`: a floor under the
   ratio).
2. Accuracy and SciPy: the hardest and a typical paper case are first brought near their LCO
   (``paper`` setting); from that common state [q, q̇, ξ] every setting integrates the same
   window and the amplitude of the tip deflection A_Tz over its last 3 s is compared with SciPy
   ``solve_ivp`` (Radau, analytic Jacobian) at rtol 1e-10. SciPy's cost is that of the
   loosest rtol at least as accurate as torchrom's ``newton-1``; torchrom's cost per case is its
   µs per case-step (B = 512 and B = 1, float64) times the window's steps.

Writes ``bench_goland.json`` and ``.csv`` (with the 1-min load average of every row).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from first_order import FirstOrderCase, scipy_amplitude  # noqa: E402
from results_io import write_results  # noqa: E402

from torchrom.aero.files import load_aero  # noqa: E402
from torchrom.rom import NonlinearROM  # noqa: E402
from torchrom.sim import HistoryRequest, LCOCriteria, Newmark  # noqa: E402
from torchrom.sim.metrics import history_metrics  # noqa: E402
from torchrom.study.cases import case_system  # noqa: E402
from torchrom.study.models import AeroelasticModel  # noqa: E402

DT = 1e-3
GAMMAS = (0.0, 1e-5, 1e-4, 5e-4, 1e-3)
SETTINGS = {
    "paper-8": {"iterations": 8, "refresh_every": 0},
    "paper": {"iterations": 2, "refresh_every": 1},
    "newton-1": {"iterations": 1, "refresh_every": 1, "predictor": "quadratic"},
    "fast": {"iterations": 1, "refresh_every": 16, "predictor": "quadratic"},
}
BATCHES = (1, 64, 512, 2048)


def case_grid(B: int) -> list[dict]:
    """B paper cases: a 4000–11000 ft altitude grid, γ cycling through GAMMAS, matched α."""
    alt = np.linspace(4000.0, 11000.0, B) if B > 1 else np.array([7000.0])
    return [{"altitude_ft": float(a), "gamma": GAMMAS[i % len(GAMMAS)], "alpha": "matched"}
            for i, a in enumerate(alt)]


def goland_cases(model: AeroelasticModel, cases: list[dict], dtype=torch.float64):
    return case_system(model, cases, dtype=dtype)[0]


def initial_state(B: int, n: int, amp: float = 0.1) -> np.ndarray:
    """The paper's start: mode 1 displaced by 0.1."""
    q0 = np.zeros((B, n))
    q0[:, 0] = amp
    return q0


def newmark(setting: str, **kw) -> Newmark:
    """The integrator of ``setting`` (``tol=1.0``: no case stops on its error estimate)."""
    cfg = {"startup_iterations": max(SETTINGS[setting]["iterations"], 2), "tol": 1.0,
           "threads": 1, **SETTINGS[setting], **kw}
    return Newmark(dt=DT, **cfg)


# ----------------------------------------------------------------------------------------------
def throughput(model, B: int, dtype, steps: int, setting: str, compile_=False,
               repeat: int = 2) -> float:
    """µs per case-step over ``steps`` steps after a short warm-up (every case kept running,
    ``tol=1.0`` and the same iterations from the first step: a fixed amount of work per step);
    the best of ``repeat`` runs (other processes on a shared machine only slow a run down)."""
    system = goland_cases(model, case_grid(B), dtype)
    integ = newmark(setting, check_every=min(500, steps), compile=compile_,
                    startup_iterations=SETTINGS[setting]["iterations"])
    run = {"q0": initial_state(B, model.rom.n), "lco": LCOCriteria(stop=False)}
    integ.run(system, t_end=min(steps, 50) * DT, **run)  # warm-up (and compilation)
    return min(integ.run(system, t_end=steps * DT, **run).us_per_case_step
               for _ in range(repeat))


def k3_gemm_us_per_case(n: int, B: int, dtype, repeat: int = 20) -> float:
    """µs per case of one K3-sized GEMM: the (n, N3) cubic coefficient matrix (N3 = n(n+1)(n+2)/6
    monomials) times B monomial vectors — the unit the step's cost is compared with; the best
    of ``repeat``."""
    import time

    n3 = n * (n + 1) * (n + 2) // 6
    gen = torch.Generator().manual_seed(0)
    A = torch.randn(n, n3, generator=gen, dtype=torch.float64).to(dtype)
    X = torch.randn(n3, B, generator=gen, dtype=torch.float64).to(dtype)
    A @ X  # warm-up
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        A @ X
        best = min(best, time.perf_counter() - t0)
    return 1e6 * best / B


def paper_step_gemm_equivalents(rom) -> float:
    """Multiply-adds of the dense products of one ``paper`` step, in K3-sized GEMMs per case:
    the step evaluates the nonlinear force with the Jacobian once (the stacked damping-matrix,
    quadratic-stiffness and tangent rows of :class:`torchrom.sim.forces.NonlinearForces` times
    x = [q; m2], plus the cubic force) and the force alone once more (damping-matrix and
    quadratic rows, plus the cubic force) — a floor under the step's ratio to one K3 GEMM
    before any per-case matrix-vector work, refreshed inverse or lag state."""
    from torchrom.sim.forces import NonlinearForces

    f = NonlinearForces(rom)
    n = rom.n
    k3 = n * (n * (n + 1) * (n + 2) // 6)
    cubic = f.K3_gathered.numel() if f.K3_gathered is not None else 0
    dense = (f.W_jacobian.numel() + cubic) + (f.W.numel() + cubic)
    return dense / k3


def window_amplitude(res, case: int, window: float) -> float:
    h = res.histories[case]
    sel = h.t >= h.t[-1] - window
    return history_metrics(h.t[sel], h.y[sel, 0], cycles=4)["amplitude"]


#: the accuracy cases: the largest LCO of the study (no damping nonlinearity, 4000 ft, about
#: 20 % of span), a small γ, a typical and the largest γ
ACCURACY_CASES = [{"altitude_ft": 4000.0, "gamma": 0.0}, {"altitude_ft": 4000.0, "gamma": 1e-5},
                  {"altitude_ft": 7000.0, "gamma": 1e-3}, {"altitude_ft": 10000.0, "gamma": 1e-4}]


def accuracy(model, n_cases: int, warm: float, T: float, window: float, scipy_cases,
             us_b512: float, us_b1: float, rtols) -> list[dict]:
    """Amplitude errors of every setting against a tight torchrom solution (6 Newton
    iterations, Jacobian every step: the same discrete equations solved to rounding) for all
    cases, and against SciPy Radau at rtol 1e-10 for the cases ``scipy_cases``."""
    cases = [{**c, "alpha": "matched"} for c in ACCURACY_CASES[:n_cases]]
    system = goland_cases(model, cases)
    pre = newmark("paper").run(system, initial_state(n_cases, model.rom.n), t_end=warm,
                               lco=LCOCriteria(stop=False))
    q0, v0, xi0 = pre.q, pre.v, pre.xi
    hist = HistoryRequest(tuple(range(n_cases)), every=1)
    ours = {}
    runs = ([("tight", torch.float64)] + [(s, torch.float64) for s in SETTINGS]
            + [("newton-1", torch.float32), ("fast", torch.float32)])
    for setting, dtype in runs:
        name = setting if dtype == torch.float64 else f"{setting}-float32"
        integ = (newmark("paper", iterations=6) if setting == "tight" else newmark(setting))
        res = integ.run(goland_cases(model, cases, dtype), q0, v0, xi0, t_end=T,
                        outputs=["A_Tz"], lco=LCOCriteria(stop=False), history=hist)
        ours[name] = ([window_amplitude(res, i, window) for i in range(n_cases)],
                      res.solver_error)
        tight = ours["tight"][0]
        errs = " ".join(f"{abs(a / t - 1):.1e}" for a, t in zip(ours[name][0], tight))
        est = " ".join(f"{e:.1e}" for e in res.solver_error)
        print(f"  {name}: amplitudes {np.round(ours[name][0], 6)}, vs tight {errs}, "
              f"estimated solver error {est}", flush=True)
    rows = [{"kind": "accuracy_vs_tight", **cases[i], "window_s": T,
             "tight_amplitude": ours["tight"][0][i],
             **{f"error_{k}": abs(a[i] / ours["tight"][0][i] - 1) for k, (a, _) in ours.items()},
             **{f"solver_error_{k}": float(e[i]) for k, (_, e) in ours.items()}}
            for i in range(n_cases)]
    steps = int(round(T / DT))
    for i in scipy_cases:
        case = FirstOrderCase(system, i)
        x0 = np.concatenate([q0[i], v0[i], xi0[i]])
        ref, ref_wall, _ = scipy_amplitude(case, x0, T, 1e-10, window, DT)
        errs = {k: abs(a[i] / ref - 1) for k, (a, _) in ours.items()}
        target = errs["newton-1"]
        tried, chosen = [], None
        for rtol in rtols:
            amp, wall, nfev = scipy_amplitude(case, x0, T, rtol, window, DT)
            err = abs(amp / ref - 1)
            tried.append({"rtol": rtol, "amplitude_error": err, "wall_s": wall, "nfev": nfev})
            if err <= target:
                chosen = tried[-1]
                break
        scipy_s = chosen["wall_s"] if chosen else float("nan")
        row = {"kind": "scipy", **cases[i], "window_s": T, "steps": steps,
               "reference_amplitude": ref, "reference_wall_s": ref_wall,
               **{f"error_{k}": e for k, e in errs.items()},
               **{f"solver_error_{k}": float(s[i]) for k, (_, s) in ours.items()},
               "scipy_rtol_matching": chosen["rtol"] if chosen else None,
               "scipy_s_per_case": scipy_s,
               "torchrom_s_per_case_B512": us_b512 * 1e-6 * steps,
               "torchrom_s_per_case_B1": us_b1 * 1e-6 * steps,
               "load_average_1min": os.getloadavg()[0], "scipy_runs": tried}
        row["ratio_scipy_over_torchrom_B512"] = scipy_s / row["torchrom_s_per_case_B512"]
        row["ratio_scipy_over_torchrom_B1"] = scipy_s / row["torchrom_s_per_case_B1"]
        rows.append(row)
        print(f"  case {cases[i]}: reference amplitude {ref:.6f}; errors "
              f"{({k: f'{e:.1e}' for k, e in errs.items()})}; SciPy rtol "
              f"{row['scipy_rtol_matching']} {scipy_s:.1f} s vs torchrom newton-1 "
              f"{row['torchrom_s_per_case_B512']:.3f} s (B=512) -> "
              f"{row['ratio_scipy_over_torchrom_B512']:.0f}x, "
              f"{row['ratio_scipy_over_torchrom_B1']:.1f}x (B=1)", flush=True)
    return rows


# ----------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rom", type=Path, required=True, help="the Goland rom.npz")
    ap.add_argument("--aero", type=Path, required=True, help="its aero.npz")
    ap.add_argument("--quick", action="store_true", help="fewer steps, cases and tolerances")
    ap.add_argument("--compile", action="store_true", help="also time torch.compile (B = 512)")
    ap.add_argument("--no-scipy", action="store_true", help="skip the accuracy/SciPy part")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    model = AeroelasticModel(NonlinearROM.load(args.rom), load_aero(args.aero))
    steps = ({1: 300, 64: 300, 512: 200, 2048: 100} if args.quick
             else {1: 2000, 64: 1000, 512: 500, 2048: 300})
    rows = []
    us = {}

    def record(**kw):
        kw["load_average_1min"] = os.getloadavg()[0]  # other processes distort timings
        rows.append(kw)
        print(f"  {kw}", flush=True)

    floor = paper_step_gemm_equivalents(model.rom)
    print(f"the paper step's dense products: {floor:.2f} K3-sized GEMMs per case (a floor under "
          "paper_over_gemm)", flush=True)
    print(f"throughput (torch {torch.__version__}, 1 thread)", flush=True)
    for dtype in (torch.float64, torch.float32):
        name = str(dtype).split(".")[-1]
        for B in BATCHES:
            for setting in SETTINGS:
                if setting == "paper-8" and B > 64:
                    continue  # 8x the work; its ratio is clear from the smaller batches
                us[setting, B, name] = throughput(model, B, dtype, steps[B], setting)
                record(kind="throughput", B=B, dtype=name, setting=setting,
                       us_per_case_step=us[setting, B, name])
            gemm = k3_gemm_us_per_case(model.rom.n, B, dtype)
            record(kind="k3_gemm", B=B, dtype=name, us_per_case=gemm,
                   paper_over_gemm=us["paper", B, name] / gemm,
                   paper_dense_gemm_equivalents=floor)
        if args.compile:
            v = throughput(model, 512, dtype, steps[512], "newton-1", compile_=True)
            record(kind="throughput", B=512, dtype=name, setting="newton-1, torch.compile",
                   us_per_case_step=v)

    acc = []
    if not args.no_scipy:
        print("accuracy and SciPy", flush=True)
        us64 = (us["newton-1", 512, "float64"], us["newton-1", 1, "float64"])
        # SciPy on the typical cases only: at rtol 1e-10 the largest LCO (γ = 0, 4000 ft)
        # would take SciPy tens of minutes (Radau resolves the stiff dual modes' transients)
        if args.quick:
            acc = accuracy(model, 3, 10.0, 3.0, 2.5, [2], *us64, [1e-4, 1e-6, 1e-8])
        else:
            acc = accuracy(model, 4, 30.0, 3.0, 2.5, [2, 3], *us64,
                           [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9])

    write_results(args.out, "bench_goland", rows, acc, "accuracy", "accuracy", threads=1,
                  dt=DT, quick=args.quick, rom=str(args.rom), aero=str(args.aero),
                  settings=SETTINGS, device="cpu (no GPU on this machine)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
