"""Writer of a SOL 145 deck of an aircraft-size wing: shell wing box, bar spar caps, DLM boxes.

The structure (SI units: m, kg, s) is a two-cell-free wing box of chord 1.6 m and depth 0.2 m
from root (clamped) to tip over a 10 m semispan: upper and lower CQUAD4 skins of
``n_chord × n_span`` grids each (2 n_chord n_span GRIDs), CQUAD4 front/rear spar webs, CBAR spar
caps along the four corners and CBAR rib posts joining the skins every ``rib_every`` stations.
The aerodynamic model is one CAERO1 of ``n_box_chord × n_box_span`` boxes over a 2 m chord
(AERO SYMXZ = 1), splined by SPLINE1 (inboard half, a subset of the upper-skin grids) and
SPLINE2 (outboard half, the mid-chord line of the upper skin); MKAERO1 cards carry ``n_k``
reduced frequencies at Mach 0.5; FLUTTER PK over 20 speeds; EIGRL ND = ``n_modes``.

Used by ``benchmarks/bench_big_deck.py`` (7,000 grids, 36 × 36 boxes, 104 k) and, small, by
``tests/test_big_wing_deck.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

SEMISPAN = 10.0
AERO_CHORD = 2.0
BOX_X = (0.2, 1.8)  # skins' chordwise extent
DEPTH = 0.2
MACH = 0.5


def _field(v) -> str:
    if isinstance(v, str):
        return f"{v:<8}"
    if isinstance(v, (int, np.integer)):
        return f"{int(v):<8d}"
    for digits in range(7, 0, -1):
        s = f"{float(v):.{digits}g}"
        if "e" in s:
            mant, exp = s.split("e")
            s = f"{mant}{'' if '.' in mant else '.'}{int(exp):+d}"
        elif "." not in s:
            s += "."
        if len(s) <= 8:
            return f"{s:<8}"
    raise ValueError(f"cannot write {v!r} in 8 characters")


def card(name: str, *fields) -> str:
    """One small-field card, continued on blank-name lines after every 8 fields."""
    lines, rest = [], list(fields)
    head = f"{name:<8}"
    while True:
        chunk, rest = rest[:8], rest[8:]
        lines.append(head + "".join("" if f is None else _field(f) if f != "" else " " * 8
                                    for f in chunk))
        if not rest:
            return "\n".join(line.rstrip() for line in lines) + "\n"
        head = " " * 8


def k_values(n_k: int) -> np.ndarray:
    """``n_k`` reduced frequencies k = ω b / V from 0.001 to 3, denser at low k."""
    return np.round(np.geomspace(1e-3, 3.0, n_k), 6)


def write_deck(path, n_chord: int = 35, n_span: int = 100, n_box_chord: int = 36,
               n_box_span: int = 36, n_k: int = 104, n_modes: int = 10,
               rib_every: int = 10) -> dict:
    """Write the deck to ``path``; returns its sizes (grids, boxes, k, DOFs before SPC)."""
    xs = np.linspace(*BOX_X, n_chord)
    ys = np.linspace(0.0, SEMISPAN, n_span)
    out = ["SOL 145\nCEND\nTITLE = GENERATED SHELL WING BOX, DLM FLUTTER\n",
           "ECHO = NONE\nSPC = 1\nMETHOD = 10\nFMETHOD = 30\nRESVEC = NO\nBEGIN BULK\n"]

    def gid(surface, i, j):  # surface 0 upper, 1 lower; i chordwise, j spanwise
        return 1 + surface * n_chord * n_span + j * n_chord + i

    for s, z in ((0, DEPTH / 2), (1, -DEPTH / 2)):
        for j, y in enumerate(ys):
            for i, x in enumerate(xs):
                out.append(card("GRID", gid(s, i, j), 0, x, y, z))
    eid = 1
    for s in (0, 1):
        for j in range(n_span - 1):
            for i in range(n_chord - 1):
                out.append(card("CQUAD4", eid, 1, gid(s, i, j), gid(s, i + 1, j),
                                gid(s, i + 1, j + 1), gid(s, i, j + 1)))
                eid += 1
    for i in (0, n_chord - 1):  # spar webs
        for j in range(n_span - 1):
            out.append(card("CQUAD4", eid, 2, gid(0, i, j), gid(0, i, j + 1),
                            gid(1, i, j + 1), gid(1, i, j)))
            eid += 1
    for s in (0, 1):  # spar caps (orientation vector: basic z)
        for i in (0, n_chord - 1):
            for j in range(n_span - 1):
                out.append(card("CBAR", eid, 3, gid(s, i, j), gid(s, i, j + 1), 0.0, 0.0, 1.0))
                eid += 1
    for j in range(0, n_span, rib_every):  # rib posts (orientation vector: basic y)
        for i in range(1, n_chord - 1):
            out.append(card("CBAR", eid, 4, gid(0, i, j), gid(1, i, j), 0.0, 1.0, 0.0))
            eid += 1
    out += [card("PSHELL", 1, 1, 0.003, 1, "", 1), card("PSHELL", 2, 1, 0.004, 1, "", 1),
            card("PBAR", 3, 1, 4.0e-4, 2.0e-8, 2.0e-8, 4.0e-8),
            card("PBAR", 4, 1, 1.0e-4, 1.0e-9, 1.0e-9, 2.0e-9),
            card("MAT1", 1, 7.0e10, "", 0.33, 2700.0)]
    root = [gid(s, i, 0) for s in (0, 1) for i in range(n_chord)]
    out.append(card("SPC1", 1, 123456, *root))
    out.append(card("EIGRL", 10, "", "", n_modes))
    # aerodynamics: one CAERO1 over the 2 m chord, boxes numbered chordwise first
    out.append(card("AERO", 0, 200.0, AERO_CHORD, 1.225, 1))
    out.append(card("PAERO1", 1))
    out.append(card("CAERO1", 1001, 1, "", n_box_span, n_box_chord, "", "", 1,
                    0.0, 0.0, 0.0, AERO_CHORD, 0.0, SEMISPAN, 0.0, AERO_CHORD))
    n_boxes = n_box_chord * n_box_span
    inboard = (n_box_span // 2) * n_box_chord
    plate = [gid(0, i, j) for j in range(0, n_span, max(1, n_span // 25))
             for i in range(0, n_chord, max(1, n_chord // 12)) if ys[j] <= 0.6 * SEMISPAN]
    beam = [gid(0, n_chord // 2, j) for j in range(n_span) if ys[j] >= 0.4 * SEMISPAN]
    out.append(card("SET1", 100, *plate))
    out.append(card("SET1", 101, *beam))
    out.append(card("SPLINE1", 100, 1001, 1001, 1000 + inboard, 100))
    out.append(card("SPLINE2", 101, 1001, 1001 + inboard, 1000 + n_boxes, 101, 0.0, 1.0, 0,
                    -1.0, -1.0))
    ks = k_values(n_k)
    for start in range(0, n_k, 8):
        out.append(card("MKAERO1", MACH, "", "", "", "", "", "", "", *ks[start:start + 8]))
    speeds = np.linspace(50.0, 400.0, 20)
    out.append(card("FLFACT", 1, 1.0))
    out.append(card("FLFACT", 2, MACH))
    out.append(card("FLFACT", 3, *speeds))
    out.append(card("FLUTTER", 30, "PK", 1, 2, 3, "L", n_modes))
    out.append("ENDDATA\n")
    Path(path).write_text("".join(out))
    n_grid = 2 * n_chord * n_span
    return {"grids": n_grid, "dof": 6 * n_grid, "boxes": n_boxes, "k": n_k,
            "elements": eid - 1}
