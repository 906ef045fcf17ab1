"""Mesh convergence of the Dakota cylinder's shell modes (tests/decks/dakota_cylinder): how far
from the converged modes are MSC Nastran's QUAD4 and our CQUAD4 on the deck's 16 x 20 mesh?

(Written when ours was 2.1-2.6 % stiffer than Nastran's on six shell modes; since the residual
bending flexibility on the CQUAD4's transverse shear (torchrom/fe/elements/quad4.py) both are
5-7 % above the limit on that mesh and agree within 0.26 %; ours converges.)

The deck (free-free cylinder, radius 1, length 10, t = 0.2, E = 1e7, ν = 0.35, ρ = 0.1, PARAM
WTMASS 0.00259 and COUPMASS 1, end rings tied by RBE2 to a 1000-mass grid and to a free grid) is
rebuilt here with r times as many elements around and along (16 r x 20 r); r = 1 reproduces the
deck's own modes to the digits printed by tests/test_public_decks.py. The 14 elastic modes are
solved by Arnoldi on (K - σM)⁻¹ M (σ below zero; the massless rotations of the coupled shell
mass only add ν = 0), which ``FEModel.modes`` does not use past 3,000 DOFs.

Writes experiments/results/cylinder_convergence.{json,md}. Run:
``python experiments/cylinder_convergence.py [--levels 1 2 3]`` (about a minute for 1-3).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as sla
from pyNastran.bdf.bdf import BDF

from torchrom.f06 import read_real_eigenvalues
from torchrom.fe.bdf_read import from_pynastran

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT / "tests" / "decks" / "dakota_cylinder"
OUT = ROOT / "experiments" / "results"


def cylinder(r: int) -> BDF:
    """The deck's cylinder with 16 r x 20 r CQUAD4 (grid numbering of our own)."""
    nc, nz = 16 * r, 20 * r
    m = BDF(debug=None)
    m.add_param("COUPMASS", [1])
    m.add_param("WTMASS", [0.00259])
    m.add_mat1(101, 1.0e7, None, 0.35, rho=0.1)
    m.add_pshell(101, mid1=101, t=0.2, mid2=101, mid3=101)

    def gid(i: int, j: int) -> int:
        return 1 + j * nc + (i % nc)

    for j in range(nz + 1):
        for i in range(nc):
            th = 2 * np.pi * i / nc
            m.add_grid(gid(i, j), [np.cos(th), np.sin(th), 10.0 * j / nz])
    base, top = 10 * nc * (nz + 1), 10 * nc * (nz + 1) + 1
    m.add_grid(base, [0.0, 0.0, -0.5])
    m.add_grid(top, [0.0, 0.0, 10.0])
    m.add_conm2(1, base, 1000.0)
    eid = 1
    for j in range(nz):
        for i in range(nc):
            m.add_cquad4(eid, 101, [gid(i, j), gid(i + 1, j), gid(i + 1, j + 1), gid(i, j + 1)])
            eid += 1
    m.add_rbe2(eid, base, "123456", [gid(i, 0) for i in range(nc)])
    m.add_rbe2(eid + 1, top, "123456", [gid(i, nz) for i in range(nc)])
    return m


def elastic_hz(r: int, n: int = 14) -> np.ndarray:
    fe = from_pynastran(cylinder(r), source=f"cylinder_{r}.bdf", name=f"cylinder_{r}")
    K, M = fe.stiffness_matrix().tocsc(), fe.mass_matrix().tocsr()
    sigma = -1e3  # rad²/s², well below the first elastic ω² (~3e8) and away from the 6 rigid
    lu = sla.splu((K - sigma * M).tocsc())
    op = sla.LinearOperator(K.shape, matvec=lambda x: lu.solve(M @ x), dtype=float)
    nu = sla.eigs(op, k=n + 10, which="LM", return_eigenvectors=False)
    lam = np.sort(sigma + 1.0 / nu.real)
    f = np.sqrt(np.abs(lam)) / (2 * np.pi)
    return f[f > 1.0][:n]  # past the six rigid-body modes (|f| < 1e-2 Hz)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args(argv)
    nastran = read_real_eigenvalues(DECK / "modal.f06")[0].cycles[6:20]
    rows = {r: elastic_hz(r) for r in args.levels}
    rec = {"nastran_16x20_hz": nastran.tolist(),
           "torchrom_hz": {f"{16 * r}x{20 * r}": f.tolist() for r, f in rows.items()}}
    lines = ["# Dakota cylinder: mesh convergence of the elastic modes (Hz)", "",
             "| mode | Nastran 16x20 | " + " | ".join(f"torchrom {16 * r}x{20 * r}"
                                                     for r in rows) + " |",
             "|---|---|" + "---|" * len(rows)]
    for k in range(len(nastran)):
        cells = [f"{rows[r][k]:.1f} ({100 * (rows[r][k] / nastran[k] - 1):+.2f} %)" for r in rows]
        lines.append(f"| {k + 7} | {nastran[k]:.1f} | " + " | ".join(cells) + " |")
    if {1, 2, 3} <= rows.keys():
        # Richardson with h² convergence from 16x20 and 32x40, checked on 48x60
        limit = (4 * rows[2] - rows[1]) / 3
        rec["extrapolated_hz"] = limit.tolist()
        lines += ["", "Extrapolated (h², from 16x20 and 32x40) and the coarse meshes against it:",
                  "", "| mode | limit | Nastran 16x20 | torchrom 16x20 | torchrom 48x60 |",
                  "|---|---|---|---|---|"]
        for k in range(len(nastran)):
            lines.append(f"| {k + 7} | {limit[k]:.1f} | {100 * (nastran[k] / limit[k] - 1):+.2f} % "
                         f"| {100 * (rows[1][k] / limit[k] - 1):+.2f} % "
                         f"| {100 * (rows[3][k] / limit[k] - 1):+.2f} % |")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "cylinder_convergence.json").write_text(json.dumps(rec, indent=1) + "\n")
    (OUT / "cylinder_convergence.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
