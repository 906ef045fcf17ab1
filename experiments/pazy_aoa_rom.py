"""The Pazy wing's condensed ROM about its static aeroelastic equilibrium at a root angle of
attack (torchrom.trim.reduced: `torchrom flutter ROM AERO --aoa`), checked at every speed
against the FE's exact condensation at the same state (torchrom.trim.condensed: the FE solve
under the equilibrium's modal load, the tangent K_c = D + A S⁻¹ A), and beside the peers'
onsets and offsets (UM/NAST with skin, SHARPy without; tests/decks/.../SOURCE.md).

Build the ROM and its aero file first (docs/guide/pazy-aoa.md), e.g. with skin:

    D=tests/decks/aepw3_pazy_skin_flutter_tipmass1
    torchrom identify $D/sol145.dat --linear 10 --stiffness condensed --nonlinear-modes 5 \
        --linear-skin 10011 --amplitude 0.5 --out rom.npz
    torchrom aero $D/sol145.dat --mach 0.001 --modes 10 \
        --k 0.01 0.05 0.1 0.15 0.2 0.3 0.5 0.75 1.0 --out aero.npz
    PYTHONPATH=$PWD python experiments/pazy_aoa_rom.py --deck $D/sol145.dat --linear-skin 10011
        --rom rom.npz --aero aero.npz [--aoa 3,5,7] [--speeds 30,31,...] [--fe-aoa 5]
        [--out experiments/results/pazy_aoa_rom_skin.json]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from experiments.pazy_aoa_static import ROM_ENVELOPE_SHOWN

DENSITY, SEMISPAN = 1.225, 0.55


def tip_row(fe, Phi, grid: int) -> np.ndarray:
    """The T3 of ``grid`` (an RBE3's dependent grid, as the references' reference axis) in
    each mode: the ROM's tip deflection is this row times q (basic frame)."""
    row = fe.mesh.grid_row()[grid]
    return np.array([fe.expand(Phi[:, j])[row, 2] for j in range(Phi.shape[1])])


