"""The wing's own axes (span, chord, up) from a deck's geometry, in basic coordinates.

A deck may put its wing in any orientation (span along y or z, thickness along z or y, rotated
through a CORD2R). Everything that speaks of "bending", "the tip's transverse deflection", "a
pressure pushing the wing up" or "point A's vertical displacement" asks this frame:

- ``up`` — the user's ``--up-axis``; else the aerodynamic coordinate system's z axis (AERO/AEROS
  ACSID: Nastran's lift direction) where the deck has CAERO panels; else the structure's
  thinnest principal axis (a plate or wingbox: its depth is well below its chord); else, for a
  beam-line model, the direction in which its CBAR/CBEAM sections bend most easily; else the
  frame cannot be told and :class:`WingFrameError` names the options that say it.
- ``span`` — the user's ``--span-axis``; else the structure's longest principal axis, made
  orthogonal to ``up`` and pointed from the constrained root towards the tip.
- ``chord`` — the flow direction (ACSID x) where there are panels, else ``span × up``; made
  orthogonal to both.

A structure alone cannot tell up from down; without panels the sign is the one whose largest
basic component is positive (a y-up deck gets +y). Everything downstream that depends on the
sign (the pressure's direction) is then the deck's convention, and ``--up-axis -y`` flips it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: a principal extent below this share of the next one is "thin" (a wingbox's depth is
#: ≈ 0.1-0.2 of its chord; a wing-fuselage stick model's vertical extent ≈ its fin height)
THIN_RATIO = 0.5
#: a beam-line model: the second principal extent below this share of the first
LINE_RATIO = 1e-3
#: beam sections bend "most easily" in one plane when the smaller second moment of area is
#: below this share of the larger (a wing spar's is typically < 0.1; a tube's is 1)
WEAK_RATIO = 0.8

UP_OPTION, SPAN_OPTION = "--up-axis", "--span-axis"
_NAMED = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


class WingFrameError(InputError):
    """The wing's axes cannot be told from the deck: the message names the options to give."""


@dataclass(frozen=True)
class WingFrame:
    """Unit vectors (basic) of the wing's span, chord and up directions; ``origin`` (basic) the
    root station's centre (smallest span coordinate, chord and up coordinates at mid-extent of
    the structure); ``source`` says how ``up`` was found."""

    span: np.ndarray
    chord: np.ndarray
    up: np.ndarray
    origin: np.ndarray
    source: str

    @property
    def axes(self) -> np.ndarray:
        """(3, 3) rows span, chord, up."""
        return np.stack((self.span, self.chord, self.up))

    def local(self, xyz) -> np.ndarray:
        """Basic positions (..., 3) → (..., 3) (span, chord, up) coordinates about ``origin``."""
        return (np.asarray(xyz, dtype=float) - self.origin) @ self.axes.T

    def describe(self) -> str:
        """e.g. "span +z, chord -x, up +y (structure: thinnest principal axis)"."""
        return (f"span {axis_name(self.span)}, chord {axis_name(self.chord)}, "
                f"up {axis_name(self.up)} ({self.source})")

    def as_dict(self) -> dict:
        return {"span": self.span.tolist(), "chord": self.chord.tolist(),
                "up": self.up.tolist(), "origin": self.origin.tolist(), "source": self.source}


def axis_name(v: np.ndarray) -> str:
    """"+x", "-y" for a basic axis; the components otherwise (e.g. "(0.707, 0, 0.707)")."""
    v = np.asarray(v, dtype=float)
    k = int(np.argmax(np.abs(v)))
    if abs(abs(v[k]) - 1.0) < 1e-9:
        return ("+" if v[k] > 0 else "-") + "xyz"[k]
    return "(" + ", ".join(f"{c:.4g}" for c in v) + ")"


def parse_axis(text: str | None, option: str) -> np.ndarray | None:
    """A direction given as ``x``, ``-y``, ``+z`` or three numbers ``a,b,c`` (basic), as a unit
    vector; None for None."""
    if text is None:
        return None
    s = str(text).strip().lower()
    sign = -1.0 if s.startswith("-") else 1.0
    name = s.lstrip("+-")
    if name in _NAMED:
        return sign * np.array(_NAMED[name])
    try:
        v = np.array([float(p) for p in s.split(",")], dtype=float)
    except ValueError:
        v = np.zeros(0)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) == 0:
        raise InputError(f"{option}: expected a basic axis (x, y, z, -x, ...) or three numbers "
                         f"a,b,c of a non-zero direction, got {text!r}")
    return v / np.linalg.norm(v)


