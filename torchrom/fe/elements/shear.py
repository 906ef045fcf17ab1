"""CSHEAR/PSHEAR: shear panel carrying in-plane shear only.

One integration point at the panel centre whose only constitutive term is
G t A on the Green shear strain 2E12 (Voigt C = diag(0, 0, G t A)); the panel therefore has no
extensional stiffness (PSHEAR F1 = F2 = 0, the edges' rods carry the direct stresses) and, through
the Green strain, stays geometrically nonlinear and rigid-rotation invariant. For a rectangular
panel this is the constant-shear-flow panel of Nastran's CSHEAR. Mass as the CQUAD4 membrane.
"""

from __future__ import annotations

import numpy as np

from ..mesh import ShearSet
from .green import GreenPoints
from .quad4 import area_mass_blocks, jacobian, quad_frames, shape


def shear_points(shears: ShearSet, xyz: np.ndarray) -> GreenPoints:
    _, xy = quad_frames(xyz[shears.nodes])
    _, det, dxy = jacobian(xy, shape(0.0, 0.0)[1])
    C = np.zeros((len(shears), 3, 3))
    C[:, 2, 2] = shears.G * shears.t * 4.0 * det
    return GreenPoints("CSHEAR", shears.eids.copy(), shears.nodes.copy(), dxy, C)


def shear_mass_blocks(shears: ShearSet, xyz: np.ndarray, coupled: bool):
    return area_mass_blocks(xyz, shears.nodes, shears.rho * shears.t + shears.nsm, coupled)
