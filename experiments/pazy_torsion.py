"""Pazy wing static torsion sweep (Riso & Cesnik, SciTech 2022 / J. Aircraft 2023): a tip mass of
0 … 3.25 kg 0.04 m behind the tip trailing edge under gravity; the tip's twist (from the
differential vertical positions of its leading and trailing edges) and displacements, self-weight
subtracted, torchrom's co-rotational full FE model against MSC Nastran SOL 400 / SOL 101, UM/NAST
(beam) and the Technion test (issue 45: torsion under large bending).

The deck is the bending sweep's (``experiments/pazy_static.py``) with one grid added 0.04 m
behind the trailing edge (x = 0.14 m) on the line of the rigid tip rod (y = 0.5568 m, as the
bending sweep's grid 61), tied by an RBE2 to the tip section's independent grid 2366, and the
mass's weight on it: a dead force on a turned arm (:mod:`torchrom.fe.dead_load`). Placed at the
tip section's own y = 0.5520 m instead, the linear tip deflection is 1.6 % below SOL 101's
(on the rod, 0.4 %). Twist: asin((z_LE − z_TE) / c) of the tip
section's grids 2138 (x = 0) and 2137 (x = 0.0989 m) at their deformed positions (the RBE2 arms
turned), less the self-weight's; displacements: grid 2366 (on the beam reference axis,
x = 0.043589 m), % of the 0.55 m semispan.

    PYTHONPATH=$PWD python experiments/pazy_torsion.py [--masses 0.5,1,2,3]
        [--out experiments/results/pazy_torsion.json] [--figure docs/guide/pazy_torsion.png]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from experiments.pazy_static import PAZY, PAZY_SEMISPAN, nonlinear_sweep, pazy_model

#: the added mass grid (0.04 m behind the 0.1 m chord's trailing edge) and its RBE2
MASS_GRID, MASS_RBE2, TIP_GRID = 9002, 9003, 2366
MASS_X = 0.14
#: the tip section's leading- and trailing-edge grids (dependent grids of the tip RBE2 7330)
LE_GRID, TE_GRID = 2138, 2137
EXTRA = (f"GRID,{MASS_GRID},,{MASS_X},5.568333-1,0.\n"
         f"RBE2,{MASS_RBE2},{TIP_GRID},123456,{MASS_GRID}\n")
#: reference sweeps (tests/decks/aepw3_pazy_noskin_rigidtip; SOURCE.md): twist (deg) and
#: displacements (vertical, axial, in-plane; % of the semispan) against the tip mass (kg)
REFERENCES = {
    "SOL 400": ("static_torsion_sweep_skin0_rot_GFEM.txt",
                "static_torsion_sweep_skin0_disp_GFEM.txt"),
    "SOL 101": ("static_torsion_sweep_skin0_rot_GFEM_linear.txt",
                "static_torsion_sweep_skin0_disp_GFEM_linear.txt"),
    "UM/NAST": ("static_torsion_sweep_skin0_rot_UM_NAST.txt",
                "static_torsion_sweep_skin0_disp_UM_NAST.txt"),
    "experiment": ("static_torsion_sweep_skin0_rot_exp.txt",
                   "static_torsion_sweep_skin0_disp_exp.txt"),
}


def reference(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(twist table (n, 2): kg, deg; displacement table (n, 2 or 4): kg, % semispan...)."""
    rot, disp = REFERENCES[name]
    return np.loadtxt(PAZY / rot, ndmin=2), np.loadtxt(PAZY / disp, ndmin=2)


def torsion_model():
    """The Pazy FE model with the torsion sweep's mass grid on its RBE2 arm."""
    return pazy_model(extra=EXTRA)


def tip_reading(fe, u: np.ndarray, u_weight: np.ndarray, large: bool = True) -> dict:
    """Twist (deg) and grid 2366's displacements (% of the semispan: vertical T3, axial T2,
    in-plane T1) of state ``u``, the self-weight state's subtracted. ``large``: a nonlinear
    state (the arms turned, the twist the asin of the edges' height difference over the chord);
    else a linear one (the linear elimination, the twist that difference over the chord, as
    SOL 101's sweep, which is proportional to the mass)."""
    def one(v):
        full = fe.expand(v, large=large)
        row = fe.mesh.grid_row()
        le, te = (fe.grid_xyz[row[g]] + full[row[g], :3] for g in (LE_GRID, TE_GRID))
        chord = np.linalg.norm(fe.grid_xyz[row[TE_GRID]] - fe.grid_xyz[row[LE_GRID]])
        sine = (le[2] - te[2]) / chord
        return np.degrees(np.arcsin(sine) if large else sine), full[row[TIP_GRID], :3]

    (tw, d), (tw0, d0) = one(u), one(u_weight)
    pct = 100.0 * (d - d0) / PAZY_SEMISPAN
    return {"twist_deg": float(tw - tw0), "vertical_pct": float(pct[2]),
            "axial_pct": float(pct[1]), "inplane_pct": float(pct[0])}


