"""An independent reference for 3-D large rotations: the inextensible, unshearable Kirchhoff rod
(a cantilever along x, clamped at x = 0) under a dead force F applied at the end of a rigid arm
that turns with the tip section.

Written for the tests, sharing no code with torchrom's FE: the cantilever is statically
determinate, so the moment at every station follows from the current shape alone,
m(s) = (p − r(s)) × F with p = r(L) + R(L) d the load's point; the body curvature is
κ(s) = C⁻¹ R(s)ᵀ m(s) (C = diag(GJ, EI_y, EI_z) about the body axis, the chord and the normal)
and the shape is integrated from the root, R' = R [κ×] (exact exponentials of the midpoint
curvature per segment), r' = R e_x. The shape is iterated to a fixed point (relaxed by one half)
under a load raised in steps.
"""

from __future__ import annotations

import numpy as np


def _exp(v: np.ndarray) -> np.ndarray:
    """exp([v×]) of rotation vectors v (n, 3)."""
    phi = np.linalg.norm(v, axis=1)[:, None, None]
    K = np.zeros((len(v), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    K -= K.transpose(0, 2, 1)
    small = phi < 1e-8
    a = np.where(small, 1.0, np.sin(phi) / np.where(small, 1.0, phi))
    b = np.where(small, 0.5, (1.0 - np.cos(phi)) / np.where(small, 1.0, phi**2))
    return np.eye(3) + a * K + b * K @ K


def cantilever_tip(L: float, stiffness, force, arm, *, n: int = 200, steps: int = 10,
                   tol: float = 1e-11, max_iter: int = 2000):
    """(R(L), r(L)): the tip section's rotation and position of the rod above under ``force``
    (3,) at ``arm`` (3, in the tip section's axes) from the tip; ``stiffness`` (GJ, EI_y, EI_z).
    Discretisation error O(1/n²)."""
    h = L / n
    c_inv = 1.0 / np.asarray(stiffness, dtype=float)
    force, arm = np.asarray(force, dtype=float), np.asarray(arm, dtype=float)
    R = np.repeat(np.eye(3)[None], n + 1, axis=0)
    r = np.zeros((n + 1, 3))
    r[:, 0] = np.linspace(0.0, L, n + 1)
    for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
        F = lam * force
        for _ in range(max_iter):
            p = r[-1] + R[-1] @ arm
            m = np.cross(p - r, F)
            kappa = np.einsum("nji,nj->ni", R, m) * c_inv
            mid = 0.5 * (kappa[:-1] + kappa[1:])
            step, half = _exp(h * mid), _exp(0.5 * h * mid)
            R_new, r_new = np.empty_like(R), np.empty_like(r)
            R_new[0], r_new[0] = np.eye(3), 0.0
            for i in range(n):
                r_new[i + 1] = r_new[i] + h * (R_new[i] @ half[i])[:, 0]
                R_new[i + 1] = R_new[i] @ step[i]
            change = np.abs(r_new - r).max()
            R, r = 0.5 * (R + R_new), 0.5 * (r + r_new)
            U, _, Vt = np.linalg.svd(R)  # back onto rotations after the relaxation
            R = U @ Vt
            if change < tol * L:
                break
        else:
            raise RuntimeError(f"kirchhoff rod: no fixed point at load factor {lam:.3g}")
    return R[-1], r[-1]
