"""The built-in geometrically nonlinear FE model (the default "FE backend").

Written here: assembly, constraint elimination, internal forces and tangents; delegated:
sparse matrices to scipy.sparse, the element kernels' tensor algebra to torch (float64, so that
the internal forces are differentiable by autograd in forward and reverse mode), eigenvalues and
sparse factorisations to scipy (see :mod:`torchrom.fe.solvers`).

Total Lagrangian, St Venant–Kirchhoff (DIGEST Sec. 1, Eqs. 1–4): rods, membranes and shear
panels use the Green–Lagrange strain, so their internal forces are exact cubic polynomials of the
displacements. With ``rotations="large"`` (the default) plate bending, transverse shear and
drilling, CBAR/CBEAM and rod torsion keep their linear element matrices in a co-rotated frame
(:mod:`torchrom.fe.elements.corotational`): large rotations, small strains. With
``rotations="small"`` (the heavy Goland wing of the paper) they are linear. Springs (CELAS,
CBUSH, GENEL) and solids stay linear in both. Shells with ZOFFS
(:mod:`torchrom.fe.elements.offset`) are linear altogether, and a model that has them refuses the
nonlinear internal forces and tangents with a one-line error.
All public vectors live on the independent ("free") DOFs: ``u_all = T u`` (constraints: SPC,
GRID PS, RBE1, RBE2, RBE3, automatic SPC of DOFs without stiffness).

- internal force f(u) = f_nl(u) + f_corot(u) + K_lin u;
- tangent stiffness K_T(u) = ∂f/∂u = K_mat(u) + K_geo(u);
- material tangent K_mat(u) = Σ B(u)ᵀ C B(u) + Σ B_e(u)ᵀ K_e B_e(u) + K_lin (no initial-stress
  part; B_e = ∂d_e/∂u of the co-rotational local displacements): with Kelvin–Voigt
  damping D = γ C the damping force is γ K_mat(u) u̇ (NOTES-damping.md, DIGEST Eqs. 52–54).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import torch
from torch.func import jvp, vjp

from ..errors import InputError
from .assembly import ProjectedPattern, assemble, project
from .constraints import COMPONENT, build_constraints, drop_free
from .dead_load import DeadLoad
from .elements.bar import bar_mass_blocks, bar_stiffness_blocks
from .elements.corotational import (
    CorotElements,
    CorotKernel,
    line_elements,
    plate_elements,
    spin_map,
)
from .elements.green import GreenKernel, GreenPoints
from .elements.offset import offset_mass_blocks, offset_stiffness_blocks
from .elements.quad4 import (
    area_mass_blocks,
    bending_blocks,
    membrane_points,
    pressure_forces,
    quad_frames,
)
from .elements.rod import rod_mass_blocks, rod_points, rod_torsion_blocks
from .elements.shear import shear_mass_blocks, shear_points
from .elements.solid import solid_blocks, solid_mass_blocks
from .elements.tria3 import tria_bending_blocks, tria_mass_blocks, tria_points
from .mass import (
    bush_blocks,
    celas_blocks,
    cmass2_blocks,
    conm1_blocks,
    conm2_blocks,
    genel_blocks,
)
from .mesh import Mesh
from .rigid_arms import ArmLift, linear_rigid_elements, rigid_arms

#: The model option ``rotations``: "large" (co-rotational bending, beams and rod torsion),
#: "small" (those linear, the paper's heavy Goland wing).
ROTATIONS = ("large", "small")


class LinearElementWarning(UserWarning):
    """A nonlinear analysis of a model with elements that stay linear (springs and solids; with
    ``rotations="small"`` also CBAR/CBEAM)."""


@dataclass
class _TorchState:
    kernels: list[GreenKernel]
    corot: list[CorotKernel]
    T_rows: torch.Tensor
    T_cols: torch.Tensor
    T_vals: torch.Tensor
    K_rows: torch.Tensor
    K_cols: torch.Tensor
    K_vals: torch.Tensor
    arms: ArmLift | None = None  # RBE2 arms turned by large rotations (rigid_arms)


def _coo_parts(M: sp.spmatrix):
    c = M.tocoo()
    return c.row.astype(np.int64), c.col.astype(np.int64), c.data


def _without_offset(shells):
    """The quads or triangles without ZOFFS (the others: :mod:`torchrom.fe.elements.offset`)."""
    return shells.select(~shells.offset) if shells.offset.any() else shells


def _offset_shells(mesh: Mesh) -> list:
    """The sets of offset quads and offset triangles (those that exist)."""
    return [s.select(s.offset) for s in (mesh.quads, mesh.trias) if s.offset.any()]


def _first_offset(mesh: Mesh) -> tuple[str, int, float, int] | None:
    """(card, element id, ZOFFS, number of offset elements) of the lowest-numbered offset
    shell, or None."""
    found = [(int(s.eids[s.offset].min()), card, s) for card, s in
             (("CQUAD4", mesh.quads), ("CTRIA3", mesh.trias)) if s.offset.any()]
    if not found:
        return None
    eid, card, s = min(found, key=lambda x: x[0])
    count = int(mesh.quads.offset.sum() + mesh.trias.offset.sum())
    return card, eid, float(s.zoffs[s.eids == eid][0]), count


def assemble_mass(mesh: Mesh) -> sp.csr_matrix:
    """Mass matrix of a mesh on all its grid DOFs (basic axes, 6 per grid): elements'
    structural and non-structural mass (lumped, or coupled with PARAM COUPMASS > 0), CONM1s,
    CONM2s and CMASS2s. Model updating re-assembles it for changed mass cards (the grids, and so the
    constraints, unchanged)."""
    xyz, cm = mesh.xyz, mesh.coupled_mass
    parts = []
    if len(mesh.rods):
        parts.append(rod_mass_blocks(mesh.rods, xyz, cm))
    quads, trias = _without_offset(mesh.quads), _without_offset(mesh.trias)
    if len(quads):
        parts.append(area_mass_blocks(xyz, quads.nodes, quads.rho * quads.t + quads.nsm, cm))
    if len(trias):
        parts.append(tria_mass_blocks(trias, xyz, cm))
    parts.extend(offset_mass_blocks(s, xyz, cm) for s in _offset_shells(mesh))
    for solids in mesh.solids:
        parts.append(solid_mass_blocks(solids, xyz, cm))
    if len(mesh.shears):
        parts.append(shear_mass_blocks(mesh.shears, xyz, cm))
    if len(mesh.bars):
        parts.append(bar_mass_blocks(mesh.bars, xyz, cm))
    if mesh.conm2:
        parts.append(conm2_blocks(mesh.conm2))
    if mesh.cmass2:
        parts.append(cmass2_blocks(mesh.cmass2, mesh.cd_axes))
    if mesh.conm1:
        parts.append(conm1_blocks(mesh.conm1))
    return assemble(parts, 6 * mesh.n_grid)


class FEModel:
    """A structural model with geometrically nonlinear internal forces on its free DOFs.

    Build one with :func:`torchrom.fe.read_bdf` or :func:`torchrom.fe.goland`. Public attributes:
    ``grid_ids``, ``grid_xyz`` (basic), ``n_dof``, ``output_points`` (name → (grid id,
    component 1..6)), ``name``, ``units``, ``source``, ``bdf`` (the pyNastran deck, including its
    aerodynamic cards), ``loads`` (load set id → free-DOF vector), ``n_modes_requested`` (EIGR/EIGRL
    ND), ``autospc`` (list of (grid id, component) removed for lack of stiffness),
    ``wing_chord`` ((x_LE, x_TE) of the aerodynamic chord in basic x when known, e.g. the heavy
    Goland wing's (0, 6) ft; None otherwise), ``rotations`` ("large": plate bending, beams and
    rod torsion co-rotational in nonlinear analyses; "small": those linear).
    """

    def __init__(
        self,
        mesh: Mesh,
        *,
        name: str = "model",
        source: str = "",
        units: dict[str, str] | None = None,
        bdf=None,
        loads: dict[int, np.ndarray] | None = None,
        n_modes_requested: int | None = None,
        output_points: dict[str, tuple[int, int]] | None = None,
        drilling: float = 1e-4,
        autospc: bool = True,
        rotations: str = "large",
    ):
        if rotations not in ROTATIONS:
            raise InputError(f"{source or name}: rotations: expected one of "
                             f"{', '.join(ROTATIONS)}, got {rotations!r}")
        self.rotations = rotations
        self.mesh = mesh
        self.name = name
        self.source = source
        self.units = dict(units or {})
        self.bdf = bdf
        self.n_modes_requested = n_modes_requested
        self.grid_ids = np.asarray(mesh.grid_ids, dtype=int)
        self.grid_xyz = np.asarray(mesh.xyz, dtype=float)
        self._row = mesh.grid_row()
        self.n_all = 6 * mesh.n_grid
        self._warned_linear = False
        self.wing_chord: tuple[float, float] | None = None
        self.notes: list[str] = []  # cards accepted without effect, conditioning, ... (reader)

        # Nonlinear (Green-strain) integration points: rods (2 nodes, 1-D), quads+shear (4, 2-D).
        # Shells with ZOFFS are linear (elements.offset): only the others have Green points.
        quads, trias = _without_offset(mesh.quads), _without_offset(mesh.trias)
        offsets = _offset_shells(mesh)
        self._offset_element = _first_offset(mesh)
        groups = []
        if len(mesh.rods):
            groups.append(rod_points(mesh.rods, mesh.xyz))
        quad_like = []
        if len(quads):
            quad_like.append(membrane_points(quads, mesh.xyz))
        if len(mesh.shears):
            quad_like.append(shear_points(mesh.shears, mesh.xyz))
        if quad_like:
            groups.append(GreenPoints.concat(quad_like))
        if len(trias):
            groups.append(tria_points(trias, mesh.xyz))
        self._points = groups

        # Linear stiffness parts (bending + drilling, rod torsion, CBAR, offset shells, springs,
        # solids), in this order in K_lin; with large rotations the ones marked True are
        # co-rotational in the nonlinear forces (their linear blocks stay in K_lin).
        large = rotations == "large"
        lin, corot_part = [], []
        if len(quads):
            lin.append(bending_blocks(quads, mesh.xyz, drilling))
            corot_part.append(large)
        if len(trias):
            lin.append(tria_bending_blocks(trias, mesh.xyz, drilling))
            corot_part.append(large)
        lin.extend(offset_stiffness_blocks(s, mesh.xyz, drilling) for s in offsets)
        corot_part.extend(False for _ in offsets)
        if len(mesh.rods):
            lin.append(rod_torsion_blocks(mesh.rods, mesh.xyz))
            corot_part.append(large)
        if len(mesh.bars):
            lin.append(bar_stiffness_blocks(mesh.bars, mesh.xyz))
            corot_part.append(large)
        if mesh.celas:
            lin.append(celas_blocks(mesh.celas, mesh.cd_axes))
        if mesh.bushes:
            lin.append(bush_blocks(mesh.bushes))
        lin.extend(genel_blocks(mesh.genel, mesh.cd_axes))
        for solids in mesh.solids:
            lin.append(solid_blocks(solids, mesh.xyz))
        corot_part.extend(False for _ in range(len(lin) - len(corot_part)))
        self._all_lin_parts = [p for p in lin if len(p[0])]
        self._lin_parts = [p for p, c in zip(lin, corot_part) if len(p[0]) and not c]
        corot = []
        if large:
            corot = [plate_elements(s, mesh.xyz, drilling) for s in (quads, trias) if len(s)]
            corot.append(line_elements(mesh.bars, mesh.rods, mesh.xyz))
        self._corot: list[CorotElements] = [c for c in corot if c is not None]

        cons = build_constraints(mesh, source=self.source or self.name)
        kernels0 = [GreenKernel(p, mesh.xyz) for p in self._points]
        K_all0 = self._linear_all(kernels0)
        self.autospc: list[tuple[int, int]] = []
        if autospc:
            # Nastran's AUTOSPC: free DOFs whose linear stiffness diagonal is zero (relative to
            # the largest of their kind) are constrained, e.g. the rotations of membrane-only or
            # rod-only grids, or the out-of-plane translations of a planar rod/shear structure.
            Kf = project(K_all0, cons.T)
            d = np.abs(Kf.diagonal())
            drop = []
            for kind in (0, 1):  # translations, rotations judged separately (different units)
                sel = np.nonzero((cons.free[:, 1] >= 3) == bool(kind))[0]
                if len(sel):
                    ref = d[sel].max() if d[sel].max() > 0 else 1.0
                    drop.extend(sel[d[sel] <= 1e-12 * ref])
            drop = np.array(sorted(drop), dtype=int)
            cons = drop_free(cons, drop, "AUTOSPC")
            self.autospc = [
                (int(self.grid_ids[g]), int(c) + 1)
                for (g, c), why in sorted(cons.status.items())
                if why == "AUTOSPC"
            ]
        self.constraints = cons
        self.T = cons.T
        self.n_dof = self.T.shape[1]
        if self.n_dof == 0:
            raise InputError(f"{self.source or self.name}: the model has no free DOFs")
        self._free_index = {(int(g), int(c)): k for k, (g, c) in enumerate(cons.free)}

        self._K_lin_free = project(K_all0, self.T)
        # Tangents = constant linear part (springs, solids; with small rotations also bending,
        # drilling, torsion, CBAR) + the Green-strain point blocks and the co-rotational element
        # blocks scattered through precomputed patterns (assembly.ProjectedPattern).
        self._const = assemble(self._lin_parts, self.n_all)
        self._K_const_free = project(self._const, self.T)
        self._pattern_cache: list[ProjectedPattern] | None = None  # built on first use
        self._all_patterns: list[ProjectedPattern] | None = None  # the same on all DOFs (arms)
        # RBE2 arms turn with their grid under large rotations (torchrom.fe.rigid_arms)
        self._arms = rigid_arms(mesh) if large else None
        self._M_free = project(self._mass_all(), self.T)
        self._M_free.eliminate_zeros()
        self._loads_all = dict(loads or {})
        self.loads = {sid: self.T.T @ f for sid, f in self._loads_all.items()}
        self.output_points: dict[str, tuple[int, int]] = {}
        self.set_output_points(output_points or {})
        self._wing_axes: tuple = (None, None)
        self._wing_frame = None
        self._torch: dict[tuple, _TorchState] = {}
        # Built eagerly: a state first built inside a torch.func transform would cache tensors
        # tied to that transform's level (call prepare_torch for other dtypes/devices).
        self.prepare_torch()

    def set_output_points(self, points) -> None:
        """Name → (grid id, component 1..6): checked to be independent DOFs."""
        for key, (gid, comp) in dict(points).items():
            self.dof_index(gid, comp, what=f"output point {key}")
        self.output_points = dict(points)

    def set_wing_axes(self, up=None, span=None) -> None:
        """The user's up and span directions (``--up-axis``/``--span-axis`` text or vectors;
        None: from the geometry, :func:`~torchrom.fe.wing_frame.wing_frame`)."""
        self._wing_axes = (up, span)
        self._wing_frame = None

    def wing_frame(self):
        """The wing's span, chord and up axes (:class:`~torchrom.fe.wing_frame.WingFrame`);
        WingFrameError where they cannot be told."""
        from .wing_frame import wing_frame

        if self._wing_frame is None:
            self._wing_frame = wing_frame(self, *self._wing_axes)
        return self._wing_frame

    # -- assembly helpers ------------------------------------------------------------------------
    @property
    def _patterns(self) -> list[ProjectedPattern]:
        """Where the point blocks land in K_free: built on the first tangent assembly, not at
        reading (a linear modal analysis never needs them; on shell models they cost more than
        the rest of the model build)."""
        if self._pattern_cache is None:
            self._pattern_cache = [ProjectedPattern(p.dof_index(), self.T)
                                   for p in [*self._points, *self._corot]]
        return self._pattern_cache

    def _linear_all(self, kernels: list[GreenKernel]) -> sp.csr_matrix:
        zero = np.zeros(self.n_all)
        parts = [(k.dof_np, k.point_matrices(zero, geometric=0.0)) for k in kernels]
        return assemble(parts + self._all_lin_parts, self.n_all)

    def _mass_all(self) -> sp.csr_matrix:
        return assemble_mass(self.mesh)

    def _state(self, dtype=torch.float64, device=None) -> _TorchState:
        device = torch.device(device if device is not None else "cpu")
        key = (dtype, str(device))
        st = self._torch.get(key)
        if st is None:
            opts = dict(dtype=dtype, device=device)
            r, c, v = _coo_parts(self.T)
            kr, kc, kv = _coo_parts(self._K_const_free)
            st = _TorchState(
                kernels=[GreenKernel(p, self.mesh.xyz, dtype=dtype, device=device)
                         for p in self._points],
                corot=[CorotKernel(c, self.mesh.xyz, dtype=dtype, device=device)
                       for c in self._corot],
                T_rows=torch.as_tensor(r, device=device),
                T_cols=torch.as_tensor(c, device=device),
                T_vals=torch.as_tensor(v, **opts),
                K_rows=torch.as_tensor(kr, device=device),
                K_cols=torch.as_tensor(kc, device=device),
                K_vals=torch.as_tensor(kv, **opts),
                arms=None if self._arms is None else ArmLift(self._arms, self.n_all, **opts),
            )
            self._torch[key] = st
        return st

    def prepare_torch(self, dtype=torch.float64, device=None) -> None:
        """Build the torch kernels for ``dtype``/``device`` now (float64 CPU is built at
        construction); do this before using another dtype/device inside ``torch.func``
        transforms."""
        self._state(dtype, device)

    def linear_elements(self) -> dict[str, int]:
        """Elements that stay linear in a nonlinear analysis, by card family → count."""
        m = self.mesh
        out = {"CELAS": len(m.celas), "CBUSH": len(m.bushes), "GENEL": len(m.genel),
               "solid (CHEXA/CPENTA/CTETRA)": sum(len(s) for s in m.solids)}
        if self.rotations == "small":
            out["CBAR/CBEAM"] = len(m.bars)
        else:
            out.update(linear_rigid_elements(m))
        return {k: v for k, v in out.items() if v}

    def _warn_linear(self) -> None:
        counts = self.linear_elements()
        if not counts or self._warned_linear:
            return
        self._warned_linear = True
        if self.rotations == "small":
            n_lin = sum(counts.values())
            text = (f"{self.name}: {n_lin} CBAR/CBEAM/CELAS/solid elements are linear (small "
                    "rotations); the nonlinear analysis includes them through their linear "
                    "stiffness only")
        else:
            which = ", ".join(f"{n} {k}" for k, n in counts.items())
            text = (f"{self.name}: {which} stay linear in this nonlinear analysis (K u with "
                    "their small-displacement stiffness, or the linear constraint): springs act "
                    "along fixed directions between their grids, solids have no large-rotation "
                    "formulation here, and RBE1/RBAR/RBE3 and RBE2s without translations are "
                    "eliminated as in a linear analysis")
        warnings.warn(text, LinearElementWarning, stacklevel=3)

    def _refuse_offsets(self, what: str) -> None:
        """Shells with ZOFFS are linear (small-rotation offset): no nonlinear analysis."""
        if self._offset_element is not None:
            card, eid, z0, count = self._offset_element
            raise InputError(
                f"{self.source or self.name}: {card} {eid}: field ZOFFS = {z0:g}: offset shells"
                f" are linear only; {what} (nonlinear analysis) is not supported for a model with"
                f" ZOFFS ({count} offset elements); modes, linear statics and flutter are"
                " supported")

    # -- DOF bookkeeping -------------------------------------------------------------------------
    def dof_index(self, grid_id: int, component: int, what: str = "dof_index") -> int:
        """Index of (grid, component 1..6 in the grid's CD system) among the free DOFs."""
        if int(component) not in range(1, 7):
            raise InputError(f"{what}: component: expected 1..6, got {component}")
        row = self._row.get(int(grid_id))
        if row is None:
            raise InputError(f"{what}: grid {grid_id} not found in {self.name}")
        key = (row, int(component) - 1)
        k = self._free_index.get(key)
        if k is None:
            why = self.constraints.status.get(key, "constrained")
            raise InputError(
                f"{what}: grid {grid_id} component {component} ({COMPONENT[key[1]]}) is not an "
                f"independent DOF ({why})"
            )
        return k

    def free_dofs(self) -> list[tuple[int, int]]:
        """(grid id, component 1..6) of every free DOF, in order."""
        return [(int(self.grid_ids[g]), int(c) + 1) for g, c in self.constraints.free]

    def expand(self, u, large: bool = False) -> np.ndarray:
        """Free-DOF vector(s) → (n_grid, 6) or (k, n_grid, 6) in basic axes (T1..T3, R1..R3).
        ``large``: displacements of a large-rotation state, the RBE2 arms turned by their
        grid's rotation (:mod:`torchrom.fe.rigid_arms`); otherwise linear (mode shapes)."""
        u = np.asarray(u, dtype=float)
        if u.shape[0] != self.n_dof:
            raise InputError(f"expand: expected {self.n_dof} rows, got shape {u.shape}")
        full = self.T @ u
        st = self._state()
        if large and st.arms is not None:
            with torch.no_grad():
                full = st.arms.lift(torch.from_numpy(np.ascontiguousarray(full.T))).numpy().T
        if u.ndim == 1:
            return full.reshape(-1, 6)
        return np.moveaxis(full.reshape(-1, 6, u.shape[1]), 2, 0)

    def _check_u(self, u, what: str) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.shape[-1] != self.n_dof:
            raise InputError(f"{what}: expected a vector of {self.n_dof} free DOFs, "
                             f"got shape {u.shape}")
        return u

    # -- matrices --------------------------------------------------------------------------------
    def mass_matrix(self) -> sp.csr_matrix:
        """Mass matrix on the free DOFs (lumped, or coupled with PARAM COUPMASS > 0)."""
        return self._M_free.copy()

    def stiffness_matrix(self) -> sp.csr_matrix:
        """Linear stiffness K = K_T(0) = K_mat(0) on the free DOFs."""
        return self._K_lin_free.copy()

    def _all_torch(self, u: torch.Tensor, st: _TorchState) -> torch.Tensor:
        out = torch.zeros(*u.shape[:-1], self.n_all, dtype=u.dtype, device=u.device)
        return out.index_add(-1, st.T_rows, u.index_select(-1, st.T_cols) * st.T_vals)

    def _free_torch(self, f_all: torch.Tensor, st: _TorchState) -> torch.Tensor:
        out = torch.zeros(*f_all.shape[:-1], self.n_dof, dtype=f_all.dtype, device=f_all.device)
        return out.index_add(-1, st.T_cols, f_all.index_select(-1, st.T_rows) * st.T_vals)

    def _const_torch(self, u: torch.Tensor, st: _TorchState) -> torch.Tensor:
        if not len(st.K_rows):
            return torch.zeros_like(u)
        out = torch.zeros_like(u)
        return out.index_add(-1, st.K_rows, u.index_select(-1, st.K_cols) * st.K_vals)

    def internal_force_torch(self, u: torch.Tensor) -> torch.Tensor:
        """Differentiable internal force f(u) for u of shape (..., n_dof) (any float dtype/device).

        Exactly cubic in u (Green-strain parts), the gradient of the co-rotational elements'
        energies (large rotations) and linear terms; autograd (reverse or forward mode, e.g.
        ``torch.func.jvp``/``jacfwd``) gives the exact tangent and Taylor coefficients.
        """
        return self._internal_force_torch(u, differentiable=True)

    def _internal_force_torch(self, u: torch.Tensor, differentiable: bool) -> torch.Tensor:
        """:meth:`internal_force_torch`; not ``differentiable``: the values alone (the shells'
        closed-form force, :meth:`CorotKernel.force_values`)."""
        self._refuse_offsets("the internal force f(u)")
        st = self._state(u.dtype, u.device)
        u_all = self._all_torch(u, st)
        pull = None
        if st.arms is not None:
            u_all, pull = vjp(st.arms.lift, u_all)
        f_all = torch.zeros_like(u_all)
        for k in st.kernels:
            f_all = f_all + k.internal_force(u_all)
        for k in st.corot:
            f_all = f_all + (k.internal_force(u_all) if differentiable else k.force_values(u_all))
        if pull is not None:
            f_all = pull(f_all)[0]  # Jᵀ f_all: the arms' forces on the independent rotations
        return self._free_torch(f_all, st) + self._const_torch(u, st)

    def material_force_torch(self, u: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
        """K_mat(u) v, differentiable, for u, v of shape (..., n_dof)."""
        self._refuse_offsets("the material tangent")
        st = self._state(u.dtype, u.device)
        u_all, v_all = self._all_torch(u, st), self._all_torch(v, st)
        pull = None
        if st.arms is not None:
            u_all, v_all = jvp(st.arms.lift, (u_all,), (v_all,))
            _, pull = vjp(st.arms.lift, self._all_torch(u, st))
        f_all = torch.zeros_like(u_all)
        for k in [*st.kernels, *st.corot]:
            f_all = f_all + k.material_force(u_all, v_all)
        if pull is not None:
            f_all = pull(f_all)[0]
        return self._free_torch(f_all, st) + self._const_torch(v, st)

    def strain_energy_torch(self, u: torch.Tensor) -> torch.Tensor:
        """Strain energy W(u) (...,): f = ∂W/∂u."""
        self._refuse_offsets("the strain energy W(u)")
        st = self._state(u.dtype, u.device)
        u_all = self._all_torch(u, st)
        if st.arms is not None:
            u_all = st.arms.lift(u_all)
        W = 0.5 * (u * self._const_torch(u, st)).sum(-1)
        for k in [*st.kernels, *st.corot]:
            W = W + k.energy(u_all)
        return W

    def internal_force(self, u) -> np.ndarray:
        """f(u) on the free DOFs (numpy in, numpy out; u may be (..., n_dof))."""
        u = self._check_u(u, "internal_force")
        self._warn_linear()
        with torch.no_grad():
            return self._internal_force_torch(torch.from_numpy(u), differentiable=False).numpy()

    def material_force(self, u, v) -> np.ndarray:
        u = self._check_u(u, "material_force")
        v = self._check_u(v, "material_force")
        with torch.no_grad():
            return self.material_force_torch(torch.from_numpy(u), torch.from_numpy(v)).numpy()

    def matrix_combination(self, u, material: float = 0.0, geometric: float = 0.0,
                           damping: float = 0.0, v=None) -> sp.csr_matrix:
        """material · K_mat(u) + geometric · K_geo(u) + damping · ∂(K_mat(u) v)/∂u, assembled in
        one pass (K_T = K_mat + K_geo; the linear element parts belong to K_mat)."""
        self._refuse_offsets("the tangent stiffness")
        u_all = self.T @ np.asarray(u, dtype=float)
        v_all = None if not damping else self.T @ np.asarray(v, dtype=float)
        K = self._K_const_free * material if material else sp.csr_matrix((self.n_dof,) * 2)
        st = self._state()
        if st.arms is not None:
            return K + self._arm_combination(st, u_all, v_all, material, geometric, damping)
        blocks = [kern.point_matrices(u_all, material, geometric, damping, v_all)
                  for kern in st.kernels]
        blocks += [kern.element_matrices(u_all, material, geometric, damping, v_all)
                   for kern in st.corot]
        for pat, b in zip(self._patterns, blocks):
            K = K + pat.assemble(b)
        return K.tocsr()

    def _arm_combination(self, st, u_lin, v_lin, material, geometric, damping):
        """The element part of :meth:`matrix_combination` with rigid arms: Tᵀ (Jᵀ K_all J +
        geometric · G) T, K_all assembled on all DOFs at the lifted state
        (:mod:`torchrom.fe.rigid_arms`; the damping derivative takes J only)."""
        if self._all_patterns is None:
            eye = sp.identity(self.n_all, format="csr")
            self._all_patterns = [ProjectedPattern(p.dof_index(), eye)
                                  for p in [*self._points, *self._corot]]
        with torch.no_grad():
            u_all = st.arms.lift(torch.from_numpy(u_lin)).numpy()
            v_all = None if v_lin is None else \
                jvp(st.arms.lift, (torch.from_numpy(u_lin),), (torch.from_numpy(v_lin),))[1].numpy()
        blocks = [kern.point_matrices(u_all, material, geometric, damping, v_all)
                  for kern in st.kernels]
        blocks += [kern.element_matrices(u_all, material, geometric, damping, v_all)
                   for kern in st.corot]
        K_all = sp.csr_matrix((self.n_all,) * 2)
        for pat, b in zip(self._all_patterns, blocks):
            K_all = K_all + pat.assemble(b)
        JT = (st.arms.jacobian(u_lin) @ self.T).tocsr()
        K = JT.T @ K_all @ JT
        if geometric:
            f_all = np.zeros(self.n_all)  # (a model of springs and arms has no kernels)
            with torch.no_grad():
                for k in [*st.kernels, *st.corot]:
                    f_all += k.internal_force(torch.from_numpy(u_all)).numpy()
            K = K + geometric * (self.T.T @ st.arms.stiffness(u_lin, f_all) @ self.T)
        return K.tocsr()

    def tangent_stiffness(self, u) -> sp.csr_matrix:
        """K_T(u) = ∂f/∂u (sparse, symmetric)."""
        u = self._check_u(u, "tangent_stiffness")
        self._warn_linear()
        return self.matrix_combination(u, material=1.0, geometric=1.0)

    def tangent_stiffnesses(self, U) -> list[sp.csr_matrix]:
        """K_T(u) of each row u of ``U`` (P, n_dof): :meth:`tangent_stiffness`'s matrices,
        the co-rotational element blocks of several states in one pass (up to
        :data:`~torchrom.fe.elements.corotational.BATCH_ELEMENTS` element states): a tangent
        of few elements costs mostly the per-operation overhead of its automatic
        differentiation, which one pass shares (the TACS wingbox's 91 shells: 43 ms a state
        alone, 20 ms in passes of 11)."""
        U = np.atleast_2d(self._check_u(U, "tangent_stiffnesses"))
        self._warn_linear()
        st = self._state()
        if st.arms is not None or not st.corot:
            return [self.matrix_combination(u, material=1.0, geometric=1.0) for u in U]
        self._refuse_offsets("the tangent stiffness")
        from .elements.corotational import BATCH_ELEMENTS

        per_pass = max(1, BATCH_ELEMENTS // sum(len(k.els) for k in st.corot))
        out = []
        for start in range(0, len(U), per_pass):
            U_all = (self.T @ U[start:start + per_pass].T).T
            corot = [kern.element_matrices(U_all) for kern in st.corot]
            for p, u_all in enumerate(U_all):
                K = self._K_const_free * 1.0
                blocks = [kern.point_matrices(u_all, 1.0, 1.0, 0.0, None) for kern in st.kernels]
                blocks += [b[p] for b in corot]
                for pat, b in zip(self._patterns, blocks):
                    K = K + pat.assemble(b)
                out.append(K.tocsr())
        return out

    def material_tangent(self, u) -> sp.csr_matrix:
        """K_mat(u): the tangent without the initial-stress part (Kelvin–Voigt damping matrix)."""
        u = self._check_u(u, "material_tangent")
        return self.matrix_combination(u, material=1.0)

    def damping_derivative(self, u, v) -> sp.csr_matrix:
        """∂(K_mat(u) v)/∂u (non-symmetric), for implicit Kelvin–Voigt time integration."""
        return self.matrix_combination(self._check_u(u, "damping_derivative"), damping=1.0,
                                       v=self._check_u(v, "damping_derivative"))

    # -- loads -----------------------------------------------------------------------------------
    def nodal_load(self, loads: dict[tuple[int, int], float]) -> np.ndarray:
        """Free-DOF load vector from {(grid id, component 1..6 in basic axes): value}."""
        return self.T.T @ self._nodal_all(loads)

    def _nodal_all(self, loads: dict[tuple[int, int], float]) -> np.ndarray:
        """The all-grid vector of :meth:`nodal_load`'s ``loads`` (its one-line refusals)."""
        f = np.zeros(self.n_all)
        for (gid, comp), val in loads.items():
            row = self._row.get(int(gid))
            if row is None:
                raise InputError(f"nodal_load: grid {gid} not found in {self.name}")
            if int(comp) not in range(1, 7):
                raise InputError(f"nodal_load: component: expected 1..6, got {comp}")
            f[row * 6 + int(comp) - 1] += float(val)
        return f

    def load_vector(self, load_id: int) -> np.ndarray:
        """Free-DOF vector of a FORCE/MOMENT/PLOAD2/PLOAD4/LOAD set of the deck."""
        if load_id not in self.loads:
            raise InputError(f"{self.name}: load set {load_id} not found "
                             f"(available: {sorted(self.loads)})")
        return self.loads[load_id].copy()

    def dead_load(self, load_id: int) -> DeadLoad:
        """The deck's load set ``load_id`` as a :class:`~torchrom.fe.dead_load.DeadLoad`, whose
        generalized force follows the large rotations (nonlinear statics)."""
        self.load_vector(load_id)  # the one-line refusal of a missing set
        return DeadLoad(self, self._loads_all[load_id])

    def nodal_dead_load(self, loads: dict[tuple[int, int], float]) -> DeadLoad:
        """:meth:`nodal_load` as a :class:`~torchrom.fe.dead_load.DeadLoad`."""
        return DeadLoad(self, self._nodal_all(loads))

    def generalized_load(self, u, f_all) -> np.ndarray:
        """Generalized free-DOF force at the state ``u`` of the dead loads ``f_all`` (all-grid
        forces and moments, basic axes): Tᵀ f with small rotations; with large rotations the
        moments' T(θ)ᵀ M and the forces on turned RBE2 arms (:mod:`torchrom.fe.dead_load`)."""
        u = self._check_u(u, "generalized_load")
        f_all = np.asarray(f_all, dtype=float)
        if self.rotations != "large":
            return self.T.T @ f_all
        st = self._state()
        with torch.no_grad():
            u_all = self._all_torch(torch.from_numpy(u), st)
            f = torch.from_numpy(f_all).reshape(-1, 6)
            T = spin_map(u_all.reshape(-1, 6)[:, 3:])
            moments = (T.transpose(-1, -2) @ f[:, 3:, None])[..., 0]
            g_all = torch.cat((f[:, :3], moments), dim=1).reshape(-1)
        if st.arms is not None:
            _, pull = vjp(st.arms.lift, u_all)
            with torch.no_grad():
                g_all = pull(g_all)[0]
        with torch.no_grad():
            return self._free_torch(g_all, st).numpy()

    def pressure_elements(self) -> np.ndarray:
        """CQUAD4 ids loaded by :meth:`pressure_load` by default: the upper skin.

        In the wing's axes (:meth:`wing_frame`): only plates facing up or down (|n·up| ≥ ½: not
        the spar and rib webs of a box modelled with CQUAD4s, which a pressure on the wing
        surface does not load), unless the model has none; of those sharing the same planform
        position (centroid span and chord coordinates), the highest one (largest up
        coordinate); a single-surface model loads all of them.
        """
        q = self.mesh.quads
        if not len(q):
            return np.zeros(0, dtype=int)
        frame = self.wing_frame()
        X = self.mesh.xyz[q.nodes]
        c = frame.local(X.mean(axis=1))
        facing = np.abs(quad_frames(X)[0][:, 2] @ frame.up) >= 0.5
        candidates = np.flatnonzero(facing) if facing.any() else np.arange(len(q))
        from .wing_frame import uppermost_per_position

        top = uppermost_per_position(c, np.ptp(self.mesh.xyz, axis=0).max(), candidates)
        return np.sort(q.eids[top])

    def pressure_load(self, p, elements=None, local: bool = False) -> np.ndarray:
        """Consistent nodal loads of a pressure on CQUAD4 skins (free DOFs, dead load).

        ``p``: a float (force per area) or a callable ``p(a, b)`` of arrays: basic x, y, or with
        ``local`` the wing's span and chord coordinates (:meth:`wing_frame`). It acts normal to
        each element, oriented so that p > 0 pushes the wing up (the frame's up axis); elements
        whose normal is square to up keep their own normal.
        ``elements``: CQUAD4 ids, default :meth:`pressure_elements` (the upper skin).
        """
        q = self.mesh.quads
        eids = self.pressure_elements() if elements is None else np.asarray(elements, int)
        pos = {int(e): k for k, e in enumerate(q.eids)}
        missing = [int(e) for e in eids if int(e) not in pos]
        if missing:
            raise InputError(f"pressure_load: elements {missing[:5]} are not CQUAD4s of "
                             f"{self.name}")
        sel = np.array([pos[int(e)] for e in eids], dtype=int)
        if not len(sel):
            return np.zeros(self.n_dof)
        nodes = q.nodes[sel]
        R, _ = quad_frames(self.mesh.xyz[nodes])
        normal = R[:, 2]
        frame = self.wing_frame()
        flip = np.where(normal @ frame.up < -1e-9, -1.0, 1.0)
        xyz = frame.local(self.mesh.xyz) if local else self.mesh.xyz
        dofs, F = pressure_forces(xyz, nodes, p, None, normal * flip[:, None])
        f = np.zeros(self.n_all)
        np.add.at(f, dofs.reshape(-1), F.reshape(-1))
        return self.T.T @ f

    # -- analyses (see solvers.py) ---------------------------------------------------------------
    def modes(self, n: int | None = None, sigma: float | None = None):
        """Lowest ``n`` modes: frequencies (Hz), mass-normalised shapes (n_dof, n), kinds."""
        from .solvers import modal_analysis

        n = n or self.n_modes_requested or 10
        return modal_analysis(self, int(n), sigma=sigma)

    def static_solve(self, load=None, **options):
        """Nonlinear static solution f(u) = λ load (:func:`torchrom.fe.solvers.static_solve`)."""
        from .solvers import static_solve

        self._warn_linear()
        return static_solve(self, load, **options)

    def transient(self, **options):
        """Nonlinear Newmark transient (see :func:`torchrom.fe.solvers.transient`)."""
        from .solvers import transient

        self._warn_linear()
        return transient(self, **options)

    def linear_static(self, load) -> np.ndarray:
        """K⁻¹ load (linear static solution)."""
        import scipy.sparse.linalg as sla

        load = self._check_u(load, "linear_static")
        return sla.spsolve(self._K_lin_free.tocsc(), load)

    def summary(self) -> dict:
        m = self.mesh
        return {
            "name": self.name,
            "grids": int(m.n_grid),
            "free_dofs": int(self.n_dof),
            "CROD": len(m.rods),
            "CQUAD4": len(m.quads),
            "CTRIA3": len(m.trias),
            "solids": sum(len(x) for x in m.solids),
            "CSHEAR": len(m.shears),
            "CBAR": len(m.bars),
            "CONM2": len(m.conm2),
            "CMASS": len(m.cmass2),
            "CONM1": len(m.conm1),
            "CELAS": len(m.celas),
            "CBUSH": len(m.bushes),
            "GENEL": len(m.genel),
            "RBE2": len(m.rbe2),
            "RBE1": len(m.rbe1),
            "RBE3": len(m.rbe3),
            "autospc": len(self.autospc),
        }

    def __repr__(self) -> str:
        s = self.summary()
        return f"FEModel({s['name']!r}, grids={s['grids']}, n_dof={s['free_dofs']})"

