"""The heavy Goland wing's identity in a deck: title, units, planform and output point A.

Kept apart from :mod:`torchrom.fe.goland` (which builds the wing and reads it back through
:mod:`torchrom.fe.bdf_read`) so that the reader can recognise a Goland deck without importing
the builder: no import circle.
"""

from __future__ import annotations

import numpy as np

#: TITLE of the decks written by ``torchrom goland``
GOLAND_TITLE = "torchrom heavy Goland wing"
GOLAND_UNITS = {"length": "ft", "mass": "slug", "time": "s", "force": "lbf"}
SPAN = 20.0  # ft
DEPTH = 0.33334  # ft, box depth
WING_CHORD = (0.0, 6.0)  # ft, leading and trailing edge x
#: The note of a Goland model built with ``rotations="small"`` (the paper's model)
GOLAND_ROTATIONS_NOTE = ("heavy Goland wing: plate bending is small-rotation (linear), as in "
                         "the paper's model and its regression-tested ROM (rotations='small'); "
                         "its membranes are Green-strain nonlinear")


def goland_output_points(fe) -> dict[str, tuple[int, int]]:
    """Point A: the grid nearest the tip's mid-box station on the upper skin, (2, 20, +0.16667)
    ft of the unrotated wing, found in the wing's own axes (:meth:`FEModel.wing_frame`: the
    deck may be rotated); A_Tx, A_Ty, A_Tz are its displacement components along the chord, the
    span and up (InputError where its CD system has no axis along one of them)."""
    from ..errors import InputError

    frame = fe.wing_frame()
    local = frame.local(fe.grid_xyz)
    extent = np.ptp(local, axis=0)
    target = np.array([local[:, 0].max(), 0.0, 0.5 * extent[2]])
    k = int(np.argmin(np.linalg.norm(local - target, axis=1)))
    gid = int(fe.mesh.grid_ids[k])
    cd = fe.mesh.cd_axes[k]  # columns: the grid's displacement axes in basic
    points = {}
    for name, axis in (("A_Tx", frame.chord), ("A_Ty", frame.span), ("A_Tz", frame.up)):
        cos = axis @ cd
        comp = int(np.argmax(np.abs(cos)))
        if abs(abs(cos[comp]) - 1.0) > 1e-6:
            raise InputError(f"{fe.name}: point {name[0]} (grid {gid}): its displacement system "
                             f"(CD) has no axis along the wing's {name[-1]} direction; give the "
                             f"grid a CD system along the wing's axes")
        points[name] = (gid, comp + 1)
    return points
