"""Rigid-body modes of an unconstrained or under-constrained model, built from its geometry.

Hand-written. A free-free structure's rigid-body modes are, up to a basis change, the rigid
motions u(x) = t + θ × (x − x₀) of its grids that its constraints admit. An eigensolver returns
them as eigenvectors of tiny eigenvalues (round-off, of either sign, e.g. 4e-8 Hz in the
bah_plane f06): their span is right to round-off but their frequencies are noise. Nastran
computes them instead from the SUPORT (r-set) DOFs, as the static shapes D = −K_ll⁻¹ K_lr of a
statically determinate support (MSC Nastran Dynamic Analysis User's Guide, "Rigid-body modes";
QRG, SUPORT), with zero eigenvalue by construction. The span of the rigid motions the
constraints admit is the same subspace without needing the support set, so it is what is built
here: :func:`rigid_body_modes` returns mass-orthonormal shapes with ω² = 0 exactly.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

#: a rigid motion is admitted when the part of it that the free DOFs cannot represent is below
#: this fraction of its size (exact rigid motions are represented to round-off, ~1e-15; one that
#: a constraint blocks misses by order 1)
ADMISSIBLE_TOL = 1e-8
#: a rigid shape's strain energy relative to that of the stiffness scale: round-off (~1e-15)
#: for a true rigid-body mode; a grounded spring (CELAS to ground) makes it order 1
ENERGY_TOL = 1e-8


def rigid_motions(xyz: np.ndarray) -> np.ndarray:
    """(6 n_grid, 6): unit translations along x, y, z and rotations about x, y, z through the
    grids' centroid, scaled by the model's size so that all six columns are of order one."""
    xyz = np.asarray(xyz, dtype=float)
    n = len(xyz)
    r = xyz - xyz.mean(axis=0)
    size = float(np.abs(r).max(initial=0.0)) or 1.0
    out = np.zeros((n, 6, 6))
    for a in range(3):
        out[:, a, a] = 1.0
        axis = np.zeros(3)
        axis[a] = 1.0
        out[:, :3, 3 + a] = np.cross(axis, r) / size
        out[:, 3 + a, 3 + a] = 1.0 / size
    return out.reshape(6 * n, 6)


def admissible_rigid_shapes(T: sp.spmatrix, xyz: np.ndarray) -> np.ndarray:
    """Free-DOF shapes (n_free, r) spanning the rigid motions that ``u_all = T u`` can represent
    (T: free DOFs → all grid DOFs in basic axes, as ``FEModel.T``)."""
    T = sp.csc_matrix(T)
    R = rigid_motions(xyz)
    # least squares u = (TᵀT)⁻¹ Tᵀ R: T has full column rank (each free DOF drives a grid DOF)
    X = sla.splu(sp.csc_matrix(T.T @ T)).solve(np.asarray(T.T @ R))
    miss = R - T @ X
    # combinations c of the six motions with T X c = R c: the null space of the misfit
    _, sv, vt = np.linalg.svd(miss, full_matrices=True)
    sv = np.concatenate([sv, np.zeros(6 - len(sv))])
    keep = sv <= ADMISSIBLE_TOL * np.linalg.norm(R, axis=0).max()
    return X @ vt[keep].T


def mass_orthonormal(G: np.ndarray, M: sp.spmatrix) -> np.ndarray:
    """Columns of G recombined so that Gᵀ M G = I (a massless combination is dropped)."""
    mg = G.T @ (M @ G)
    w, v = np.linalg.eigh(0.5 * (mg + mg.T))
    keep = w > 1e-12 * max(float(w.max(initial=0.0)), 1e-300)
    return G @ (v[:, keep] / np.sqrt(w[keep]))


def rigid_body_modes(fe, modes) -> tuple[np.ndarray, str]:
    """(shapes (n_free, r), how): mass-orthonormal rigid-body shapes of ``fe`` whose modes are
    ``modes`` (:class:`torchrom.fe.solvers.Modes`, r = ``modes.n_rigid``).

    The geometric shapes (:func:`admissible_rigid_shapes`) when they are r, strain-free and span
    the eigensolver's rigid shapes; otherwise (scalar points, a mechanism that is not a rigid
    motion) the eigensolver's, re-orthonormalised, and ``how`` says so."""
    from .solvers import stiffness_mass_scale

    M, K = fe.mass_matrix(), fe.stiffness_matrix()
    eig = np.asarray(modes.rigid_shapes)
    r = eig.shape[1]
    G = admissible_rigid_shapes(fe.T, fe.grid_xyz)
    if G.shape[1] == r and r > 0:
        G = mass_orthonormal(G, M)
        scale = stiffness_mass_scale(K, M)
        strain = np.abs(G.T @ (K @ G)).max(initial=0.0)
        # the eigensolver's shapes must lie in the geometric span (M-projection residual)
        rest = eig - G @ (G.T @ (M @ eig))
        if G.shape[1] == r and strain <= ENERGY_TOL * scale and (
                np.sqrt(np.einsum("ik,ik->k", rest, M @ rest)).max(initial=0.0) <= 1e-6):
            return G, "rigid motions of the grids admitted by the constraints"
    return mass_orthonormal(eig, M), ("the eigensolver's zero-frequency shapes (they are not "
                                      "rigid motions of the grids)")


def orthogonalise_against(shapes: np.ndarray, rigid: np.ndarray, M: sp.spmatrix) -> np.ndarray:
    """``shapes`` minus their M-projection on the (M-orthonormal) ``rigid`` shapes."""
    return shapes - rigid @ (rigid.T @ (M @ shapes))
