"""Steady (k = 0) aerodynamics on the panels: the vortex-lattice solution of the doublet-lattice
method at zero frequency (Nastran's SOL 144 aerodynamics), for a rigid incidence and for any
box motion.

The generalized force of the boxes' pressures on a motion i is Q_ij (k = 0) of
:func:`torchrom.aero.dlm.compute_gaf` (F_i = −q∞ Q_ij x_j, the paper's sign): the same
influence coefficients, splines and symmetry as the flutter path. Written here only what a
rigid incidence is: a rotation α about the aero frame's y axis (flow along +x, nose up for
α > 0) displaces a box point p by α ŷ × (p − o), so its normal motion is h = n · (ŷ × (p − o))
and its streamwise slope ∂h/∂x = n · (ŷ × x̂) = −n_z per unit α.
The loads stay on the undeformed boxes (non-follower): the boxes are where the panel cards put
them, their normals do not turn with the structure.
"""

from __future__ import annotations

import numpy as np

from .dlm import GAF, BoxMotion, compute_gaf
from .panels import AeroPanels


def incidence_motion(panels: AeroPanels, origin=(0.0, 0.0, 0.0)) -> BoxMotion:
    """Box motion (1 row) of a rigid nose-up incidence of 1 rad about the aero y axis through
    ``origin`` (aero frame; the origin moves h, not the k = 0 normalwash)."""
    y = np.array([0.0, 1.0, 0.0])
    n = panels.normals

    def normal_motion(points):
        return np.einsum("ij,ij->i", n, np.cross(y, points - np.asarray(origin, float)))

    slope = np.einsum("ij,j->i", n, np.cross(y, [1.0, 0.0, 0.0]))
    return BoxMotion(normal_motion(panels.doublet_points)[None],
                     normal_motion(panels.control_points)[None], slope[None])


def stack_motions(*motions: BoxMotion) -> BoxMotion:
    """One motion whose rows are those of ``motions`` in order."""
    return BoxMotion(np.vstack([m.h_load for m in motions]),
                     np.vstack([m.h_control for m in motions]),
                     np.vstack([m.slope_control for m in motions]))


def steady_gaf(panels: AeroPanels, motion: BoxMotion, mach: float, semichord: float,
               kernel: str = "parabolic") -> np.ndarray:
    """Q(k = 0) (n, n) real, for the n rows of ``motion`` (F_i = −q∞ Q_ij x_j)."""
    gaf = compute_gaf(panels, motion, mach, [0.0], semichord, kernel)
    return np.asarray(gaf.Q[0].real)


def with_incidence(motion: BoxMotion, panels: AeroPanels) -> BoxMotion:
    """``motion``'s rows followed by a unit incidence (:func:`incidence_motion`): one DLM
    solve then gives the modal GAFs and the modal load of the incidence together."""
    return stack_motions(motion, incidence_motion(panels))


def split_incidence(gaf: GAF) -> tuple[GAF, np.ndarray]:
    """(the GAFs of all rows but the last, Q_iα (m,) the k = 0 generalized force of the last
    row, a unit incidence, on each of the others: F_i = −q∞ Q_iα α) of a GAF computed on
    :func:`with_incidence`'s motion; its k must contain 0."""
    zero = np.flatnonzero(gaf.k == 0.0)
    if not len(zero):
        raise ValueError("split_incidence: the GAF has no k = 0")
    m = gaf.n_modes - 1
    return gaf.subset(m), np.asarray(gaf.Q[zero[0], :m, m].real)
