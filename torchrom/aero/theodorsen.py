"""Theodorsen's unsteady thin-airfoil aerodynamics and the two-degree-of-freedom typical section.

Written here (scipy Hankel functions): Theodorsen's function C(k) = H1⁽²⁾(k) / (H1⁽²⁾(k) +
i H0⁽²⁾(k)) (k = ω b / V), the section GAF for plunge h (positive up, at the elastic axis) and
pitch α (nose up) per unit span in the paper's sign (F_aero = -q∞ Q q), and the typical-section
structure (Bisplinghoff, Ashley & Halfman 1955, Ch. 9; Hodges & Pierce 2011, Ch. 5). Used as an
independent aerodynamic model to test the RFA and flutter solvers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy

from ..errors import InputError


def theodorsen_function(k) -> np.ndarray:
    """C(k) = F + iG for reduced frequencies k >= 0 (C(0) = 1)."""
    k = np.asarray(k, dtype=float)
    out = np.ones(k.shape, dtype=complex)
    nz = k > 0
    h1, h0 = scipy.special.hankel2(1, k[nz]), scipy.special.hankel2(0, k[nz])
    out[nz] = h1 / (h1 + 1j * h0)
    return out


def section_gaf(p, semichord: float, a: float, circulation=None) -> np.ndarray:
    """Section Q(p) (per unit span) for coordinates [h, α]; p = s b / V (p = ik harmonic).

    ``a``: elastic-axis position aft of mid-chord in semichords. ``circulation``: C as a function
    of p (default Theodorsen's exact C(k) on p = ik).
    """
    p = np.asarray(p, dtype=complex).reshape(-1)
    b = float(semichord)
    c = theodorsen_function(p.imag) if circulation is None else np.asarray(circulation(p))
    q = np.empty((len(p), 2, 2), dtype=complex)
    q[:, 0, 0] = 2 * np.pi * p**2 + 4 * np.pi * c * p
    q[:, 0, 1] = -(2 * np.pi * b * (p - a * p**2) + 4 * np.pi * c * b * (1 + (0.5 - a) * p))
    q[:, 1, 0] = 2 * np.pi * b * a * p**2 + 4 * np.pi * (a + 0.5) * c * b * p
    q[:, 1, 1] = -(
        -2 * np.pi * b**2 * (0.5 - a) * p
        - 2 * np.pi * b**2 * (1 / 8 + a**2) * p**2
        + 4 * np.pi * (a + 0.5) * c * b**2 * (1 + (0.5 - a) * p)
    )
    return q


@dataclass(frozen=True)
class TypicalSection:
    """Two-DOF airfoil (plunge h up, pitch α nose up), per unit span, consistent units.

    semichord b; a: elastic axis aft of mid-chord (semichords); x_alpha: CG aft of the elastic
    axis (semichords); r_alpha²: (radius of gyration about the EA / b)²; mass per unit span m;
    uncoupled frequencies omega_h, omega_alpha (rad/s).
    """

    semichord: float
    a: float
    x_alpha: float
    r_alpha_sq: float
    mass: float
    omega_h: float
    omega_alpha: float

    def __post_init__(self):
        if min(self.semichord, self.r_alpha_sq, self.mass, self.omega_h, self.omega_alpha) <= 0:
            raise InputError("typical section: b, r_alpha², mass and frequencies must be positive")

    def mass_matrix(self) -> np.ndarray:
        m, b = self.mass, self.semichord
        s_alpha = m * self.x_alpha * b
        return np.array([[m, -s_alpha], [-s_alpha, m * self.r_alpha_sq * b**2]])

    def stiffness_matrix(self) -> np.ndarray:
        m, b = self.mass, self.semichord
        return np.diag([m * self.omega_h**2, m * self.r_alpha_sq * b**2 * self.omega_alpha**2])

    def density_for_mass_ratio(self, mu: float) -> float:
        """Air density giving the mass ratio μ = m / (π ρ b²)."""
        return self.mass / (mu * np.pi * self.semichord**2)

    def gaf(self, k) -> np.ndarray:
        """Exact-Theodorsen Q(ik), shape (nk, 2, 2)."""
        return section_gaf(1j * np.asarray(k, dtype=float), self.semichord, self.a)
