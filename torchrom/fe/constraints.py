"""Constraint elimination: SPC/SPC1/GRID PS, MPC, RBE2/RBAR, RBE1, RBE3 and automatic SPC →
u_all = T u_free.

Every grid has six DOFs measured in its displacement system (CD). The independent
("free") DOFs are the CD components that are neither single-point constrained nor dependent on a
rigid element. Dependent DOFs are eliminated by a **linear** transformation (small rotations):

- MPC: Σ a_i u_i = 0 makes the first term's DOF dependent, u_0 = −Σ_(i>0) (a_i / a_0) u_i;
- RBE2: the dependent components of each GM follow the rigid motion of GN,
  u_m = u_n + θ_n × (x_m − x_n), θ_m = θ_n; RBAR with one end independent is the same;
- RBE1: the same rigid body, its motion fixed by six independent components taken from one or
  several grids (GN_i/CN_i): A (t, θ) = u_ind, then u_dep = B A⁻¹ u_ind with A, B the rows of
  the rigid motion at the independent and dependent components (one function for both);
- RBE3: the reference grid's REFC components are the weighted least-squares rigid-body fit of the
  independent components (Nastran's interpolation element): with the independent grid i at
  d_i = x_i − x_ref, component c along the unit vector e, the fit minimises
  Σ w_i (e·(t + θ × d_i) − u_ic)² over the translation t and rotation θ of the reference;
  rotational components are weighted by w_i L_c² with L_c the mean |d_i| (Nastran's default);
  the rotations of the fit are used only for the REFC components.

Because the RBEs are linear they do not rotate with a large rigid rotation; the Goland store's
RBE3 only carries inertia, so this affects only the store's motion at large amplitudes.
Chains (an RBE whose independent grid is another RBE's dependent grid) are resolved by
substitution; cycles are an error. The resulting T maps free DOFs to the all-grid vector in
**basic** axes (T1..T3, R1..R3 per grid), the layout every element works on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .mass import rigid_links
from .mesh import Mesh

COMPONENT = ("T1", "T2", "T3", "R1", "R2", "R3")


@dataclass
class Constraints:
    """T (n_all × n_free, basic axes) and the bookkeeping behind it."""

    T: sp.csr_matrix
    free: np.ndarray  # (n_free, 2): grid row, component 0..5 (in the grid's CD system)
    status: dict[tuple[int, int], str]  # non-free DOFs: "SPC", "RBE3 12", "AUTOSPC", ...


def _cd_block(cd: np.ndarray) -> np.ndarray:
    B = np.zeros((6, 6))
    B[:3, :3] = cd
    B[3:, 3:] = cd
    return B


def _rigid_map(d: np.ndarray) -> np.ndarray:
    """Map (t, θ) at a point to (translation, rotation) at offset d: [[I, −[d×]], [0, I]]."""
    return rigid_links(d)[0]


def _rigid_rows(mesh: Mesh, pairs, x0: np.ndarray) -> np.ndarray:
    """(k, 6): the (grid row, CD component) ``pairs`` in a small rigid motion (t, θ) (basic)
    of the point x0."""
    return np.array([(_cd_block(mesh.cd_axes[g]).T @ _rigid_map(mesh.xyz[g] - x0))[c]
                     for g, c in pairs]).reshape(-1, 6)


def _rigid_body(mesh: Mesh, independent, dependent, where: str):
    """Dependent DOF → [(coefficient, grid row, component)] of the independent DOFs, for grids
    that move as one rigid body (RBE2, RBE1): the six independent components fix the rigid
    motion (t, θ) of the first independent grid, A (t, θ) = u_ind; each dependent component
    is its row of that motion, u_dep = B A⁻¹ u_ind."""
    g0 = independent[0][0]
    x0 = mesh.xyz[g0]
    if sorted(independent) == [(g0, c) for c in range(6)]:
        Ainv = _cd_block(mesh.cd_axes[g0])  # one grid's six components: its motion, exactly
        independent = [(g0, c) for c in range(6)]
    else:
        A = _rigid_rows(mesh, independent, x0)
        if len(independent) != 6 or np.linalg.matrix_rank(A, tol=1e-10 * np.abs(A).max()) < 6:
            raise InputError(
                f"{where}: the independent components ({len(independent)}) do not determine a "
                "rigid motion (expected six that fix the three translations and rotations)"
            )
        Ainv = np.linalg.inv(A)
    B = _rigid_rows(mesh, dependent, x0) @ Ainv
    return {dof: [(B[i, k], g, c) for k, (g, c) in enumerate(independent) if B[i, k] != 0.0]
            for i, dof in enumerate(dependent)}


def build_constraints(mesh: Mesh, source: str = "model") -> Constraints:
    n = mesh.n_grid
    gid = mesh.grid_ids
    # Dependent DOF -> list of (coefficient, grid row, comp); expressed in CD components.
    deps: dict[tuple[int, int], list[tuple[float, int, int]]] = {}
    owner: dict[tuple[int, int], str] = {}

    def claim(dof: tuple[int, int], who: str) -> None:
        if dof in owner:
            raise InputError(
                f"{source}: {who}: grid {gid[dof[0]]} component {dof[1] + 1} is already "
                f"dependent in {owner[dof]}; a DOF can be dependent in one rigid element only"
            )
        owner[dof] = who

    for mp in mesh.mpc:
        a0, g0, c0 = mp.terms[0]
        claim((g0, c0), f"MPC {mp.sid}")
        deps[(g0, c0)] = [(-a / a0, g, c) for a, g, c in mp.terms[1:]]

    rigid = [(f"RBE2 {rb.eid}", [(rb.independent, c) for c in range(6)],
              [(m, c) for m in rb.dependent for c in rb.comps]) for rb in mesh.rbe2]
    rigid += [(f"RBE1 {rb.eid}", rb.independent, rb.dependent) for rb in mesh.rbe1]
    for who, independent, dependent in rigid:
        for dof, terms in _rigid_body(mesh, independent, dependent, f"{source}: {who}").items():
            claim(dof, who)
            deps[dof] = terms

    for rb in mesh.rbe3:
        who = f"RBE3 {rb.eid}"
        xr = mesh.xyz[rb.ref]
        rows, weights, cols = [], [], []
        dists = [np.linalg.norm(mesh.xyz[g] - xr) for _, _, grids in rb.groups for g in grids]
        Lc = float(np.mean(dists)) if dists else 1.0
        Lc = Lc if Lc > 0 else 1.0
        for w, comps, grids in rb.groups:
            for g in grids:
                Qg = _cd_block(mesh.cd_axes[g])
                A = (_rigid_map(mesh.xyz[g] - xr).T @ Qg).T  # rows: CD comps of g; cols: (t, θ)
                for c in comps:
                    rows.append(A[c])
                    weights.append(w * (Lc**2 if c >= 3 else 1.0))
                    cols.append((g, c))
        A = np.array(rows).reshape(-1, 6)
        W = np.array(weights)
        N = A.T @ (W[:, None] * A)
        if len(rows) < 6 or np.linalg.matrix_rank(N, tol=1e-10 * np.abs(N).max()) < 6:
            raise InputError(
                f"{source}: {who}: the independent grids/components do not determine a rigid "
                "motion of the reference grid (need three non-collinear grids with translations)"
            )
        fit = np.linalg.solve(N, A.T * W)  # (6 basic t/θ, n_indep)
        Qr = _cd_block(mesh.cd_axes[rb.ref])
        ref_cd = Qr.T @ fit
        for c in rb.ref_comps:
            claim((rb.ref, c), who)
            deps[(rb.ref, c)] = [
                (ref_cd[c, k], g, cc) for k, (g, cc) in enumerate(cols) if ref_cd[c, k] != 0.0
            ]

    status: dict[tuple[int, int], str] = {}
    for dof in mesh.spc:
        if dof in deps:
            raise InputError(
                f"{source}: grid {gid[dof[0]]} component {dof[1] + 1} is constrained "
                f"({mesh.spc_source.get(dof, 'SPC')}) and dependent in {owner[dof]}"
            )
        status[dof] = mesh.spc_source.get(dof, "SPC")
    for dof, who in owner.items():
        status[dof] = who

    free = [(g, c) for g in range(n) for c in range(6) if (g, c) not in status]
    index = {dof: k for k, dof in enumerate(free)}

    resolved: dict[tuple[int, int], dict[int, float]] = {}
    visiting: set[tuple[int, int]] = set()

    def row_of(dof: tuple[int, int]) -> dict[int, float]:
        if dof in index:
            return {index[dof]: 1.0}
        if dof not in deps:
            return {}
        if dof in resolved:
            return resolved[dof]
        if dof in visiting:
            raise InputError(
                f"{source}: {owner[dof]}: rigid elements form a dependency cycle through grid "
                f"{gid[dof[0]]} component {dof[1] + 1}"
            )
        visiting.add(dof)
        out: dict[int, float] = {}
        for coef, g, c in deps[dof]:
            for j, v in row_of((g, c)).items():
                out[j] = out.get(j, 0.0) + coef * v
        visiting.discard(dof)
        resolved[dof] = out
        return out

    r_idx, c_idx, vals = [], [], []
    for g in range(n):
        B = _cd_block(mesh.cd_axes[g])
        for c in range(6):
            row = row_of((g, c))
            for j, v in row.items():
                # basic components of grid g receive B[:, c] * (CD component c)
                for bi in range(6):
                    if B[bi, c] != 0.0:
                        r_idx.append(g * 6 + bi)
                        c_idx.append(j)
                        vals.append(B[bi, c] * v)
    T = sp.csr_matrix((vals, (r_idx, c_idx)), shape=(6 * n, len(free)))
    T.sum_duplicates()
    T.eliminate_zeros()
    return Constraints(T=T, free=np.array(free, dtype=int).reshape(-1, 2), status=status)


def drop_free(cons: Constraints, drop: np.ndarray, reason: str) -> Constraints:
    """Constrain the free DOFs ``drop`` (indices) to zero (automatic SPC)."""
    if not len(drop):
        return cons
    keep = np.setdiff1d(np.arange(cons.T.shape[1]), drop)
    status = dict(cons.status)
    for k in drop:
        status[tuple(int(x) for x in cons.free[k])] = reason
    T = cons.T[:, keep].tocsr()
    T.eliminate_zeros()
    return Constraints(T=T, free=cons.free[keep], status=status)
