"""Free-DOF vectors of an FE model as shapes on its grids (:class:`torchrom.rom.shapes.MeshShapes`).

Each vector is expanded through the model's constraints to all grids in the basic frame
(:meth:`FEModel.expand`: SPC'd components zero, RBE2/RBE3/MPC dependents filled in, a CD frame's
components turned to basic), and the mesh is drawn by its shells (CQUAD4 and CSHEAR as quads,
CTRIA3 as triangles) and its line elements (CROD/CONROD, CBAR/CBEAM). Rigid elements, springs,
masses and solids have no face or line here: their grids are kept, their lines are not drawn.
"""

from __future__ import annotations

import numpy as np

from ..rom.shapes import MeshShapes


def mesh_shapes(fe, vectors) -> MeshShapes:
    """The columns of ``vectors`` (n_dof, k) — mode shapes, a ROM basis — on ``fe``'s grids."""
    V = np.asarray(vectors, dtype=float)
    V = V.reshape(-1, 1) if V.ndim == 1 else V
    full = fe.expand(V)  # (k, G, 6) in basic axes
    mesh = fe.mesh
    quads = [np.asarray(mesh.quads.nodes, dtype=np.int64).reshape(-1, 4),
             np.asarray(mesh.shears.nodes, dtype=np.int64).reshape(-1, 4)]
    lines = [np.asarray(mesh.rods.nodes, dtype=np.int64).reshape(-1, 2),
             np.asarray(mesh.bars.nodes, dtype=np.int64).reshape(-1, 2)]
    units = getattr(fe, "units", None) or {}
    return MeshShapes(fe.grid_ids, fe.grid_xyz, np.moveaxis(full, 0, -1),
                      quads=np.concatenate(quads), trias=np.asarray(mesh.trias.nodes,
                                                                    dtype=np.int64),
                      lines=np.concatenate(lines), length_unit=units.get("length"),
                      source=str(getattr(fe, "source", "") or getattr(fe, "name", "")))
