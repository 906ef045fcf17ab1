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


def goland_output_points(mesh) -> dict[str, tuple[int, int]]:
    """Point A: the grid nearest (2, 20, +0.16667) ft (upper skin, tip, mid-box)."""
    target = np.array([2.0, SPAN, DEPTH / 2.0])
    k = int(np.argmin(np.linalg.norm(mesh.xyz - target, axis=1)))
    gid = int(mesh.grid_ids[k])
    return {"A_Tx": (gid, 1), "A_Ty": (gid, 2), "A_Tz": (gid, 3)}
