"""Classify mode shapes as bending, torsion, in-plane or axial from their displacement content.

Geometric (no mass weighting). The span axis is the principal axis of the
structural grids (those connected to elements); the normal is basic z made orthogonal to it
(the principal axis of least extent if the span is nearly vertical); the chord completes the
frame. At each span station the normal displacements are fitted by heave + twist × (chord
position): heave measures bending, twist × L_c / 2 (the edge deflection it causes, L_c the chord
extent) measures torsion. A beam-line model has no chord extent at a station: its twist is the
rotation about the span axis and L_c is the aerodynamic reference chord of the deck (AEROS/AERO)
or 10 % of the span. Chordwise translations measure "in-plane" (lead–lag) content, spanwise
translations "axial" content. The kind is the largest of the four sums of squares.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

KINDS = ("bending", "torsion", "in-plane", "axial")


def _structural_rows(fe) -> np.ndarray:
    m = fe.mesh
    rows = [m.rods.nodes.ravel(), m.quads.nodes.ravel(), m.trias.nodes.ravel(),
            m.shears.nodes.ravel(), m.bars.nodes.ravel()] + [x.nodes.ravel() for x in m.solids]
    rows = np.unique(np.concatenate([r.astype(int) for r in rows]))
    return rows if len(rows) else np.arange(m.n_grid)


def _reference_chord(fe, span_extent: float) -> float:
    bdf = getattr(fe, "bdf", None)
    for attr, field in (("aeros", "cref"), ("aero", "cref")):
        card = getattr(bdf, attr, None) if bdf is not None else None
        val = getattr(card, field, None) if card is not None else None
        if val:
            return float(val)
    return 0.1 * span_extent


def wing_axes(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(span, chord, normal) unit vectors of a set of grid positions."""
    X = xyz - xyz.mean(axis=0)
    _, _, vt = np.linalg.svd(X, full_matrices=False) if len(X) > 1 else (None, None, np.eye(3))
    span = vt[0]
    nz = np.array([0.0, 0.0, 1.0]) - span[2] * span
    if np.linalg.norm(nz) < 0.3:
        nz = vt[-1] if vt.shape[0] == 3 else np.cross(span, [1.0, 0.0, 0.0])
    normal = nz / np.linalg.norm(nz)
    chord = np.cross(normal, span)
    return span, chord, normal


def classify(fe, shapes: np.ndarray) -> tuple[list[str], list[dict[str, float]]]:
    """Kinds and content fractions (bending/torsion/in-plane/axial, summing to 1) of modes."""
    rows = _structural_rows(fe)
    xyz = fe.grid_xyz[rows]
    span, chord, normal = wing_axes(xyz)
    s = xyz @ span
    c = xyz @ chord
    extent = max(np.ptp(s), 1e-300)
    tol = 1e-3 * extent
    order = np.argsort(s)
    breaks = np.nonzero(np.diff(s[order]) > tol)[0] + 1
    stations = np.split(order, breaks)
    chord_extent = np.ptp(c)
    L_c = chord_extent if chord_extent > 1e-3 * extent else _reference_chord(fe, extent)
    U_all = fe.expand(shapes)
    if U_all.ndim == 2:
        U_all = U_all[None]
    kinds, fractions = [], []
    for U in U_all:
        U = U[rows]
        tn, tc, ts = U[:, :3] @ normal, U[:, :3] @ chord, U[:, :3] @ span
        rs = U[:, 3:] @ span
        bend = tors = 0.0
        for st in stations:
            cc = c[st] - c[st].mean()
            if np.ptp(c[st]) > 1e-3 * extent:
                A = np.stack((np.ones(len(st)), cc), axis=1)
                (heave, twist), *_ = np.linalg.lstsq(A, tn[st], rcond=None)
            else:
                heave, twist = tn[st].mean(), rs[st].mean()
            bend += len(st) * heave**2
            tors += len(st) * (twist * L_c / 2.0) ** 2
        parts = np.array([bend, tors, np.sum(tc**2), np.sum(ts**2)])
        total = parts.sum()
        frac = parts / total if total > 0 else parts
        kinds.append(KINDS[int(np.argmax(parts))])
        fractions.append({k: float(v) for k, v in zip(KINDS, frac)})
    return kinds, fractions


#: a share below this is left out of a kind's label
SHOWN_SHARE = 0.05


#: short names of the kinds (figure annotations)
SHORT = {"bending": "b", "torsion": "t", "in-plane": "ip", "axial": "ax"}


def kind_label(kind: str | None, content: Mapping[str, float] | None = None,
               short: bool = False) -> str:
    """``kind`` with the content shares of at least :data:`SHOWN_SHARE`, largest first, e.g.
    "bending (0.44 bending, 0.29 in-plane, 0.26 torsion)" (``short``: "bending (b .44, ip .29,
    t .26)"); the kind alone for a pure mode (no second share of :data:`SHOWN_SHARE`) or when
    the shares are unknown."""
    kind = kind or "unknown kind"
    if not content:
        return kind
    shares = sorted(((v, k) for k, v in content.items() if v >= SHOWN_SHARE), reverse=True)
    if len(shares) < 2:
        return kind
    if short:
        parts = (f"{SHORT.get(k, k)} {v:.2f}".replace(" 0.", " .") for v, k in shares)
        return f"{kind} ({', '.join(parts)})"
    return f"{kind} ({', '.join(f'{v:.2f} {k}' for v, k in shares)})"
