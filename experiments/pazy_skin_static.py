"""The skinned Pazy wing's condensed ROM (``identify --linear-skin``) against the published
nonlinear static bending sweep of the same wing with skin: Riso & Cesnik's UM/NAST beam model
(SciTech 2022; no nonlinear GFEM answer exists with skin: "the finite element model with skin
does not run" in SOL 400), beside the GFEM's SOL 101 with skin and UM/NAST without skin.

The load is the tip mass's weight, m × 9.81 N down at the tip grid 2366 (the ROM's output
``max_mode1``, 6.4 mm ahead of the mid-chord where the sweep hangs its mass); the sweep's
displacements have the self-weight's subtracted, this one applies none. Tip displacement in %
of the semispan (0.55 m), downward positive.

    torchrom identify tests/decks/aepw3_pazy_skin_flutter_tipmass1/sol145.dat --linear 10 \\
        --stiffness condensed --nonlinear-modes 3 --higher-amplitude 0.1 --linear-skin 10011 \\
        --out rom.npz
    PYTHONPATH=$PWD python experiments/pazy_skin_static.py rom.npz \\
        [--out experiments/results/pazy_skin_static.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

DECK = Path(__file__).resolve().parents[1] / "tests/decks/aepw3_pazy_skin_flutter_tipmass1"
SEMISPAN = 0.55  # m, the sweeps' reference
GRAVITY = 9.81  # m/s²
TABLES = {"UM/NAST with skin": "sweep_static_bending_UM_NAST_sweep_w_skin.txt",
          "UM/NAST without skin": "sweep_static_bending_UM_NAST_sweep_wo_skin.txt",
          "GFEM SOL 101 with skin": "sweep_static_bending_GFEM_linear_sweep_w_skin.txt"}


def rom_tip_sweep(rom, masses: np.ndarray, output: str = "max_mode1",
                  linear: bool = False) -> np.ndarray:
    """Tip deflection (% semispan, down positive) of the ROM's static solution under each
    tip mass's weight at ``output``'s grid, continued from one mass to the next (``linear``:
    K1 q = f)."""
    from torchrom.identify.validate import rom_static_solve

    row = rom.output_matrix([output])[1][0]
    K1 = np.asarray(rom.K1, dtype=float)
    q, out = None, []
    for m in masses:
        f = -GRAVITY * m * row
        q = np.linalg.solve(K1, f) if linear else rom_static_solve(rom, f, q)
        out.append(-100.0 * float(row @ q) / SEMISPAN)
    return np.array(out)


def main(argv=None) -> int:
    from torchrom.rom import NonlinearROM

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("rom", type=Path)
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    rom = NonlinearROM.load(args.rom)
    refs = {k: np.loadtxt(DECK / v) for k, v in TABLES.items()}
    um = refs["UM/NAST with skin"]
    masses = um[um[:, 0] > 0, 0][9::10]         # 0.25, 0.5, ..., 3.5 kg
    rom_pct = rom_tip_sweep(rom, masses)
    lin = rom_tip_sweep(rom, masses, linear=True)
    print("| mass kg | UM/NAST skin % | ROM % | ROM - UM/NAST (% of it) | ROM linear % | "
          "SOL 101 skin % | UM/NAST no skin % |")
    rows = []
    for m, r, rl in zip(masses, rom_pct, lin):
        ref = {k: -float(np.interp(m, t[:, 0], t[:, 1])) for k, t in refs.items()}
        u = ref["UM/NAST with skin"]
        print(f"| {m:.2f} | {u:.2f} | {r:.2f} | {100 * (r - u) / u:+.1f} | {rl:.2f} | "
              f"{ref['GFEM SOL 101 with skin']:.2f} | {ref['UM/NAST without skin']:.2f} |")
        rows.append({"mass_kg": float(m), "rom_pct": float(r), "rom_linear_pct": float(rl),
                     **{k + " %": v for k, v in ref.items()}})
    if args.out:
        args.out.write_text(json.dumps({"rom": str(args.rom), "rows": rows,
                                        "rom_identification": rom.metadata["identification"]},
                                       indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