def run(args, progress=print) -> dict:

    from torchrom.aero.files import load_aero
    from torchrom.fe import read_bdf
    from torchrom.rom import NonlinearROM
    from torchrom.trim.flutter import boundaries
    from torchrom.trim.reduced import (
        SteadyModalAero,
        deformed_flutter,
        envelope_ratio,
        rom_equilibria,
        root_finder,
        tangent_structure,
    )

    rom, aero = NonlinearROM.load(args.rom), load_aero(args.aero)
    steady = SteadyModalAero.from_aero(aero, rom.n)
    fe = read_bdf(args.deck)
    Phi = fe.modes(rom.n).shapes
    # the ROM's basis must be the deck's modes, signs included: its max_mode1 point's row
    from torchrom.rom.points import rom_points

    grid, comp = rom_points(rom)["max_mode1"].lstrip("G").split(":T")
    dof = fe.dof_index(int(grid), int(comp))
    np.testing.assert_allclose(rom.outputs["max_mode1"], Phi[dof], rtol=1e-6, atol=1e-12)
    tip = tip_row(fe, Phi, args.tip_grid)
    from torchrom.rom.reference import reference_q, structural_force

    q_ref = reference_q(rom)   # a ROM about a deformed state: its coordinates are q − q_ref
    speeds = np.asarray(args.speeds)
    t0 = time.perf_counter()
    eq = rom_equilibria(rom, steady, args.aoa, speeds, DENSITY)
    res = {m: deformed_flutter(rom, eq, root_finder(m, rom, aero)) for m in ("state-space", "p-k")}
    out = {"rom": str(args.rom), "aoa_deg": list(args.aoa), "speeds": speeds.tolist(),
           "rom_seconds": time.perf_counter() - t0, "cases": []}
    pk = root_finder("p-k", rom, aero)
    from torchrom.identify.condensation import reference_equilibrium
    from torchrom.trim.condensed import deck_condensation, steady_load_law

    model = (deck_condensation(fe, Phi, rom.K1.numpy(), args.linear_skin) if args.fe_aoa
             else None)
    for a, aoa in enumerate(eq.aoa_deg):
        ok = eq.converged[a]
        case = {"aoa_deg": float(aoa),
                "tip_pct": [100 * float(tip @ (q + q_ref)) / SEMISPAN if c else None
                            for q, c in zip(eq.q[a], ok)],
                "envelope_ratio": [float(envelope_ratio(rom, q)) if c else None
                                   for q, c in zip(eq.q[a], ok)]}
        for m, r in res.items():
            case[m] = [{"kind": b.kind, "velocity": b.velocity, "frequency_hz": b.frequency_hz,
                        "tip_pct": 100 * float(tip @ (r.state_at(a, b) + q_ref)) / SEMISPAN}
                       for b in r.boundaries[a]]
        if model is not None and float(aoa) in args.fe_aoa:
            t = time.perf_counter()
            pts, fe_tip, rom_nat, fe_nat, u, p_fe = [], [], [], [], None, None
            for i, v in enumerate(speeds):
                if not ok[i]:
                    break
                # the exact condensation's load p from the ROM's state: A p = f(q) − D q, f the
                # ROM's whole structural force (about a deformed state f_ref + its change)
                x = eq.q[a, i]
                q_rom = x + q_ref
                f = structural_force(rom, x)
                # the FE continues from its own last state; the ROM's guess starts it
                p0 = np.linalg.solve(model.A, f - model.D @ q_rom) if p_fe is None else p_fe
                dyn = 0.5 * DENSITY * v**2
                if u is None:  # the first: its load continued from rest (one step from rest
                    # under the whole load can land the skeleton on another branch)
                    st = reference_equilibrium(model, steady_load_law(
                        steady, dyn, math.radians(aoa), rom.n))
                else:
                    st = model.equilibrium(steady, dyn, math.radians(aoa), p0, u)
                u, p_fe = st.u, st.p
                Kc = model.tangent(st)
                structure = tangent_structure(rom, st.q - q_ref)
                structure.K = Kc
                pts.append(pk(structure, float(v), DENSITY))
                fe_tip.append(100 * float(tip @ st.q) / SEMISPAN)
                fe_nat.append(pts[-1].natural_hz[:6].tolist())
                rom_nat.append(res["p-k"].points[a][i].natural_hz[:6].tolist())
                progress(f"  {aoa:g} deg, {v:g} m/s: tip ROM {case['tip_pct'][i]:.2f} %, FE "
                         f"{fe_tip[-1]:.2f} %; natural Hz ROM {np.round(rom_nat[-1][:5], 2)}, "
                         f"FE {np.round(fe_nat[-1][:5], 2)}; g ROM "
                         f"{res['p-k'].points[a][i].critical[0]:+.4f}, FE "
                         f"{pts[-1].critical[0]:+.4f}")
            case["fe"] = {"seconds": time.perf_counter() - t, "tip_pct": fe_tip,
                          "natural_hz": fe_nat, "rom_natural_hz": rom_nat,
                          "boundaries": [{"kind": b.kind, "velocity": b.velocity,
                                          "frequency_hz": b.frequency_hz,
                                          "tip_pct": float(np.interp(b.velocity,
                                                                     speeds[:len(fe_tip)],
                                                                     fe_tip))}
                                         for b in boundaries(pts)]}
        out["cases"].append(case)
    return out


REFS = Path(__file__).resolve().parents[1] / "tests" / "decks" / "aepw3_pazy_flutter_deformed"


def references() -> dict[str, np.ndarray]:
    """The peers' onsets and offsets of the skinned wing: name -> (aoa deg, speed m/s) rows
    (tests/decks/aepw3_pazy_flutter_deformed/SOURCE.md; the JA files are (speed, aoa))."""
    def ja(name):
        t = np.loadtxt(REFS / name, ndmin=2)[:, ::-1]
        return t[(t[:, 0] >= 0) & (t[:, 0] <= 7)]

    jfs = "UM_NAST_JFS2023_{}_vs_aoa_nf.txt"
    out = {"UM/NAST onset (non-follower)": np.loadtxt(REFS / jfs.format("onset")),
           "UM/NAST offset (non-follower)": np.loadtxt(REFS / jfs.format("offset")),
           "UM/NAST onset (follower, tip loss)": ja("UM_NAST_JA2023_onset_vs_aoa.txt"),
           "UM/NAST offset (follower, tip loss)": ja("UM_NAST_JA2023_offset_vs_aoa.txt")}
    exp = np.loadtxt(REFS / "experiment_flutter.txt", ndmin=2)
    out["tunnel onset (speed up)"] = exp[exp[:, 1] > 0][:, [0, 2]]
    out["tunnel, LCO stops (speed down)"] = exp[exp[:, 1] < 0][:, [0, 2]]
    sharpy = []
    for path in sorted(REFS.glob("sharpy_skin_on_flutter_speeds_alpha*.txt")):
        aoa = int(path.stem[-4:]) / 100
        sharpy += [(aoa, v) for v in np.loadtxt(path, ndmin=2)[:, 0] if v < 70]
    out["SHARPy (onset, offset)"] = np.array(sharpy)
    return out


