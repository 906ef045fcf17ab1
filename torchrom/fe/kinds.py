"""Classify mode shapes as bending, torsion, in-plane or axial from their displacement content.

Geometric (no mass weighting), in the wing's own axes (:mod:`torchrom.fe.wing_frame`: span,
chord and up from the panels, the structure or the user's ``--up-axis``). At each span station
the up displacements are fitted by heave + twist × (chord position): heave measures bending,
twist × L_c / 2 (the edge deflection it causes, L_c the chord extent) measures torsion. A
beam-line model has no chord extent at a station: its twist is the rotation about the span
axis and L_c is the aerodynamic reference chord of the deck (AEROS/AERO) or 10 % of the span.
Chordwise translations measure "in-plane" (lead–lag) content, spanwise translations "axial"
content. The kind is the largest of the four sums of squares.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .wing_frame import WingFrameError, structural_rows

KINDS = ("bending", "torsion", "in-plane", "axial")


def _reference_chord(fe, span_extent: float) -> float:
    bdf = getattr(fe, "bdf", None)
    for attr, field in (("aeros", "cref"), ("aero", "cref")):
        card = getattr(bdf, attr, None) if bdf is not None else None
        val = getattr(card, field, None) if card is not None else None
        if val:
            return float(val)
    return 0.1 * span_extent


def classify(fe, shapes: np.ndarray) -> tuple[list[str], list[dict[str, float]]]:
    """Kinds and content fractions (bending/torsion/in-plane/axial, summing to 1) of modes;
    ``["unknown"] * n`` and no fractions where the wing's axes cannot be told
    (:class:`~torchrom.fe.wing_frame.WingFrameError`)."""
    try:
        frame = fe.wing_frame()
    except WingFrameError:
        n = 1 if np.ndim(shapes) == 1 else np.shape(shapes)[1]
        return ["unknown"] * n, [{} for _ in range(n)]
    rows = structural_rows(fe)
    xyz = fe.grid_xyz[rows]
    span, chord, normal = frame.span, frame.chord, frame.up
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
