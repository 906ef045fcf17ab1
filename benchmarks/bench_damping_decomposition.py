"""The optimum damping decomposition and the criterion's SDP optimum on the quick study's Goland
9L12D ROMs, the methods of issue 48 beside their peers (not run by the tests).

    PYTHONPATH=. python benchmarks/bench_damping_decomposition.py [--work /tmp/bench_dd]
        [--variants updated calibrated] [--no-sdp] [--out benchmarks/results]

The ROMs are the quick study's model stage (``QUICK_PIPELINE`` of torchrom.paper.study, each
wing variant), built once into ``--work`` (cached there). Runs, side by side in this process on
one intra-op thread: the decomposition with (subset stages, whole-basis stage) solved by
(barrier, L-BFGS) — issue 48's: the batched barrier method of torchrom.identify.eigmax and the
soft minimum's L-BFGS with its analytic gradient —, by (barrier, Adam) and by (Adam, Adam), the
soft-minimum Adam ascents of the path before issue 48; each with seconds per stage, the
eigen-decompositions of the whole-basis stage, the smallest scaled eigenvalue after the
subsets, after the whole-basis stage and at the end, the enforcement, the K3 reproduction
error and the damping tensors' change from (Adam, Adam); and the SDP optimum
(torchrom.identify.damping_family.sdp_member's program) over the null-space coordinates ("now",
as the study runs it), beside the formulation before issue 48 ("before": an unnormalised zero
cone of the identified coefficients, 2,000 iterations, eps 1e-5): status, iterations, seconds,
t*, and λ_min of the solver's matrix and of the member after the exact projection onto the
identified coefficients (≤ t*: a feasible point). Writes ``bench_damping_decomposition.json``
and ``.csv``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402


def _rom(variant: str, work: Path):
    from torchrom.paper.pipeline import goland_pipeline
    from torchrom.paper.study import QUICK_PIPELINE

    base = dataclasses.replace(QUICK_PIPELINE, variant=variant)
    return goland_pipeline(base, work / f"model_{variant}", log=lambda s: None).model.rom


#: (subset solver, whole-basis solver): issue 48's, the subsets' barrier with the whole-basis Adam
#: ascent (the study's until the whole-basis L-BFGS), and the method before issue 48 (last)
SOLVERS = (("barrier", "lbfgs"), ("barrier", "adam"), ("adam", "adam"))


def _decomposition(rom, solver: str, whole: str) -> dict:
    from torchrom.identify import damping as dmp

    stage_s: dict[str, float] = {}
    originals = (dmp._optimise_stage, dmp._optimise_stage_barrier, dmp._enforce_psd,
                 dmp._optimise_whole_lbfgs)

    def timed(fn, key):
        def wrapper(*a, **k):
            t = time.perf_counter()
            out = fn(*a, **k)
            name = key(a)
            stage_s[name] = stage_s.get(name, 0.0) + time.perf_counter() - t
            return out
        return wrapper

    def stage_name(a):
        null = a[3]
        return ("whole" if len(null.subsets) == 1 and len(null.subsets[0]) == a[0].n
                else f"subsets of {len(null.subsets[0])}")

    dmp._optimise_stage = timed(originals[0], stage_name)
    dmp._optimise_stage_barrier = timed(originals[1], stage_name)
    dmp._enforce_psd = timed(originals[2], lambda a: "enforcement")
    dmp._optimise_whole_lbfgs = timed(originals[3], stage_name)
    try:
        t = time.perf_counter()
        d = dmp.optimum_decomposition(rom.K1.numpy(), rom.K2.numpy(), rom.K3.numpy(),
                                      dmp.DecompositionOptions(subset_solver=solver,
                                                               whole_solver=whole))
        total = time.perf_counter() - t
    finally:
        (dmp._optimise_stage, dmp._optimise_stage_barrier, dmp._enforce_psd,
         dmp._optimise_whole_lbfgs) = originals
    r = d.report
    return {"seconds": total, "stage_s": stage_s,
            "after_subsets": r["after_subsets"]["min_eigenvalue_scaled"],
            "after_whole": r["after_whole"]["min_eigenvalue_scaled"],
            "final": r["final"]["min_eigenvalue_scaled"],
            "whole_evaluations": r["stages"]["whole"].get("evaluations",
                                                          r["options"]["whole_iterations"]),
            "enforcement": r["enforcement"]["method"],
            "reproduction_error_K3": r["reproduction_error_K3"], "_D": (d.D2, d.D3)}


def _sdp_before(p, iterations: int = 2000, eps: float = 1e-5):
    """The peer: the SDP as it was before issue 48, class entries m and t under SCS with the
    identified coefficients as an unnormalised zero cone (a copy of that code)."""
    import numpy as np
    import scipy.sparse as sp
    import scs
    import torch

    st, alpha_hat, b, K1hat = p.st, p.alpha_hat, p.b, p.K1hat
    n = st.n
    N = n + n * (n + 1) // 2
    ncls = len(st.rows)
    nx = ncls + 1

    def vidx(i, j):
        return j * N - j * (j - 1) // 2 + (i - j)

    Az = sp.csr_matrix((alpha_hat, (st.group, np.arange(ncls))), shape=(st.n_groups, nx))
    lo, hi = np.maximum(st.rows, st.cols), np.minimum(st.rows, st.cols)
    scale = np.where(lo == hi, 1.0, np.sqrt(2.0))
    diag = np.array([vidx(i, i) for i in range(N)])
    Ap = sp.csr_matrix((np.concatenate([-scale, np.ones(N)]),
                        (np.concatenate([vidx(lo, hi), diag]),
                         np.concatenate([np.arange(ncls), np.full(N, ncls)]))),
                       shape=(N * (N + 1) // 2, nx))
    bp = np.zeros(N * (N + 1) // 2)
    for i in range(n):
        for j in range(i + 1):
            bp[vidx(i, j)] = K1hat[i, j] * (1.0 if i == j else np.sqrt(2.0))
    c = np.zeros(nx)
    c[-1] = -1.0
    data = {"A": sp.vstack([Az, Ap]).tocsc(), "b": np.concatenate([b, bp]), "c": c}
    t0 = time.perf_counter()
    sol = scs.SCS(data, {"z": st.n_groups, "s": [N]}, eps_abs=eps, eps_rel=eps,
                  max_iters=iterations, verbose=False).solve()
    m = torch.as_tensor(sol["x"][:ncls])
    return m, {"solver": "SCS", "status": sol["info"]["status"],
               "iterations": int(sol["info"]["iter"]), "seconds": time.perf_counter() - t0,
               "optimum_t": float(sol["x"][-1]), "eps": eps}


def _sdp(rom, how: str) -> dict:
    """The criterion's SDP on ``rom``: "before" (the peer) or "now" (issue 48's formulation,
    as sdp_member runs it)."""
    from torchrom.identify import damping as dmp
    from torchrom.identify import damping_family as fam

    with dmp._one_thread():
        p = dmp.decomposition_problem(rom.K1.numpy(), rom.K2.numpy(), rom.K3.numpy())
        if how == "before":
            m, rep = _sdp_before(p)
            rep["min_eigenvalue_scaled_solver"] = fam._min_eigenvalue(p, m)
        else:
            m, rep = fam._sdp_entries(p, fam.SDP_ITERATIONS, fam.SDP_EPS)
        mp = dmp._affine_projector(p.st, p.alpha_hat, p.b)(m)
        rep["min_eigenvalue_scaled_projected"] = fam._min_eigenvalue(p, mp)
    return rep


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/bench_damping_decomposition"))
    ap.add_argument("--variants", nargs="+", default=["updated", "calibrated"])
    ap.add_argument("--no-sdp", action="store_true", help="skip the SDP rows (minutes)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    import numpy as np

    rows, runs = [], []
    for variant in args.variants:
        rom = _rom(variant, args.work)
        res = {sw: _decomposition(rom, *sw) for sw in SOLVERS}
        D = {sw: r.pop("_D") for sw, r in res.items()}
        for (s, w), r in res.items():
            row = {"kind": "decomposition", "variant": variant, "subset_solver": s,
                   "whole_solver": w, **{k: v for k, v in r.items() if k != "stage_s"},
                   **{f"{k} s": v for k, v in r["stage_s"].items()}}
            if (s, w) != SOLVERS[-1]:  # the tensors' change from the method before issue 48
                row["D2 change vs adam"], row["D3 change vs adam"] = (
                    float(np.abs(a - b).max() / np.abs(b).max())
                    for a, b in zip(D[(s, w)], D[SOLVERS[-1]]))
            rows.append(row)
            print(row, flush=True)
        if not args.no_sdp and variant == args.variants[0]:
            for how in ("now", "before"):
                rep = _sdp(rom, how)
                run = {"kind": "sdp", "variant": variant, "formulation": how, **rep}
                runs.append(run)
                print(run, flush=True)
    write_results(args.out, "bench_damping_decomposition", rows, runs, "sdp_runs", "sdp",
                  python=sys.version.split()[0])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