def sweep(masses, *, tol: float = 1e-7, progress=print) -> dict:
    """The nonlinear and linear sweeps' readings at ``masses`` (kg) and the wall time."""
    fe = torsion_model()
    res = nonlinear_sweep(fe, masses, tol=tol, progress=lambda line: None,
                          mass_grid=MASS_GRID)
    rows = []
    for m, u, ul in zip(res.masses, res.states, res.linear_states):
        rows.append({"mass_kg": float(m), **tip_reading(fe, u, res.u_weight),
                     "linear": tip_reading(fe, ul, res.u_linear_weight, large=False)})
        r = rows[-1]
        progress(f"  {m:5.2f} kg: twist {r['twist_deg']:6.3f} deg (linear "
                 f"{r['linear']['twist_deg']:6.3f}), vertical {r['vertical_pct']:8.3f} %, "
                 f"in-plane {r['inplane_pct']:7.3f} %")
    return {"rows": rows, "seconds": res.seconds, "iterations": res.iterations, "tol": tol}


def comparison(rows: list[dict]) -> list[dict]:
    """Each mass's twist and vertical displacement beside every reference's (interpolated)."""
    out = []
    refs = {name: reference(name) for name in REFERENCES}
    for r in rows:
        line = {"mass_kg": r["mass_kg"], "twist_deg": r["twist_deg"],
                "vertical_pct": r["vertical_pct"], "inplane_pct": r["inplane_pct"],
                "linear_twist_deg": r["linear"]["twist_deg"]}
        for name, (rot, disp) in refs.items():
            inside = rot[0, 0] <= r["mass_kg"] <= rot[-1, 0]
            line[f"{name} twist_deg"] = float(np.interp(r["mass_kg"], rot[:, 0], rot[:, 1])) \
                if inside else None
            line[f"{name} vertical_pct"] = float(np.interp(r["mass_kg"], disp[:, 0], disp[:, 1])) \
                if inside else None
        out.append(line)
    return out


def figure(table: list[dict], path: Path) -> None:
    """Twist and vertical tip displacement against the tip mass, torchrom beside the peers."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    m = [r["mass_kg"] for r in table]
    for name, style in (("SOL 400", "k-"), ("SOL 101", "k:"), ("UM/NAST", "b--"),
                        ("experiment", "ro")):
        rot, disp = reference(name)
        a.plot(rot[:, 0], rot[:, 1], style, label=f"{name}", mfc="none")
        b.plot(disp[:, 0], -disp[:, 1], style, label=f"{name}", mfc="none")
    a.plot(m, [r["twist_deg"] for r in table], "gs", label="torchrom FE (co-rotational)")
    a.plot(m, [r["linear_twist_deg"] for r in table], "g^", mfc="none", label="torchrom linear")
    b.plot(m, [-r["vertical_pct"] for r in table], "gs", label="torchrom FE (co-rotational)")
    a.set(xlabel="tip mass (kg)", ylabel="tip twist (deg)", title="Twist")
    b.set(xlabel="tip mass (kg)", ylabel="tip deflection, down (% of the semispan)",
          title="Vertical deflection")
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Pazy wing without skin: tip mass 0.04 m behind the trailing edge")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--masses", default=None,
                   help="tip masses (kg), default: SOL 400's (0.25 … 3.25 by 0.25)")
    p.add_argument("--tol", type=float, default=1e-7)
    p.add_argument("--out", type=Path, default=None, help="JSON of the measured sweep")
    p.add_argument("--figure", type=Path, default=None, help="PNG of the sweep")
    args = p.parse_args(argv)
    masses = reference("SOL 400")[0][1:, 0] if args.masses is None else \
        np.array([float(x) for x in args.masses.split(",")])
    t = time.perf_counter()
    res = sweep(masses, tol=args.tol)
    table = comparison(res["rows"])
    print(f"sweep: {len(masses)} masses in {res['seconds']:.1f} s "
          f"({time.perf_counter() - t:.1f} s with the model)")
    print("| tip mass (kg) | SOL 400 twist (°) | torchrom twist (°) | difference (°) | "
          "UM/NAST twist (°) | SOL 400 vertical (%) | torchrom vertical (%) | "
          "difference (% of semispan) |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")

    def fmt(x, spec=".3f"):
        return "" if x is None else format(x, spec)

    for r in table:
        ref_tw, ref_w = r["SOL 400 twist_deg"], r["SOL 400 vertical_pct"]
        print(f"| {r['mass_kg']:.2f} | {fmt(ref_tw)} | {r['twist_deg']:.3f} | "
              f"{fmt(None if ref_tw is None else r['twist_deg'] - ref_tw, '+.3f')} | "
              f"{fmt(r['UM/NAST twist_deg'])} | {fmt(ref_w)} | {r['vertical_pct']:.3f} | "
              f"{fmt(None if ref_w is None else r['vertical_pct'] - ref_w, '+.3f')} |")
    if args.figure:
        figure(table, args.figure)
        print(f"figure: {args.figure}")
    if args.out:
        args.out.write_text(json.dumps({**res, "table": table}, indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
