"""The Pazy wing's static aeroelastic tip deflection against speed at a root angle of attack
(AePW-3; issue 45): torchrom's full FE, linear (as SOL 144: with and without skin) and
geometrically nonlinear (without skin, the steady loads on the undeformed boxes), beside
MSC Nastran SOL 144 / SOL 400, UM/NAST, SHARPy and the Technion test
(tests/decks/aepw3_pazy_static_aeroelastic/SOURCE.md).

Decks: with skin, ``aepw3_pazy_skin_flutter_tipmass1/sol145.dat`` (the flutter deck: its
panels, reference axis and beam spline; no tip mass, no gravity: the statics do not see the
mass); without skin, ``aepw3_pazy_noskin_rigidtip/sol144_noskin_tipmass.dat`` (the rigid-tip
GFEM with the same panels and spline, and the 10 g tip mass of the references' deformed-modes
GFEM, which the statics do not see either). At 7° the first five modes about each nonlinear
equilibrium, tracked from the undeformed ones, against that GFEM's (SOL 400 + modes).
Tip deflection: the reference axis's tip grid 80000016 (RBE3 to
the tip rib), % of the 0.55 m semispan; 1.225 kg/m³, Mach 0.

    PYTHONPATH=$PWD python experiments/pazy_aoa_static.py [--aoa 5,7] [--speeds 10,15,...]
        [--out experiments/results/pazy_aoa_static.json] [--figure docs/guide/pazy_aoa_static.png]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DECKS = ROOT / "tests" / "decks"
SKIN = DECKS / "aepw3_pazy_skin_flutter_tipmass1" / "sol145.dat"
NOSKIN = DECKS / "aepw3_pazy_noskin_rigidtip" / "sol144_noskin.dat"
#: the same with the 10 g tip mass of the references' deformed-modes GFEM (the statics without
#: gravity are those of NOSKIN; the modes need the mass)
NOSKIN_TIPMASS = DECKS / "aepw3_pazy_noskin_rigidtip" / "sol144_noskin_tipmass.dat"
REFS = DECKS / "aepw3_pazy_static_aeroelastic"
TIP, SEMISPAN, DENSITY = 80000016, 0.55, 1.225


def _table(name: str) -> np.ndarray:
    t = np.loadtxt(REFS / name, ndmin=2)
    return t[np.isfinite(t[:, 1])]


def references(aoa: int) -> dict[str, np.ndarray]:
    """Speed (m/s) → tip deflection (% of the semispan) of each peer at ``aoa`` degrees."""
    a = f"aoa{aoa}"
    out = {
        "SOL 144, skin": _table(f"static_aeroelastic_sweep_{a}_skin1_disp_GFEM_linear.txt"),
        "SOL 144, no skin": _table(f"static_aeroelastic_sweep_{a}_skin0_disp_GFEM_linear.txt"),
        "SOL 400, no skin": _table(f"static_aeroelastic_sweep_{a}_skin0_disp_GFEM.txt"),
        "UM/NAST, skin": _table(f"static_aeroelastic_sweep_{a}_skin1_disp_UM_NAST.txt"),
        "UM/NAST, no skin": _table(f"static_aeroelastic_sweep_{a}_skin0_disp_UM_NAST.txt"),
        "experiment, skin": _table(f"static_aeroelastic_sweep_{a}_skin1_disp_exp.txt"),
    }
    for skin, tag in (("skin", "w"), ("no skin", "wo")):
        s = _table(f"sharpy_{tag}_skin_alpha0{aoa}00.txt")  # metres at 50 % chord
        out[f"SHARPy, {skin}"] = np.column_stack([s[:, 0], 100.0 * s[:, 1] / SEMISPAN])
    return {k: v[:, :2] for k, v in out.items()}


def _model(path):
    from torchrom.aero.nastran_flutter import load_deck
    from torchrom.fe import read_bdf
    from torchrom.trim.operators import steady_operator

    fe = read_bdf(path)
    return fe, steady_operator(fe, load_deck(path, require_flutter=False), mach=0.0)


def _tip_pct(fe, u, large: bool) -> float:
    return 100.0 * fe.expand(u, large=large)[fe.mesh.grid_row()[TIP], 2] / SEMISPAN


#: tracked modes about each nonlinear equilibrium (the references' first five)
N_TRACKED = 5


def run(aoas, speeds, progress=print, modes_at: tuple[int, ...] = (7,)) -> dict:
    """torchrom's curves: linear with and without skin, nonlinear without skin; at the angles
    ``modes_at`` also the first five modes about each nonlinear equilibrium, tracked from the
    undeformed ones (:mod:`torchrom.trim.modes`)."""
    from torchrom.errors import ConvergenceError
    from torchrom.trim.equilibrium import linear_sweep, nonlinear_sweep
    from torchrom.trim.modes import tangent_modes

    out = {"speeds": list(speeds), "aoa_deg": list(aoas), "curves": {}, "seconds": {},
           "modes": {}}
    for label, path in (("skin", SKIN), ("no skin", NOSKIN_TIPMASS)):
        fe, op = _model(path)
        for aoa in aoas:
            t = time.perf_counter()
            lin = linear_sweep(fe, op, speeds, DENSITY, math.radians(aoa))
            out["curves"][f"torchrom FE linear, {label}, {aoa}"] = [
                _tip_pct(fe, e.u, False) if e.converged else None for e in lin]
            out["seconds"][f"linear, {label}, {aoa}"] = time.perf_counter() - t
            if label == "skin":
                continue  # the foil skin stops the nonlinear solutions (as in SOL 400)
            t = time.perf_counter()
            def show(e, fe=fe, aoa=aoa):
                tip = f"{_tip_pct(fe, e.u, True):.3f} %" if e.converged else "not converged"
                progress(f"  {aoa}°, {e.velocity:g} m/s: {tip}")

            nl = nonlinear_sweep(fe, op, speeds, DENSITY, math.radians(aoa), progress=show)
            out["curves"][f"torchrom FE nonlinear, {label}, {aoa}"] = [
                _tip_pct(fe, e.u, True) if e.converged else None for e in nl]
            out["seconds"][f"nonlinear, {label}, {aoa}"] = time.perf_counter() - t
            if aoa in modes_at:
                # tracked by continuity: each speed's modes against the last speed's (the
                # torsion mode's shape changes under large bending; against the undeformed
                # shapes it swaps with the fifth past a quarter of the span)
                ref = fe.modes(N_TRACKED).shapes
                rows = []
                for e in nl:
                    if not e.converged:
                        continue
                    try:
                        tm = tangent_modes(fe, e.u, N_TRACKED + 3, ref)
                    except ConvergenceError as exc:
                        progress(f"  modes at {e.velocity:g} m/s: {exc}")
                        continue
                    ref = tm.shapes[:, tm.tracked]
                    rows.append({"velocity": e.velocity, "tip_pct": _tip_pct(fe, e.u, True),
                                 "frequencies_hz": tm.tracked_frequencies().tolist(),
                                 "mac": tm.mac.tolist()})
                    progress(f"  modes at {e.velocity:g} m/s: "
                             + ", ".join(f"{f:.2f}" for f in rows[-1]["frequencies_hz"])
                             + " Hz")
                out["modes"][f"{label}, {aoa}"] = rows
    return out


#: the ROM's equilibria and boundaries drawn: those within this multiple of the identification
#: solves' reach (``envelope_ratio`` of ``flutter --aoa``)
ROM_ENVELOPE_SHOWN = 5.0


def rom_tips(rom_path: Path, flutter_json: Path, grid: int = TIP,
             envelope: float = ROM_ENVELOPE_SHOWN) -> dict[float, np.ndarray]:
    """The ROM's static tip deflection (% of the semispan at ``grid``, T3, from the mode
    shapes rom.npz keeps) at each angle's converged equilibria of ``torchrom flutter ROM AERO
    --aoa``'s JSON, those within ``envelope`` times the identification solves' reach:
    {aoa: rows of (speed, tip %, the tangent's natural frequencies (Hz)...)}."""
    from torchrom.rom import NonlinearROM

    rom = NonlinearROM.load(rom_path)
    row = int(np.flatnonzero(rom.shapes.grid_ids == grid)[0])
    tip = rom.shapes.phi[row, 2, :]
    q_ref = rom.reference.q if rom.reference is not None else np.zeros(rom.n)
    out: dict[float, list] = {}
    for e in json.loads(flutter_json.read_text())["equilibria"]:
        if e["converged"] and not e["envelope_ratio"] > envelope:
            pct = 100 * float(tip @ (q_ref + np.asarray(e["q"]))) / SEMISPAN
            out.setdefault(float(e["aoa_deg"]), []).append((e["velocity"], pct,
                                                            *e["natural_hz"]))
    return {a: np.array(v) for a, v in out.items()}


def figure(res: dict, path: Path, rom: dict[float, np.ndarray] | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    aoas = res["aoa_deg"]
    fig, axes = plt.subplots(1, len(aoas), figsize=(5.5 * len(aoas), 4.5), squeeze=False)
    styles = {"SOL 144, skin": ("k:", None), "SOL 144, no skin": ("0.5", ":"),
              "SOL 400, no skin": ("k-", None), "UM/NAST, skin": ("b--", None),
              "UM/NAST, no skin": ("c--", None), "SHARPy, skin": ("m-.", None),
              "SHARPy, no skin": ("r-.", None), "experiment, skin": ("ko", None)}
    V = np.asarray(res["speeds"], float)
    for ax, aoa in zip(axes[0], aoas):
        for name, table in references(aoa).items():
            fmt, ls = styles[name]
            kw = {"mfc": "none"} if fmt.endswith("o") else {}
            if ls:
                ax.plot(table[:, 0], table[:, 1], color=fmt, ls=ls, label=name)
            else:
                ax.plot(table[:, 0], table[:, 1], fmt, label=name, **kw)
        for key, marker in (("torchrom FE linear, skin", "gs"),
                            ("torchrom FE linear, no skin", "g^"),
                            ("torchrom FE nonlinear, no skin", "gD")):
            y = res["curves"].get(f"{key}, {aoa}")
            if y is not None:
                y = np.array([np.nan if v is None else v for v in y])
                ax.plot(V, y, marker, mfc="none" if "linear," in key else None, label=key)
        if rom and float(aoa) in rom:
            t = rom[float(aoa)]
            ax.plot(t[:, 0], t[:, 1], "r-", lw=2, alpha=0.7,
                    label="torchrom ROM about 5°, 45 m/s, skin")
        ax.set(xlabel="speed (m/s)", ylabel="tip deflection (% of the semispan)",
               title=f"root angle of attack {aoa}°", xlim=(0, V.max() + 5), ylim=(0, 60))
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Pazy wing: static aeroelastic tip deflection (1.225 kg/m³, no gravity)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def rom_modes(rom_path: Path, flutter_json: Path, aoa: float, grid: int = TIP,
              envelope: float = ROM_ENVELOPE_SHOWN) -> tuple[np.ndarray, np.ndarray]:
    """The ROM's tangent frequencies (Hz) against its tip deflection (% of the semispan) at
    ``aoa`` (:func:`rom_tips`): (tip (P,), frequencies (P, n))."""
    rows = rom_tips(rom_path, flutter_json, grid, envelope).get(float(aoa), np.zeros((0, 2)))
    return rows[:, 1], rows[:, 2:]


def modes_figure(res: dict, path: Path, aoa: int = 7, skinned: dict | None = None) -> None:
    """The first five frequencies against the tip deflection at ``aoa``: torchrom's FE tangent
    beside the GFEM's SOL 400 + modes and UM/NAST (non-follower); with ``skinned`` (``fe``:
    the FE exact condensation's (tip, frequencies) of the skinned wing, ``rom``: the ROM's)
    a second panel for the wing with skin, which no peer gives."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = res["modes"][f"no skin, {aoa}"]
    tip = [r["tip_pct"] for r in rows]
    f = np.array([r["frequencies_hz"] for r in rows])
    gfem = np.loadtxt(REFS / f"modal_deformed_aoa{aoa}_GFEM_sweep.txt")
    um = np.loadtxt(REFS / f"modal_deformed_aoa{aoa}_UM_NAST_sweep_nf.txt")
    fig, axes = plt.subplots(1, 2 if skinned else 1, figsize=(12 if skinned else 6.5, 4.5),
                             squeeze=False)
    ax = axes[0][0]
    names = ("1st bending", "1st in-plane", "1st torsion", "2nd bending", "5th")
    for j, name in enumerate(names[:4]):
        c = f"C{j}"
        ax.plot(gfem[:, 1], gfem[:, 2 + j], "-", color=c, label=f"SOL 400 GFEM, {name}")
        ax.plot(um[:, 1], um[:, 2 + j], ":", color=c)
        ax.plot(tip, f[:, j], "s", color=c, mfc="none")
    ax.plot([], [], "k:", label="UM/NAST (non-follower)")
    ax.plot([], [], "ks", mfc="none", label="torchrom FE tangent")
    ax.set(xlabel="tip deflection (% of the semispan)", ylabel="frequency (Hz)",
           title=f"without skin at {aoa}°: modes of the deformed wing")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    if skinned:
        ax = axes[0][1]
        t_fe, f_fe = skinned["fe"]
        t_rom, f_rom = skinned["rom"]
        for j in range(min(4, f_fe.shape[1], f_rom.shape[1] if f_rom.size else 4)):
            c = f"C{j}"
            ax.plot(t_fe, f_fe[:, j], "o", color=c, mfc="none")
            if f_rom.size:
                ax.plot(t_rom, f_rom[:, j], "-", color=c)
        ax.plot([], [], "ko", mfc="none", label="torchrom FE exact condensation (10 modes)")
        ax.plot([], [], "k-", label="torchrom ROM about 5°, 45 m/s")
        ax.set(xlabel="tip deflection (% of the semispan)", ylabel="frequency (Hz)",
               title=f"with skin at {aoa}°: the tangent's first four frequencies",
               xlim=(10, 40), ylim=(0, 100))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def skinned_modes(fe_json: Path, rom_path: Path | None, flutter_json: Path | None,
                  aoa: float = 7.0) -> dict:
    """The skinned wing's tangent frequencies at ``aoa`` against its tip: the FE exact
    condensation's from experiments/pazy_aoa_rom.py's JSON, the ROM's from its flutter JSON."""
    case = next(c for c in json.loads(fe_json.read_text())["cases"]
                if float(c["aoa_deg"]) == float(aoa) and "fe" in c)
    fe = (np.asarray(case["fe"]["tip_pct"], float), np.asarray(case["fe"]["natural_hz"], float))
    rom = rom_modes(rom_path, flutter_json, aoa) if rom_path else (np.zeros(0), np.zeros((0, 0)))
    return {"fe": fe, "rom": rom}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--aoa", default="5,7", help="root angles of attack (deg)")
    p.add_argument("--speeds", default="10,15,20,25,30,35,40,45,50,55,60", help="m/s")
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--figure", type=Path, default=None)
    p.add_argument("--modes-figure", type=Path, default=None,
                   help="PNG of the 7° modes against the tip deflection")
    p.add_argument("--rom-flutter", type=Path, nargs=2, default=None,
                   metavar=("ROM.npz", "FLUTTER.json"),
                   help="also draw this ROM's equilibria from its flutter --aoa JSON")
    p.add_argument("--skinned-fe", type=Path, default=None, metavar="JSON",
                   help="experiments/pazy_aoa_rom.py's JSON with the FE exact condensation at "
                        "7°: the modes figure's second panel (with skin), beside --rom-flutter")
    p.add_argument("--from", dest="source", type=Path, default=None, metavar="JSON",
                   help="take the results from an earlier run's --out instead of solving")
    args = p.parse_args(argv)
    if args.source is not None:
        res = json.loads(args.source.read_text())
        aoas, speeds = res["aoa_deg"], res["speeds"]
    else:
        aoas = [int(a) for a in args.aoa.split(",")]
        speeds = [float(v) for v in args.speeds.split(",")]
        res = run(aoas, speeds)
    for aoa in aoas:
        refs = references(aoa)
        print(f"| {aoa}° | V (m/s) | FE linear, skin | SOL 144, skin | FE linear, no skin | "
              "SOL 144, no skin | FE nonlinear, no skin | SOL 400, no skin | UM/NAST, skin | "
              "experiment, skin |")
        print("|---|" + "---:|" * 9)
        for k, V in enumerate(speeds):
            def ref(name, V=V, refs=refs):
                t = refs[name]
                return f"{np.interp(V, t[:, 0], t[:, 1]):.3f}" if t[0, 0] <= V <= t[-1, 0] \
                    else ""

            def ours(key, k=k, aoa=aoa):
                y = res["curves"].get(f"{key}, {aoa}")
                return "" if y is None or y[k] is None else f"{y[k]:.3f}"
            print(f"| | {V:g} | {ours('torchrom FE linear, skin')} | {ref('SOL 144, skin')} | "
                  f"{ours('torchrom FE linear, no skin')} | {ref('SOL 144, no skin')} | "
                  f"{ours('torchrom FE nonlinear, no skin')} | {ref('SOL 400, no skin')} | "
                  f"{ref('UM/NAST, skin')} | {ref('experiment, skin')} |")
    print("seconds:", {k: round(v, 1) for k, v in res["seconds"].items()})
    for key, rows in res["modes"].items():
        gfem = np.loadtxt(REFS / f"modal_deformed_aoa{key.split(', ')[1]}_GFEM_sweep.txt")
        print(f"| {key} | V (m/s) | tip (%) | torchrom torsion (Hz) | SOL 400 GFEM torsion at "
              "the same tip (Hz) | difference |")
        print("|---|---:|---:|---:|---:|---:|")
        for r in rows:
            ref = float(np.interp(r["tip_pct"], gfem[:, 1], gfem[:, 4]))
            f3 = r["frequencies_hz"][2]
            print(f"| | {r['velocity']:g} | {r['tip_pct']:.2f} | {f3:.2f} | {ref:.2f} | "
                  f"{100 * (f3 / ref - 1):+.2f} % |")
    if args.figure:
        figure(res, args.figure, rom_tips(*args.rom_flutter) if args.rom_flutter else None)
        print(f"figure: {args.figure}")
    if args.modes_figure and res["modes"]:
        skinned = None
        if args.skinned_fe:
            rom_path, fl = args.rom_flutter if args.rom_flutter else (None, None)
            skinned = skinned_modes(args.skinned_fe, rom_path, fl)
        modes_figure(res, args.modes_figure, skinned=skinned)
        print(f"figure: {args.modes_figure}")
    if args.out and args.source is None:
        args.out.write_text(json.dumps(res, indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
