"""PCOMP laminates as the equivalent shell stiffness of classical lamination theory.

Written here (Jones, Mechanics of Composite Materials, 2nd ed., Sec. 4.3, Eqs. 4.22–4.28): each
ply k (material MAT1 or MAT8, thickness t_k, angle θ_k from the element's material x axis,
between z_(k−1) and z_k measured from the reference plane, the first ply at Z0) contributes its
transformed plane-stress matrix Q̄_k to

    A = Σ Q̄_k (z_k − z_(k−1)),  B = ½ Σ Q̄_k (z_k² − z_(k−1)²),  D = ⅓ Σ Q̄_k (z_k³ − z_(k−1)³).

The shell elements take A (membrane) and D (bending) in their own element axes; a laminate with
membrane–bending coupling (B ≠ 0: unsymmetric lay-up or an offset Z0) is refused, since the
elements have no coupling term. Transverse shear: 5/6 Σ t_k (G1Z + G2Z)/2 (MAT8) or 5/6 Σ t_k G
(MAT1) — Nastran derives its own from the ply stresses; thin laminates hardly depend on it.
The element's THETA rotates the material axes from the element x axis (MCID is refused).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class Laminate:
    """Equivalent shell stiffness: ``A`` (force/strain), ``D`` (moment/curvature), 3×3 in
    Voigt [xx, yy, 2xy] element axes; ``shear`` (transverse shear force/strain), ``thickness``,
    ``mass_per_area`` (Σ ρ_k t_k, without NSM)."""

    A: np.ndarray
    D: np.ndarray
    shear: float
    thickness: float
    mass_per_area: float


def ply_q(mat, owner: str) -> tuple[np.ndarray, float, float]:
    """Plane-stress Q (material axes), transverse shear modulus and density of a ply."""
    if mat.type == "MAT8":
        e1, e2, nu12 = float(mat.e11), float(mat.e22), float(mat.nu12)
        nu21 = nu12 * e2 / e1
        den = 1.0 - nu12 * nu21
        Q = np.array([[e1 / den, nu12 * e2 / den, 0.0], [nu12 * e2 / den, e2 / den, 0.0],
                      [0.0, 0.0, float(mat.g12)]])
        gz = 0.5 * (float(mat.g1z or 0.0) + float(mat.g2z or 0.0))
        return Q, gz, float(mat.rho or 0.0)
    if mat.type == "MAT1":
        E, nu = float(mat.e or 0.0), float(mat.nu or 0.0)
        G = float(mat.g or 0.0) or E / (2.0 * (1.0 + nu))
        c = E / (1.0 - nu**2)
        Q = np.array([[c, c * nu, 0.0], [c * nu, c, 0.0], [0.0, 0.0, G]])
        return Q, G, float(mat.rho or 0.0)
    raise InputError(f"{owner}: ply material {mat.mid} is a {mat.type}; expected MAT1 or MAT8")


def rotate_q(Q: np.ndarray, theta_deg: float) -> np.ndarray:
    """Q̄ = T⁻¹ Q T⁻ᵀ for a ply at θ from the x axis (Jones Eq. 2.84, engineering shear)."""
    c, s = np.cos(np.radians(theta_deg)), np.sin(np.radians(theta_deg))
    T = np.array([[c * c, s * s, 2 * c * s], [s * s, c * c, -2 * c * s],
                  [-c * s, c * s, c * c - s * s]])
    R = np.diag([1.0, 1.0, 2.0])
    Tbar = R @ T @ np.linalg.inv(R)  # strain transformation (engineering shear)
    return Tbar.T @ Q @ Tbar


def laminate(prop, materials: dict, theta_element: float = 0.0) -> Laminate:
    """Equivalent A, D of a PCOMP (pyNastran card; LAM=SYM expanded by pyNastran)."""
    owner = f"PCOMP {prop.pid}"
    lam = str(prop.lam or "").upper()
    if lam not in ("", "SYM", "MEM", "BEND", "SMEAR", "SMCORE"):
        raise InputError(f"{owner}: field LAM: {prop.lam} is not supported")
    if lam in ("MEM", "BEND", "SMEAR", "SMCORE"):
        raise InputError(f"{owner}: field LAM: {lam} is not supported (blank or SYM)")
    ts = np.asarray(prop.get_thicknesses(), dtype=float)
    thetas = np.asarray(prop.get_thetas(), dtype=float) + float(theta_element)
    mids = np.asarray(prop.get_material_ids(), dtype=int)
    if np.any(ts <= 0):
        raise InputError(f"{owner}: field T: expected positive ply thicknesses, got {ts.tolist()}")
    total = float(ts.sum())
    z0 = -0.5 * total if prop.z0 is None else float(prop.z0)
    z = z0 + np.concatenate(([0.0], np.cumsum(ts)))
    A, B, D = (np.zeros((3, 3)) for _ in range(3))
    shear = mass = 0.0
    for k, (mid, t, th) in enumerate(zip(mids, ts, thetas)):
        mat = materials.get(int(mid))
        if mat is None:
            raise InputError(f"{owner}: ply {k + 1}: material {mid} not found")
        Q, gz, rho = ply_q(mat, owner)
        Qb = rotate_q(Q, th)
        A += Qb * (z[k + 1] - z[k])
        B += 0.5 * Qb * (z[k + 1] ** 2 - z[k] ** 2)
        D += Qb * (z[k + 1] ** 3 - z[k] ** 3) / 3.0
        shear += 5.0 / 6.0 * gz * t
        mass += rho * t
    if np.abs(B).max() > 1e-9 * np.abs(A).max() * total:
        raise InputError(f"{owner}: the laminate couples membrane and bending (B ≠ 0: unsymmetric "
                         "lay-up or offset Z0), which the shell elements do not model")
    return Laminate(A, D, shear, total, mass)