def structural_rows(fe) -> np.ndarray:
    """Rows of the grids connected to elements (all grids when none is)."""
    m = fe.mesh
    rows = [m.rods.nodes.ravel(), m.quads.nodes.ravel(), m.trias.nodes.ravel(),
            m.shears.nodes.ravel(), m.bars.nodes.ravel()] + [x.nodes.ravel() for x in m.solids]
    rows = np.unique(np.concatenate([r.astype(int) for r in rows]))
    return rows if len(rows) else np.arange(m.n_grid)


def principal_axes(xyz: np.ndarray) -> np.ndarray:
    """(3, 3) rows: the principal axes of a point set, longest first (the identity for fewer
    than two points)."""
    X = np.asarray(xyz, dtype=float)
    X = X - X.mean(axis=0)
    if len(X) < 2:
        return np.eye(3)
    _, _, vt = np.linalg.svd(X, full_matrices=True)
    return vt


def uppermost_per_position(local: np.ndarray, scale: float, candidates=None) -> np.ndarray:
    """Sorted indices of the points with the largest up coordinate among those sharing one
    planform position: ``local`` (n, 3) span, chord, up coordinates; positions equal to 1e-6
    of ``scale``; ``candidates`` the indices considered (default all). A box's upper skin, or
    one grid per point of a spline plane."""
    local = np.asarray(local, dtype=float)
    keys = np.round(local[:, :2] / (1e-6 * max(float(scale), 1e-300))).astype(np.int64)
    best: dict[tuple, int] = {}
    for k in (range(len(local)) if candidates is None else candidates):
        key = tuple(keys[k])
        if key not in best or local[k, 2] > local[best[key], 2]:
            best[key] = int(k)
    return np.array(sorted(best.values()), dtype=int)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _conventional_sign(v: np.ndarray) -> np.ndarray:
    """``v`` with its largest basic component positive (ties: the first)."""
    k = int(np.argmax(np.abs(v) + 1e-12 * np.arange(3, 0, -1)))
    return v if v[k] >= 0 else -v


def _orthogonal(v: np.ndarray, to: np.ndarray) -> np.ndarray | None:
    w = v - (v @ to) * to
    n = np.linalg.norm(w)
    return w / n if n > 1e-6 else None


def _panel_frame(fe) -> tuple[np.ndarray, np.ndarray] | None:
    """(up, flow) of the aerodynamic coordinate system where the deck has CAERO panels."""
    bdf = getattr(fe, "bdf", None)
    if bdf is None or not getattr(bdf, "caeros", None):
        return None
    card = bdf.aero if getattr(bdf, "aero", None) is not None else getattr(bdf, "aeros", None)
    cid = int(getattr(card, "acsid", 0) or 0) if card is not None else 0
    if not cid:
        return np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    coord = bdf.coords.get(cid)
    if coord is None:
        return None
    beta = np.asarray(coord.beta(), dtype=float)
    return _unit(beta[2]), _unit(beta[0])


def _weak_bending_direction(fe, span: np.ndarray) -> np.ndarray | None:
    """The direction in which the CBAR/CBEAM sections bend most easily (length-weighted), or
    None when the sections bend alike in both planes (a tube) or there are no bars."""
    b = fe.mesh.bars
    if not len(b.eids):
        return None
    X = fe.mesh.xyz[b.nodes]
    ex = X[:, 1] - X[:, 0]
    length = np.linalg.norm(ex, axis=1)
    ok = length > 0
    if not ok.any():
        return None
    ex = ex[ok] / length[ok, None]
    ey = b.v[ok] - np.sum(b.v[ok] * ex, axis=1)[:, None] * ex
    ey /= np.maximum(np.linalg.norm(ey, axis=1), 1e-300)[:, None]
    ez = np.cross(ex, ey)
    I1, I2 = np.asarray(b.I1, float)[ok], np.asarray(b.I2, float)[ok]
    # I1 resists bending in plane 1 (element x-y): the displacement along y
    weak = np.where((I1 <= I2)[:, None], ey, ez)
    ratio = np.minimum(I1, I2) / np.maximum(np.maximum(I1, I2), 1e-300)
    w = length[ok] * (ratio < WEAK_RATIO)
    if w.sum() <= 0.5 * length[ok].sum():
        return None
    S = (weak * w[:, None]).T @ weak
    vals, vecs = np.linalg.eigh(S)
    d = _orthogonal(vecs[:, -1], span)
    return None if d is None else _conventional_sign(d)


