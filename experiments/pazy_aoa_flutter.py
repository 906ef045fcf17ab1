"""Flutter of the Pazy wing without skin about its static aeroelastic equilibrium at a root
angle of attack, by the full FE model's tangent ("SOL 400, then SOL 145 on its modes";
torchrom.trim.flutter): at each speed the nonlinear equilibrium under the steady loads, the
modes of K_T(u), and the p-k roots at that speed with the DLM on the undeformed boxes; onset
and offset speeds where a root's damping changes sign. Beside SHARPy's matched deformed-wing
flutter of the wing without skin (ngoiz/pazy-aepw3-results, 06_DeformedWingFlutter/
sharpy_skin_off; tests/decks/aepw3_pazy_static_aeroelastic/SOURCE.md).

    PYTHONPATH=$PWD python experiments/pazy_aoa_flutter.py [--aoa 0,3,5,7]
        [--speeds 30,32.5,...] [--out experiments/results/pazy_aoa_flutter.json]
        [--figure docs/guide/pazy_aoa_flutter.png]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from experiments.pazy_aoa_static import DENSITY, NOSKIN, REFS, _model, _tip_pct

#: modes in the p-k basis (the f06 flutter decks keep 10)
N_MODES = 10


def sharpy(aoa: float) -> np.ndarray:
    """SHARPy's (speed m/s, tip deflection / semispan) boundaries at ``aoa`` (deg), [] if none."""
    path = REFS / f"sharpy_skin_off_flutter_speeds_alpha{round(aoa * 100):04d}.txt"
    return np.loadtxt(path, ndmin=2) if path.exists() else np.zeros((0, 2))


def run(aoas, speeds, progress=print) -> dict:
    from torchrom.aero.nastran_flutter import load_deck
    from torchrom.trim.equilibrium import nonlinear_sweep
    from torchrom.trim.flutter import boundaries, spline_gaf, stability_at

    fe, op = _model(NOSKIN)
    t0 = time.perf_counter()
    gaf = spline_gaf(load_deck(NOSKIN, require_flutter=False), op)
    progress(f"GAFs of {len(op.grid_ids) * 6} spline DOFs at {len(gaf.k)} reduced frequencies: "
             f"{time.perf_counter() - t0:.0f} s")
    out = {"speeds": list(speeds), "cases": []}
    for aoa in aoas:
        t = time.perf_counter()
        points, tips = [], []
        for eq in nonlinear_sweep(fe, op, speeds, DENSITY, math.radians(aoa)):
            if not eq.converged:
                progress(f"  {aoa}°, {eq.velocity:g} m/s: no equilibrium ({eq.message})")
                break
            points.append(stability_at(fe, op, gaf, eq.u, eq.velocity, DENSITY, N_MODES))
            tips.append(_tip_pct(fe, eq.u, True))
            g, f = points[-1].critical
            progress(f"  {aoa}°, {eq.velocity:g} m/s: tip {tips[-1]:.2f} %, critical g "
                     f"{g:+.4f} at {f:.2f} Hz")
        found = boundaries(points)
        case = {"aoa_deg": aoa, "seconds": time.perf_counter() - t,
                "tip_pct": tips,
                "critical_damping": [p.critical[0] for p in points],
                "critical_frequency_hz": [p.critical[1] for p in points],
                "boundaries": [{"kind": b.kind, "velocity": b.velocity,
                                "frequency_hz": b.frequency_hz,
                                "tip_pct": float(np.interp(b.velocity, speeds[:len(tips)],
                                                           tips))} for b in found]}
        out["cases"].append(case)
        progress(f"{aoa}°: " + "; ".join(f"{b['kind']} {b['velocity']:.2f} m/s, "
                                          f"{b['frequency_hz']:.2f} Hz, tip {b['tip_pct']:.1f} %"
                                          for b in case["boundaries"])
                 + f" ({case['seconds']:.0f} s)")
    return out


def figure(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for case in res["cases"]:
        for b in case["boundaries"]:
            ax.plot(case["aoa_deg"], b["velocity"], "gs" if b["kind"] == "onset" else "gv",
                    mfc="none")
        s = sharpy(case["aoa_deg"])
        ax.plot([case["aoa_deg"]] * len(s), s[:, 0], "kx")
    ax.plot([], [], "gs", mfc="none", label="torchrom FE tangent, onset")
    ax.plot([], [], "gv", mfc="none", label="torchrom FE tangent, offset")
    ax.plot([], [], "kx", label="SHARPy (onset, offset, re-onset)")
    ax.set(xlabel="root angle of attack (deg)", ylabel="speed (m/s)",
           title="Pazy wing without skin: flutter about the deformed wing")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--aoa", default="0,3,5,7")
    p.add_argument("--speeds", default=",".join(f"{v:g}" for v in np.arange(30, 70.1, 2.5)))
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--figure", type=Path, default=None)
    args = p.parse_args(argv)
    res = run([float(a) for a in args.aoa.split(",")],
              [float(v) for v in args.speeds.split(",")])
    print("| AoA (°) | torchrom FE tangent | SHARPy (no skin) |")
    print("|---:|---|---|")
    for case in res["cases"]:
        ours = "; ".join(f"{b['kind']} {b['velocity']:.1f} m/s ({b['frequency_hz']:.1f} Hz, "
                         f"tip {b['tip_pct']:.1f} %)" for b in case["boundaries"])
        theirs = "; ".join(f"{v:.1f} m/s (tip {100 * w:.1f} %)"
                           for v, w in sharpy(case["aoa_deg"]))
        print(f"| {case['aoa_deg']:g} | {ours} | {theirs} |")
    if args.figure:
        figure(res, args.figure)
        print(f"figure: {args.figure}")
    if args.out:
        args.out.write_text(json.dumps(res, indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
