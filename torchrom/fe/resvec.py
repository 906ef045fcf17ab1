"""Residual vectors (Nastran RESVEC, inertia-relief loads): static shapes added to a modal basis.

Nastran augments the eigenmodes of a modal solution with residual vectors, the
static responses to load patterns, made orthogonal to the modes (its "REAL EIGENVALUES (AFTER
AUGMENTATION OF RESIDUAL VECTORS)" table; Case Control RESVEC, MSC QRG: INRLOD "residual vectors
based on inertia relief", APPLOD applied loads, RVDOF unit loads, DAMPLOD viscous dampers). Only
the inertia-relief kind applies to a flutter deck without loads or dampers, and only it is built
here: the loads are the inertia forces M D of unit rigid-body accelerations (the six rigid motions
D of the grids, on the free DOFs); on a structure with rigid-body modes G they are first
relieved (F - M G Gᵀ F) and the response is taken orthogonal to G. The responses are made
M-orthogonal to the modal basis Φ (then also K-orthogonal: K Φ = M Φ Λ), dependent ones dropped,
and recombined by a Rayleigh–Ritz solve on their own span (they are already uncoupled from Φ), so
the augmented basis stays mass-normalised with a diagonal stiffness.

Measured against Nastran's augmented tables: bah_plane (8 modes, 2 of them rigid; 4 vectors):
56.557 Hz as Nastran's, 39.02, 119.31, 179.08 Hz where Nastran has 41.23, 120.58, 180.32; pt145
(clamped, 6 modes; 3 vectors): 1711.82 Hz as Nastran's, 1388.97 and 2916.46 where it has 1394.46
and 3112.26. The span is the same kind but not Nastran's: its exact load set is not documented
in the sources at hand (tests/test_public_decks.py).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from .rigid import orthogonalise_against, rigid_motions_on_free
from .solvers import inertia_relief_solve

#: a residual vector whose squared M-norm after orthogonalisation against the basis (and the
#: other vectors) is below this fraction of the largest response's is dependent and dropped
DEPENDENT_TOL = 1e-10


def inertia_residual_vectors(fe, basis: np.ndarray, rigid: np.ndarray | None = None):
    """(frequencies_hz (r,), vectors (n_free, r)) of the inertia-relief residual vectors of
    ``fe`` against the mass-normalised modal ``basis`` (n_free, m), whose rigid-body columns are
    ``rigid`` (None: a restrained structure). Ascending; mass-normalised, M- and K-orthogonal to
    ``basis``."""
    M = sp.csr_matrix(fe.mass_matrix())
    K = sp.csc_matrix(fe.stiffness_matrix())
    X, _, _ = rigid_motions_on_free(fe.T, fe.grid_xyz)
    loads = M @ X
    if rigid is not None and rigid.shape[1]:
        # inertia relief: the rigid-body part of the loads accelerates the body, it does not
        # deform it (the response M-orthogonal to G)
        U = inertia_relief_solve(K, M, rigid, np.asarray(loads))
    else:
        U = sla.splu(K).solve(np.asarray(loads))
    size = float(np.einsum("ik,ik->k", U, M @ U).max(initial=0.0))
    U = orthogonalise_against(U, basis, M)
    mm = U.T @ (M @ U)
    w, v = np.linalg.eigh(0.5 * (mm + mm.T))
    # relative to the responses before the projection: when the basis spans them (a model with
    # as many modes as DOFs, 0012_flutter) what is left is round-off, not a vector
    keep = w > DEPENDENT_TOL * max(size, 1e-300)
    U = U @ (v[:, keep] / np.sqrt(w[keep]))
    if U.shape[1] == 0:
        return np.zeros(0), U
    kk = U.T @ (K @ U)
    lam, y = la.eigh(0.5 * (kk + kk.T), U.T @ (M @ U))
    return np.sqrt(np.abs(lam)) / (2 * np.pi), U @ y
