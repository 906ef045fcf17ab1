"""Stand-ins for FE models (modes given in closed form) used by the aero tests.

They implement the part of the FEModel contract (COMMON.md) the aero code uses: grid_ids,
grid_xyz, n_dof, expand(u) and modes(n) -> (frequencies_hz, shapes mass-normalised, kinds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Modes:
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    kinds: list


class ClosedFormFE:
    """Grids with prescribed 6-DOF mode shapes (n_modes, n_grid, 6) and frequencies."""

    def __init__(self, grid_ids, grid_xyz, frequencies_hz, mode_fields, source="closed-form"):
        self.grid_ids = np.asarray(grid_ids)
        self.grid_xyz = np.asarray(grid_xyz, dtype=float)
        self._f = np.asarray(frequencies_hz, dtype=float)
        self._fields = np.asarray(mode_fields, dtype=float)
        self.n_dof = self.grid_ids.size * 6
        self.source = source

    def expand(self, u):
        """(n_dof,) -> (n_grid, 6); (n_dof, k) -> (k, n_grid, 6) (FEModel contract)."""
        u = np.asarray(u)
        if u.ndim == 1:
            return u.reshape(len(self.grid_ids), 6)
        return u.T.reshape(u.shape[1], len(self.grid_ids), 6)

    def modes(self, n):
        n = min(n, len(self._f))
        shapes = self._fields[:n].reshape(n, -1).T
        return Modes(self._f[:n], shapes, ["closed-form"] * n)


def plate_fe(
    nx=3, ny=11, chord=4.0, span=20.0, frequencies_hz=(1.7, 3.1), generalized_masses=(50.0, 190.0)
):
    """Goland-like box grid (x 0..chord, y 0..span, top and bottom skins) with a bending mode and
    a torsion mode about x = chord / 2, mass-normalised for the given generalized masses (the
    defaults are those of w = (y/L)² and θ = y/L on a 12.5 slug/ft wing with I_α ≈ 28 slug·ft)."""
    gx, gy = np.meshgrid(np.linspace(0, chord, nx), np.linspace(0, span, ny))
    top = np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, 1 / 6)]
    xyz = np.r_[top, top * [1, 1, -1]]
    y, x = xyz[:, 1] / span, xyz[:, 0] - chord / 2
    fields = np.zeros((2, len(xyz), 6))
    fields[0, :, 2] = y**2
    fields[0, :, 3] = 2 * y / span
    fields[1, :, 2] = -x * y  # nose-up twist θ = y/span about the mid-box line
    fields[1, :, 4] = y
    fields /= np.sqrt(np.asarray(generalized_masses, dtype=float))[:, None, None]
    return ClosedFormFE(np.arange(1, len(xyz) + 1), xyz, frequencies_hz, fields)


#: the free aircraft stand-in of :func:`rigid_and_elastic`: structural damping c = α + γ K of
#: each uncoupled mode (α, γ as ``torchrom flutter --alpha --gamma`` give them) and the
#: quasi-steady GAF Q(k) = A0 + i k A1 (sign F = -q∞ Q q, semichord 1)
RIGID_ELASTIC = {"alpha": 0.1, "gamma": 0.001, "K": (0.0, 100.0), "A0": (0.05, 0.0),
                 "A1": (-0.25, -0.35)}


def rigid_and_elastic(mach: float, untouched_k: float | None = None):
    """A free aircraft in closed form: a rigid-body mode (K = 0) with an aerodynamic stiffness
    and an elastic mode (ω = 10 rad/s), uncoupled, unit masses, each with structural damping
    c and aerodynamic damping ½ ρ V b A1 < 0. Each root's damping crosses zero where
    c = ½ ρ V |A1|: the rigid root at ρV = 2·0.1/0.25 = 0.8 (lower speed, higher altitude) and
    the elastic one at ρV = 2·0.2/0.35 = 8/7, with s = 10i exactly. ``untouched_k``: a third
    mode of that stiffness (unit mass) the aerodynamics do not touch (zero GAF row and column).
    Returns (ModalStructure, GAF table on k = 0 and 1e-3..2, RFA with no lag states: exact for
    this Q)."""
    from torchrom.aero.dlm import GAF
    from torchrom.aero.flutter import ModalStructure
    from torchrom.aero.rfa import RFA

    p = RIGID_ELASTIC
    extra = () if untouched_k is None else (0.0,)
    stiffness = p["K"] + (() if untouched_k is None else (untouched_k,))
    n = len(stiffness)
    structure = ModalStructure(np.eye(n), np.diag(stiffness), alpha=p["alpha"],
                               gamma=p["gamma"])
    a0, a1 = np.diag(p["A0"] + extra), np.diag(p["A1"] + extra)
    k = np.r_[0.0, np.geomspace(1e-3, 2.0, 40)]  # p-k's speeds reach ω b / 1e-3
    gaf = GAF(mach, 1.0, k, a0[None] + 1j * k[:, None, None] * a1[None])
    rfa = RFA(a0, a1, np.zeros((n, n)), np.zeros((n, 0)), np.zeros((0, 0)), np.zeros((0, n)),
              np.zeros(0), "roger", 1.0, mach)
    return structure, gaf, rfa
