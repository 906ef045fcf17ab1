"""A wing's planform from its structure's outline: leading and trailing edges per span station.

Input: the structural grids' positions in the wing's own axes (span s from the root, chord
coordinate c along the flow, up n; :class:`torchrom.fe.wing_frame.WingFrame`). Stations are
the grids' distinct span positions; at each one the leading edge is the smallest c, the
trailing edge the largest and the mean surface the middle of the up extent. Stations where
the edges run straight on (sweep and taper constant) are dropped, so that each remaining
segment is one trapezoidal CAERO1. ``box_chord`` (front, rear) says what fraction of the wing's
chord the structure spans (a wingbox between spars at 15 % and 65 %: (0.15, 0.65)); the
edges are then extended to the full chord.

Written here: no maintained library derives a lifting-surface planform from an FE mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: span positions closer than this share of the span are one station
STATION_TOL = 1e-3
#: an intermediate station is kept where an edge leaves the straight line between its
#: neighbours by more than this share of the local chord
KINK_TOL = 1e-3


@dataclass(frozen=True)
class Planform:
    """Stations (k,) along the span: span position ``s``, leading and trailing edge chord
    coordinates ``le``, ``te`` and the mean surface's up coordinate ``n`` (wing axes, the
    deck's length unit)."""

    s: np.ndarray
    le: np.ndarray
    te: np.ndarray
    n: np.ndarray

    @property
    def chord(self) -> np.ndarray:
        return self.te - self.le

    @property
    def area(self) -> float:
        """Planform area (trapezoids between stations)."""
        c, s = self.chord, self.s
        return float(np.sum(0.5 * (c[1:] + c[:-1]) * np.diff(s)))

    @property
    def mean_chord(self) -> float:
        """Area over span: the reference chord (Nastran AERO REFC)."""
        return self.area / float(self.s[-1] - self.s[0])


def _stations(local: np.ndarray) -> list[np.ndarray]:
    s = local[:, 0]
    extent = max(float(np.ptp(s)), 1e-300)
    order = np.argsort(s)
    breaks = np.nonzero(np.diff(s[order]) > STATION_TOL * extent)[0] + 1
    return np.split(order, breaks)


def _straight(s, y, i, j, tol) -> bool:
    """Stations i < k < j lie on the line through stations i and j (within ``tol``)."""
    if j - i < 2:
        return True
    t = (s[i + 1:j] - s[i]) / (s[j] - s[i])
    line = y[i] + t * (y[j] - y[i])
    return bool(np.all(np.abs(y[i + 1:j] - line) <= tol[i + 1:j]))


def planform(local: np.ndarray, box_chord: tuple[float, float] = (0.0, 1.0)) -> Planform:
    """The :class:`Planform` of grid positions ``local`` (n, 3) in wing axes (module
    docstring). InputError when fewer than two stations or a station without chord extent
    (a beam-line model: give its chord, e.g. write the panels by hand)."""
    front, rear = (float(x) for x in box_chord)
    if not 0.0 <= front < rear <= 1.0:
        raise InputError(f"--box-chord: expected 0 <= FRONT < REAR <= 1 (fractions of the "
                         f"wing's chord), got {front:g} {rear:g}")
    local = np.asarray(local, dtype=float)
    groups = _stations(local)
    if len(groups) < 2:
        raise InputError("panels: the structure has fewer than two span stations: its span "
                         "cannot be told (check --span-axis)")
    s = np.array([local[g, 0].mean() for g in groups])
    lo = np.array([local[g, 1].min() for g in groups])
    hi = np.array([local[g, 1].max() for g in groups])
    n = np.array([0.5 * (local[g, 2].min() + local[g, 2].max()) for g in groups])
    width = hi - lo
    if np.any(width <= STATION_TOL * np.ptp(s)):
        k = int(np.argmin(width))
        raise InputError(f"panels: the structure has no chordwise extent at span station "
                         f"{s[k]:.4g} (a beam-line model): its planform cannot be read from "
                         f"the structure; write CAERO1 cards by hand")
    chord = width / (rear - front)
    le, te = lo - front * chord, lo + (1.0 - front) * chord
    # keep the root, the tip and the kinks of either edge
    tol = KINK_TOL * chord
    keep, i = [0], 0
    while i < len(s) - 1:
        j = i + 1
        while j + 1 < len(s) and _straight(s, le, i, j + 1, tol) and _straight(
                s, te, i, j + 1, tol) and _straight(s, n, i, j + 1, tol):
            j += 1
        keep.append(j)
        i = j
    k = np.array(keep)
    return Planform(s[k], le[k], te[k], n[k])
