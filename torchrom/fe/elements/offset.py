"""CQUAD4/CTRIA3 with ZOFFS: the shell's reference plane offset from the plane of its grids.

MSC Nastran Quick Reference Guide (CQUAD4, CTRIA3, field ZOFFS): the element's
reference plane lies at z0 = ZOFFS along the element normal (G1-G2-G3 right-hand rule, the
normal of :func:`~torchrom.fe.elements.quad4.quad_frames` / ``tria_frames``) from the plane of
the grids. Each grid is tied to its point of the reference plane by a rigid offset (small
rotations), u_ref = u + θ × (z0 n) = u − [z0 n]× θ, θ_ref = θ, and the element's matrices, formed
on the reference plane by the unchanged element modules, are transformed K = Tᵀ K_ref T.
The membrane strain at the reference plane is then ε + z0 κ: the membrane–bending coupling
B = z0 A and D + z0² A of plate theory (Reddy, *Mechanics of Laminated Composite Plates and
Shells*, §3.3, for a laminate whose reference surface is moved by z0), with A integrated by the
membrane's own rule (normal strains at 2×2 Gauss points, the in-plane shear at the centre for the
quad; one point for the triangle), so the offset twisting stiffness z0² A66 of a quad is
integrated at its centre. For the triangle the offset part z0² A acts on the constant gradient
of the linearly interpolated grid rotations (the CST membrane), the plate's own D on DKT's
curvatures; the two agree as the mesh converges (two plates at ZOFFS = ±t/2 vs one of 2t, tip
deflection of a cantilever strip, ν = 0.3: 0.67 %, 0.36 %, 0.22 %, 0.11 % apart on 10×2, 20×4,
40×8, 80×16 cells; ν = 0: 0.60 %, 0.15 %, 0.037 %, 0.009 %).

Choices, stated because they change numbers:

- **Linear only**: the offset is a small-rotation transformation, so an offset element enters
  the model through its linear stiffness (membrane at u = 0, bending, drilling), and the
  model refuses the nonlinear analyses (internal forces, tangents, nonlinear static/transient,
  reduced-order models) of a deck with ZOFFS (:class:`~torchrom.fe.model.FEModel`); modes,
  linear statics and flutter are unaffected.
- **Drilling** stays at the grids: the drilling spring (θz − ω) is a numerical stabiliser, not
  part of A, and moving it would add a spurious z0² drilling stiffness to the bending.
- **Mass** (ρ t + NSM per area, lumped or consistent as without offset) sits on the reference
  plane: M = Tᵀ M_ref T, which adds the rotary inertia m z0² about the in-plane axes and the
  translation–rotation coupling of a mass at a distance z0 (the lumped mass is then no longer
  diagonal, as for an offset CONM2). The plate's own rotary inertia about its mid-plane stays
  neglected, as without offset.
- Loads stay at the grids: a pressure acts along the normal, parallel to the offset, so moving
  it to the reference plane would change nothing; a PLOAD4 with an in-plane direction (N1–N3)
  would gain a moment z0 × F there, which is not added.
"""

from __future__ import annotations

import numpy as np

from ..mass import rigid_links
from ..mesh import QuadSet, TriaSet
from .green import GreenKernel
from .quad4 import area_mass_blocks, bending_blocks, membrane_points, quad_dofs, quad_frames
from .tria3 import tria_bending_blocks, tria_dofs, tria_frames, tria_mass_blocks, tria_points


def offset_transform(normal: np.ndarray, z0: np.ndarray, nn: int) -> np.ndarray:
    """T (n, 6nn, 6nn) from the grids' six DOFs to the reference plane's: per grid the rigid
    link to the point z0 n from it (:func:`~torchrom.fe.mass.rigid_links`)."""
    block = rigid_links(z0[:, None] * normal)
    T = np.zeros((len(z0), 6 * nn, 6 * nn))
    for a in range(nn):
        T[:, 6 * a : 6 * a + 6, 6 * a : 6 * a + 6] = block
    return T


def _translations_to_six(blocks: np.ndarray, nn: int) -> np.ndarray:
    """Blocks on the translations (n, 3nn, 3nn) placed on six DOFs per grid (n, 6nn, 6nn)."""
    idx = (6 * np.arange(nn)[:, None] + np.arange(3)).reshape(-1)
    out = np.zeros((len(blocks), 6 * nn, 6 * nn))
    out[:, idx[:, None], idx[None, :]] = blocks
    return out


def _membrane_linear(points, xyz: np.ndarray, n: int, nn: int) -> np.ndarray:
    """The Green-strain membrane's stiffness at u = 0 (n, 6nn, 6nn), summed over each element's
    integration points (``points`` lists them point by point, all elements each time)."""
    per_point = GreenKernel(points, xyz).point_matrices(np.zeros(6 * len(xyz)), geometric=0.0)
    return _translations_to_six(per_point.reshape(-1, n, 3 * nn, 3 * nn).sum(axis=0), nn)


def _bending_and_drilling(shells, xyz, drilling, blocks_of, nn):
    """(bending, drilling) stiffness (n, 6nn, 6nn) of all elements (zero where membrane only).

    The element modules return bending + drilling together; the drilling part is their
    difference with drilling = 0, so that only the bending is moved to the reference plane."""
    n = len(shells)
    sel = shells.bend_E > 0
    bend, drill = np.zeros((n, 6 * nn, 6 * nn)), np.zeros((n, 6 * nn, 6 * nn))
    if sel.any():
        bend[sel] = blocks_of(shells, xyz, 0.0)[1]
        drill[sel] = blocks_of(shells, xyz, drilling)[1] - bend[sel]
    return bend, drill


def _normals(shells, xyz) -> np.ndarray:
    X = xyz[shells.nodes]
    return (quad_frames(X)[0] if isinstance(shells, QuadSet) else tria_frames(X)[0])[:, 2]


def offset_stiffness_blocks(shells: QuadSet | TriaSet, xyz: np.ndarray, drilling: float = 1e-4):
    """(dofs, K) of offset quads or triangles: membrane and bending on the reference plane,
    drilling at the grids, on six DOFs per grid (basic)."""
    quad = isinstance(shells, QuadSet)
    nn, n = (4 if quad else 3), len(shells)
    points = membrane_points(shells, xyz) if quad else tria_points(shells, xyz)
    blocks_of = bending_blocks if quad else tria_bending_blocks
    K_ref = _membrane_linear(points, xyz, n, nn)
    bend, drill = _bending_and_drilling(shells, xyz, drilling, blocks_of, nn)
    T = offset_transform(_normals(shells, xyz), shells.zoffs, nn)
    K = T.transpose(0, 2, 1) @ (K_ref + bend) @ T + drill
    return (quad_dofs if quad else tria_dofs)(shells.nodes), K


def offset_mass_blocks(shells: QuadSet | TriaSet, xyz: np.ndarray, coupled: bool):
    """(dofs, M) of offset quads or triangles: the translational mass on the reference plane
    (ρ t + NSM per area, lumped or consistent as without offset), on six DOFs per grid."""
    quad = isinstance(shells, QuadSet)
    nn = 4 if quad else 3
    if quad:
        M3 = area_mass_blocks(xyz, shells.nodes, shells.rho * shells.t + shells.nsm, coupled)[1]
    else:
        M3 = tria_mass_blocks(shells, xyz, coupled)[1]
    T = offset_transform(_normals(shells, xyz), shells.zoffs, nn)
    M = T.transpose(0, 2, 1) @ _translations_to_six(M3, nn) @ T
    return (quad_dofs if quad else tria_dofs)(shells.nodes), M
