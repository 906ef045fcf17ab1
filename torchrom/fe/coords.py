"""Axes of Nastran coordinate systems at a point (rectangular, cylindrical, spherical), and
Nastran component strings.

Delegated to pyNastran: the systems' rotation (``Coord.beta()``) and origin. Written here: the
local axes of the curvilinear systems at a basic point (used for GRID CD, CBAR orientation, CONM2
offsets and FORCE/MOMENT directions).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError


def axes_at(coord, point: np.ndarray) -> np.ndarray:
    """Unit axes (columns, basic) of a coordinate system at a basic point (curvilinear too)."""
    beta = np.asarray(coord.beta(), dtype=float)  # rows: local x, y, z in basic
    kind = coord.type[-1]
    if coord.cid == 0 or kind == "R":
        return beta.T
    p = beta @ (np.asarray(point, float) - np.asarray(coord.origin, float))
    th = np.arctan2(p[1], p[0])
    c, s = np.cos(th), np.sin(th)
    if kind == "C":
        local = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    else:  # spherical (R, θ from z, φ about z)
        r_xy = np.hypot(p[0], p[1])
        ph = np.arctan2(r_xy, p[2])
        cp, sp_ = np.cos(ph), np.sin(ph)
        local = np.array(
            [[sp_ * c, cp * c, -s], [sp_ * s, cp * s, c], [cp, -sp_, 0.0]]
        )
    return beta.T @ local


def components(value, fname: str, where: str) -> list[int]:
    """Nastran component string ('123456' subset) → sorted 0-based list."""
    if value in (None, "", 0, "0"):
        return []
    s = str(value)
    if not s.isdigit() or any(ch not in "123456" for ch in s):
        raise InputError(f"{fname}: {where}: expected components from 1..6, got {value!r}")
    return sorted({int(ch) - 1 for ch in s})