def _constrained_rows(fe) -> np.ndarray:
    status = getattr(getattr(fe, "constraints", None), "status", {}) or {}
    return np.unique([r for (r, _), why in status.items() if str(why).startswith("SPC")]
                     ).astype(int)


def wing_frame(fe, up=None, span=None) -> WingFrame:
    """The :class:`WingFrame` of an FE model (see the module docstring). ``up``/``span``: the
    user's directions (vectors or :func:`parse_axis` text); WingFrameError where up cannot be
    told."""
    up = parse_axis(up, UP_OPTION) if isinstance(up, str) else up
    span = parse_axis(span, SPAN_OPTION) if isinstance(span, str) else span
    rows = structural_rows(fe)
    xyz = np.asarray(fe.grid_xyz, dtype=float)[rows]
    X = xyz - xyz.mean(axis=0)
    if len(X) > 1:
        _, sv, vt = np.linalg.svd(X, full_matrices=False)
        sv = np.concatenate([sv, np.zeros(3 - len(sv))])
        vt = np.concatenate([vt, np.zeros((3 - len(vt), 3))]) if len(vt) < 3 else vt
    else:
        sv, vt = np.zeros(3), np.eye(3)
    longest = vt[0] if sv[0] > 0 else None
    flow = None
    if up is not None:
        up, source = _unit(up), f"{UP_OPTION}"
    else:
        panels = _panel_frame(fe)
        if panels is not None:
            (up, flow), source = panels, "panels: the aerodynamic system's z"
        elif sv[0] > 0 and sv[1] > LINE_RATIO * sv[0] and sv[2] < THIN_RATIO * sv[1]:
            up, source = _conventional_sign(vt[2]), "structure: thinnest principal axis"
        else:
            up = None
            if longest is not None and sv[1] <= LINE_RATIO * sv[0]:
                up = _weak_bending_direction(fe, longest)
            source = "beam sections: their weakest bending direction"
            if up is None:
                raise WingFrameError(
                    f"{getattr(fe, 'name', 'deck')}: cannot tell the wing's up axis from its "
                    f"geometry (no CAERO panels, no thin direction, no beam section that bends "
                    f"more easily one way); give {UP_OPTION} (e.g. {UP_OPTION} z) and, if "
                    f"needed, {SPAN_OPTION}")
    if span is not None:
        s = _orthogonal(_unit(span), up)
        if s is None:
            raise InputError(f"{SPAN_OPTION}: the span axis must not be parallel to the up "
                             f"axis ({axis_name(up)})")
    else:
        candidates = [v for v in vt[: 3] if np.linalg.norm(v) > 0]
        s = None
        for v in candidates:  # the longest principal axis not along up
            s = _orthogonal(v, up)
            if s is not None and abs(v @ up) < 0.9:
                break
        if s is None:
            s = _orthogonal(np.array([0.0, 1.0, 0.0]), up)
            s = s if s is not None else _orthogonal(np.array([1.0, 0.0, 0.0]), up)
        fixed = _constrained_rows(fe)
        root = np.asarray(fe.grid_xyz, float)[fixed] if len(fixed) else None
        if root is not None and abs((root.mean(axis=0) - xyz.mean(axis=0)) @ s) > 1e-9 * max(
                sv[0], 1e-300):
            s = s if (root.mean(axis=0) - xyz.mean(axis=0)) @ s < 0 else -s
        else:
            s = _conventional_sign(s)
    if flow is not None:
        chord = _orthogonal(flow, up)
        chord = _orthogonal(chord, s) if chord is not None else None
    else:
        chord = None
    if chord is None:
        chord = _unit(np.cross(s, up))
    local = (xyz - xyz.mean(axis=0)) @ np.stack((s, chord, up)).T
    origin = xyz.mean(axis=0) + s * local[:, 0].min() + chord * 0.5 * (
        local[:, 1].min() + local[:, 1].max()) + up * 0.5 * (local[:, 2].min() + local[:, 2].max())
    return WingFrame(span=s, chord=chord, up=up, origin=origin, source=source)
