"""Rigid-body modes of an unconstrained or under-constrained model, built from its geometry.

A free-free structure's rigid-body modes are, up to a basis change, the rigid
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

from ..errors import InputError

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


def rigid_motions_on_free(T: sp.spmatrix, xyz: np.ndarray):
    """(X (n_free, 6), misfit R - T X, R): the free-DOF vectors closest (least squares) to the
    six :func:`rigid_motions`; a motion the constraints block leaves a misfit of order one."""
    T = sp.csc_matrix(T)
    R = rigid_motions(xyz)
    # least squares u = (TᵀT)⁻¹ Tᵀ R: T has full column rank (each free DOF drives a grid DOF)
    X = sla.splu(sp.csc_matrix(T.T @ T)).solve(np.asarray(T.T @ R))
    return X, R - T @ X, R


def admissible_rigid_shapes(T: sp.spmatrix, xyz: np.ndarray) -> np.ndarray:
    """Free-DOF shapes (n_free, r) spanning the rigid motions that ``u_all = T u`` can represent
    (T: free DOFs → all grid DOFs in basic axes, as ``FEModel.T``)."""
    X, miss, R = rigid_motions_on_free(T, xyz)
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


def suport_dofs(fe) -> list[tuple[int, int]]:
    """(grid, component) of the deck's SUPORT entries and of the SUPORT1 set that case control
    selects (MSC QRG SUPORT/SUPORT1: the r-set that Nastran uses to compute its rigid-body
    modes); empty when the model has no deck or none of them."""
    model = getattr(fe, "bdf", None)
    if model is None:
        return []
    out = []
    cards = list(getattr(model, "suport", []))
    cc = model.case_control_deck
    if cc is not None:
        for sub in cc.subcases.values():
            if sub.has_parameter("SUPORT1")[0]:
                card = model.suport1.get(int(sub.get_parameter("SUPORT1")[0]))
                if card is not None and card not in cards:
                    cards.append(card)
    for card in cards:
        for gid, comps in zip(card.node_ids, card.Cs):
            out += [(int(gid), int(c)) for c in str(comps) if c in "123456"]
    return list(dict.fromkeys(out))


def suport_note(fe, rigid: np.ndarray) -> str | None:
    """A note on the deck's SUPORT r-set against the rigid-body shapes ``rigid`` (n_free, r):
    Nastran computes its rigid-body modes from the r-set, which takes a statically determinate
    set, as many DOFs as rigid-body modes with the shapes' r × r block on them non-singular.
    None when the deck has no SUPORT."""
    dofs = suport_dofs(fe)
    if not dofs:
        return None
    r = rigid.shape[1]
    rows = []
    for gid, comp in dofs:
        try:
            rows.append(fe.dof_index(gid, comp, what="SUPORT"))
        except InputError:  # a DOF that is constrained or dependent: Nastran rejects it too
            return (f"SUPORT: grid {gid} component {comp} is not an independent DOF; the "
                    f"{r} rigid-body modes come from the geometry")
    block = rigid[rows, :]
    sv = np.linalg.svd(block, compute_uv=False) if block.size else np.zeros(0)
    rank = int(np.sum(sv > 1e-8 * sv.max())) if len(sv) else 0
    if len(rows) == r and rank == r:
        return (f"SUPORT: {r} DOFs, a statically determinate r-set for the {r} rigid-body "
                f"modes (the same span as Nastran's)")
    return (f"SUPORT: {len(rows)} DOFs of rank {rank} for {r} rigid-body modes (Nastran wants "
            f"as many, statically determinate); the rigid-body modes come from the geometry")


def modal_basis_with_rigid(fe, modes, n_total: int | None, notes: list[str]):
    """Frequencies and shapes of Nastran's modal basis: the rigid-body modes first (0 Hz exactly,
    :func:`rigid_body_modes`), then the elastic ones, ``n_total`` in all (None:
    every mode computed). Nastran counts its rigid-body modes among ND and LMODES."""
    f = np.asarray(modes.frequencies_hz)
    shapes = np.asarray(modes.shapes)
    if not modes.n_rigid:
        return (f, shapes) if n_total is None else (f[:n_total], shapes[:, :n_total])
    rigid, how = rigid_body_modes(fe, modes)
    r = rigid.shape[1]
    n_el = len(f) if n_total is None else max(n_total - r, 0)
    elastic = orthogonalise_against(shapes[:, :n_el], rigid, fe.mass_matrix())
    notes.append(f"{r} rigid-body mode(s) kept in the modal basis at 0 Hz ({how}; the "
                 f"eigensolver gave ω² = "
                 + ", ".join(f"{x:.2g}" for x in modes.rigid_eigenvalues) + ")")
    note = suport_note(fe, rigid)
    if note:
        notes.append(note)
    n = r + n_el if n_total is None else min(n_total, r + n_el)
    return (np.concatenate([np.zeros(r), f[:n_el]])[:n],
            np.concatenate([rigid, elastic], axis=1)[:, :n])