def figure(cases: list[dict], path: Path, rom_flutter: dict | None = None) -> None:
    """Onset and offset against the root angle: torchrom's FE exact condensation beside the
    peers, and the ROM's (``rom_flutter``: the JSON of ``torchrom flutter ROM AERO --aoa``,
    its p-k boundaries; those past ``ROM_ENVELOPE_SHOWN`` times its solves' reach left out)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.8))
    styles = {"UM/NAST onset (non-follower)": "b-", "UM/NAST offset (non-follower)": "b--",
              "UM/NAST onset (follower, tip loss)": "c-",
              "UM/NAST offset (follower, tip loss)": "c--",
              "tunnel onset (speed up)": "k^", "tunnel, LCO stops (speed down)": "kv",
              "SHARPy (onset, offset)": "mx"}
    for name, t in references().items():
        ax.plot(t[:, 0], t[:, 1], styles[name], label=name, mfc="none")
    for kind, marker in (("onset", "s"), ("offset", "o")):
        pts = [(c["aoa_deg"], b["velocity"]) for c in cases if "fe" in c
               for b in c["fe"]["boundaries"] if b["kind"] == kind]
        if pts:
            a, v = np.array(pts).T
            ax.plot(a, v, "g" + marker, ms=8, label=f"torchrom FE exact condensation, {kind}")
        if rom_flutter is not None:
            pts = [(b["aoa_deg"], b["velocity"]) for b in rom_flutter["boundaries"]
                   if b["kind"] == kind and b["method"] == "p-k"
                   and not b.get("envelope_ratio", 0) > ROM_ENVELOPE_SHOWN]
            if pts:
                a, v = np.array(pts).T
                ax.plot(a, v, "r" + marker, ms=5, label=f"torchrom ROM about 5°, {kind}")
    ax.set(xlabel="root angle of attack (deg)", ylabel="speed (m/s)", ylim=(30, 80),
           title="Pazy wing with skin: flutter about the deformed wing")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--deck", type=Path)
    p.add_argument("--rom", type=Path)
    p.add_argument("--aero", type=Path)
    p.add_argument("--linear-skin", type=int, action="append", default=[])
    p.add_argument("--tip-grid", type=int, default=80000016,
                   help="the reference axis's tip grid, where the references read the tip")
    p.add_argument("--aoa", type=lambda s: [float(x) for x in s.split(",")],
                   default=[3.0, 5.0, 7.0])
    p.add_argument("--speeds", type=lambda s: [float(x) for x in s.split(",")],
                   default=[float(v) for v in np.arange(20.0, 70.01, 1.0)])
    p.add_argument("--fe-aoa", type=lambda s: [float(x) for x in s.split(",")], default=[])
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--figure", type=Path, default=None,
                   help="onset/offset against the root angle beside the peers")
    p.add_argument("--rom-flutter", type=Path, default=None,
                   help="also draw the ROM's p-k boundaries from this JSON of torchrom "
                        "flutter ROM AERO --aoa")
    p.add_argument("--from-json", type=Path, nargs="+", default=None,
                   help="tabulate and draw these results of earlier runs instead of running")
    args = p.parse_args(argv)
    if args.from_json:
        res = {"cases": [c for f in args.from_json for c in json.loads(f.read_text())["cases"]]}
        res["cases"].sort(key=lambda c: c["aoa_deg"])
    else:
        res = run(args)
    print("| AoA (°) | ROM p-k | ROM state space | FE exact condensation |")
    print("|---:|---|---|---|")

    def fmt(bs):
        return "; ".join(f"{b['kind']} {b['velocity']:.1f} m/s ({b['frequency_hz']:.1f} Hz, "
                         f"tip {b['tip_pct']:.1f} %)" for b in bs) or "none"
    for c in res["cases"]:
        fe = fmt(c["fe"]["boundaries"]) if "fe" in c else "-"
        print(f"| {c['aoa_deg']:g} | {fmt(c['p-k'])} | {fmt(c['state-space'])} | {fe} |")
    if args.figure:
        figure(res["cases"], args.figure,
               json.loads(args.rom_flutter.read_text()) if args.rom_flutter else None)
        print(f"figure: {args.figure}")
    if args.out and not args.from_json:
        args.out.write_text(json.dumps(res, indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
