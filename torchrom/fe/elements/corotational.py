"""Element-independent co-rotational (EICR) layer: large rotations for the linear element kernels.

Written here (the formulation is Rankin & Brogan's element-independent co-rotational one,
J. Pressure Vessel Technol. 108, 1986, as reviewed by Felippa & Haugen, CMAME 194, 2005, with
Battini & Pacoste's mean-triad frame for beams, CMAME 191, 2002); tensor algebra and derivatives
delegated to torch (``torch.func``). No element matrix is written here: every element keeps its
own linear stiffness K_e in its own axes (CBAR/CBEAM: :func:`~.bar.bar_local_stiffness`; CROD
torsion: :func:`~.rod.rod_torsion_local`; CQUAD4/CTRIA3 bending, transverse shear and drilling:
:func:`~.quad4.plate_on_six` with the element's axes), and this layer makes it follow large
rigid rotations. Per element, from the current nodal positions x_n and rotations R_n:

1. the co-rotated frame E (columns e1, e2, e3) — a beam (or rod): e1 along the chord between its
   ends, e2 the part normal to e1 of ½ (R_A + R_B) e2⁰ (the mean of the nodal triads applied to
   the initial y axis, fixing the twist); a quad: e3 from the diagonals, e1 along the mean of
   its 1-2 and 4-3 edges (the edge-average in-plane spin of :func:`~.quad4.quad_frames`); a
   triangle: e1 along G1→G2 (:func:`~.tria3.tria_frames`). The initial frame E⁰ is the same
   function of the initial geometry;
2. the local deformational displacements d_n = Eᵀ (x_n − x̄) − E⁰ᵀ (X_n − X̄) (x̄ the nodal
   mean) and rotations ϑ_n = log(Eᵀ R_n E⁰);
3. the element's strain energy W_e = ½ dᵀ K_e d with its unchanged linear K_e;
4. the internal force is the gradient of Σ W_e with respect to the element's global DOFs and
   the tangent its Hessian (forward-over-reverse automatic differentiation, batched over the
   elements): exact, symmetric and consistent by construction, no projector or spin matrices.

Rotation parameterisation: a node's rotation DOFs θ (basic axes) are its *total* rotation
vector, R = exp([θ×]) (Rodrigues); the tangent map of exp is singular at |θ| = 2π for
rotations about other axes (a planar problem, whose rotation axis is fixed, is not affected).
Offsets (CBAR/CBEAM WA, WB) are rigid arms that turn with their grid: x_end = X + u + (R − I) w.
The Kelvin–Voigt material tangent is Bᵀ K_e B with B = ∂d/∂u (no stress-dependent part).

At u = 0, d = 0 and the Hessian is Bᵀ K_e B with B the linearised map, which equals the linear
element's Tᵀ K_e T because K_e has the rigid motions in its null space: the tangent at rest is
the linear stiffness (tests/test_fe_corotational.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch.func import grad, jvp, vjp, vmap

from ..mesh import BarSet, QuadSet, RodSet, TriaSet
from .bar import bar_local_stiffness
from .corot_shell import ShellMap
from .quad4 import plate_on_six, plate_parts
from .rod import rod_geometry, rod_torsion_local
from .tria3 import tria_plate_parts

#: Below this θ·θ (rad²) the Rodrigues coefficients sin φ/φ and (1 − cos φ)/φ² are evaluated by
#: their Taylor series (six terms: truncation below 1e-18) — smooth at θ = 0, where the closed
#: forms' derivatives are 0/0 (the model's rest state, where the Taylor coefficients are taken).
EXP_SERIES = 1e-2
#: Below this 1 − cos φ the logarithm's φ/sin φ is evaluated by its series (nine terms,
#: truncation below 1e-19) for the same reason.
LOG_SERIES = 1e-2
#: The frames each family uses (module docstring).
FRAMES = ("line", "quad", "tria")
#: Element states (elements × states) of one batched tangent pass
#: (:meth:`CorotKernel.element_matrices` with several states): its forward-over-reverse pass
#: holds about 0.2 MB per element state (measured on the TACS wingbox's CQUAD4s: 18 MB a state
#: of 91 shells), so 1,024 of them stay near 200 MB.
BATCH_ELEMENTS = 1024


@dataclass
class CorotElements:
    """One family of co-rotational elements (same node count and frame).

    ``conn`` (E, nn) grid rows; ``K`` (E, 6nn, 6nn) the linear stiffness in the element axes,
    six DOFs (t, θ) per node; ``offsets`` (E, nn, 3) rigid arms from the grids to the element's
    nodes (basic); ``ref`` (E, 3) the initial y axis (line frames only); ``kind`` names the
    cards (messages)."""

    kind: str
    frame: str
    eids: np.ndarray
    conn: np.ndarray
    K: np.ndarray
    offsets: np.ndarray
    ref: np.ndarray

    def __len__(self) -> int:
        return len(self.eids)

    def dof_index(self) -> np.ndarray:
        """(E, 6nn) all-grid DOF indices."""
        nn = self.conn.shape[1]
        return (self.conn[:, :, None] * 6 + np.arange(6)).reshape(len(self.conn), 6 * nn)

    @staticmethod
    def concat(groups: list[CorotElements]) -> CorotElements:
        """One family from several with the same frame and node count."""
        if len(groups) == 1:
            return groups[0]
        return CorotElements("+".join(g.kind for g in groups), groups[0].frame,
                             *(np.concatenate([getattr(g, f) for g in groups]) for f in
                               ("eids", "conn", "K", "offsets", "ref")))


def _perpendicular(e: np.ndarray) -> np.ndarray:
    """Unit vectors (n, 3) normal to the unit vectors e (n, 3) (any: rods have no y axis)."""
    b = np.eye(3)[np.argmin(np.abs(e), axis=1)]
    p = b - np.einsum("ni,ni->n", b, e)[:, None] * e
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def line_elements(bars: BarSet, rods: RodSet, xyz: np.ndarray) -> CorotElements | None:
    """CBAR/CBEAM (their whole condensed 12 × 12 stiffness, offsets WA/WB) and the torsion of
    CROD/CONROD with J > 0, or None when there are none."""
    groups = []
    if len(bars):
        _, R, K = bar_local_stiffness(bars, xyz)
        groups.append(CorotElements("CBAR/CBEAM", "line", bars.eids.copy(), bars.nodes.copy(), K,
                                    np.stack((bars.wa, bars.wb), axis=1), R[:, 1].copy()))
    if len(rods):
        sel, K = rod_torsion_local(rods, xyz)
        if sel.any():
            _, e = rod_geometry(rods.nodes[sel], xyz)
            groups.append(CorotElements("CROD torsion", "line", rods.eids[sel],
                                        rods.nodes[sel], K, np.zeros((len(K), 2, 3)),
                                        _perpendicular(e)))
    return CorotElements.concat(groups) if groups else None


def plate_elements(shells: QuadSet | TriaSet, xyz: np.ndarray,
                   drilling: float) -> CorotElements | None:
    """Bending, transverse shear (MITC4) and drilling of quads or triangles with bending (the
    membrane stays in the Green-strain kernel), or None."""
    quad = isinstance(shells, QuadSet)
    if not (shells.bend_E > 0).any():
        return None
    sel, _, Kl, dN0, k = (plate_parts if quad else tria_plate_parts)(shells, xyz, drilling)
    n, nn = dN0.shape[:2]
    K = plate_on_six(np.broadcast_to(np.eye(3), (n, 3, 3)), Kl, dN0, k)
    return CorotElements("CQUAD4" if quad else "CTRIA3", "quad" if quad else "tria",
                         shells.eids[sel], shells.nodes[sel], K, np.zeros((n, nn, 3)),
                         np.zeros((n, 3)))


# -- rotations ------------------------------------------------------------------------------------
def _horner(x: torch.Tensor, coefficients) -> torch.Tensor:
    out = torch.full_like(x, float(coefficients[-1]))
    for c in coefficients[-2::-1]:
        out = out * x + c
    return out


_SIN_SERIES = [(-1.0) ** k / float(np.prod(np.arange(1, 2 * k + 2))) for k in range(6)]
_COS_SERIES = [(-1.0) ** k / float(np.prod(np.arange(1, 2 * k + 3))) for k in range(6)]
# φ / sin φ as a series in x = 1 − cos φ: Σ 2ⁿ (n!)² / (2n + 1)! xⁿ
_LOG_SERIES = [2.0**k * float(np.prod(np.arange(1, k + 1))) ** 2
               / float(np.prod(np.arange(1, 2 * k + 2))) for k in range(9)]


def skew(v: torch.Tensor) -> torch.Tensor:
    """[v×] (..., 3, 3) of vectors (..., 3)."""
    z = torch.zeros_like(v[..., 0])
    return torch.stack((torch.stack((z, -v[..., 2], v[..., 1]), -1),
                        torch.stack((v[..., 2], z, -v[..., 0]), -1),
                        torch.stack((-v[..., 1], v[..., 0], z), -1)), -2)


def rodrigues(theta: torch.Tensor):
    """(a, b, c) = (sin φ/φ, (1 − cos φ)/φ², cos φ), φ = |θ|, of rotation vectors (..., 3):
    exp([θ×]) = c I + b θ θᵀ + a [θ×] (Rodrigues; [θ×]² = θ θᵀ − φ² I)."""
    s = (theta * theta).sum(-1)
    small = s < EXP_SERIES
    s_safe = torch.where(small, torch.ones_like(s), s)
    phi = torch.sqrt(s_safe)
    a = torch.where(small, _horner(s, _SIN_SERIES), torch.sin(phi) / phi)
    b = torch.where(small, _horner(s, _COS_SERIES), 2.0 * torch.sin(0.5 * phi) ** 2 / s_safe)
    return a, b, 1.0 - b * s


def rotate(theta: torch.Tensor, abc, v: torch.Tensor) -> torch.Tensor:
    """exp([θ×]) v = c v + b θ (θ·v) + a θ × v for vectors v (..., 3) (broadcast)."""
    a, b, c = (t[..., None] for t in abc)
    theta, v = torch.broadcast_tensors(theta, v)
    return (c * v + b * theta * (theta * v).sum(-1, keepdim=True)
            + a * _cross(theta, v))


#: (1 − sin φ/φ)/φ² = (φ − sin φ)/φ³ as a series in φ² (six terms, as _SIN_SERIES)
_SPIN_SERIES = [(-1.0) ** k / float(np.prod(np.arange(1, 2 * k + 4))) for k in range(6)]


def spin_map(theta: torch.Tensor) -> torch.Tensor:
    """T(θ) (..., 3, 3) with δω = T(θ) δθ: the spatial spin of R = exp([θ×]) (δR Rᵀ = [δω×])
    under a change δθ of the total rotation vector (the left Jacobian of SO(3)),
    T = I + b [θ×] + c [θ×]², b = (1 − cos φ)/φ², c = (φ − sin φ)/φ³.

    A dead moment M does the work M·δω = (Tᵀ M)·δθ: Tᵀ(θ) M is its generalized force on the
    rotation DOFs. T = I only for δθ parallel to θ (planar problems)."""
    s = (theta * theta).sum(-1)
    _, b, _ = rodrigues(theta)
    small = s < EXP_SERIES
    s_safe = torch.where(small, torch.ones_like(s), s)
    phi = torch.sqrt(s_safe)
    c = torch.where(small, _horner(s, _SPIN_SERIES), (phi - torch.sin(phi)) / (phi * s_safe))
    W = skew(theta)
    eye = torch.eye(3, dtype=theta.dtype, device=theta.device)
    return eye + b[..., None, None] * W + c[..., None, None] * (W @ W)


def _cross(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """a × b over the last axis, written out in elementwise products like the rest of the
    layer (no batched small-matrix kernels under the torch.func transforms)."""
    a1, a2, a3 = a.unbind(-1)
    b1, b2, b3 = b.unbind(-1)
    return torch.stack((a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1), -1)


def rotation_exp(theta: torch.Tensor) -> torch.Tensor:
    """R = exp([θ×]) (..., 3, 3) of rotation vectors θ (..., 3) (:func:`rodrigues`)."""
    a, b, c = rodrigues(theta)
    eye = torch.eye(3, dtype=theta.dtype, device=theta.device)
    outer = theta[..., :, None] * theta[..., None, :]
    return (c[..., None, None] * eye + b[..., None, None] * outer
            + a[..., None, None] * skew(theta))


def axial(A: torch.Tensor) -> torch.Tensor:
    """(A₃₂ − A₂₃, A₁₃ − A₃₁, A₂₁ − A₁₂) (..., 3) of matrices A (..., 3, 3): the vector w of
    A − Aᵀ = [w×]."""
    return torch.stack((A[..., 2, 1] - A[..., 1, 2], A[..., 0, 2] - A[..., 2, 0],
                        A[..., 1, 0] - A[..., 0, 1]), -1)


def rotation_log(Q: torch.Tensor) -> torch.Tensor:
    """Rotation vector ϑ (..., 3) of rotation matrices Q (..., 3, 3), |ϑ| < π:
    ϑ = (φ / sin φ) axial(Q − Qᵀ)/2 with cos φ = (tr Q − 1)/2."""
    return log_from_parts(0.5 * (3.0 - Q.diagonal(dim1=-2, dim2=-1).sum(-1)), 0.5 * axial(Q))


def log_from_parts(x: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """:func:`rotation_log` from x = 1 − cos φ = (3 − tr Q)/2 (...,) and
    v = sin φ · axis = axial(Q)/2 (..., 3): ϑ = (φ / sin φ) v."""
    small = x < LOG_SERIES
    x_safe = torch.where(small, torch.full_like(x, 0.5), x)
    exact = torch.acos(1.0 - x_safe) / torch.sqrt(x_safe * (2.0 - x_safe))
    return torch.where(small, _horner(x, _LOG_SERIES), exact)[..., None] * v


# -- frames ---------------------------------------------------------------------------------------
def _unit(v: torch.Tensor) -> torch.Tensor:
    return v / torch.sqrt((v * v).sum(-1, keepdim=True))


def _complete(e1: torch.Tensor, e3: torch.Tensor) -> torch.Tensor:
    return torch.stack((e1, _cross(e3, e1), e3), dim=-1)


def element_frame(frame: str, x: torch.Tensor, q: torch.Tensor | None = None):
    """Co-rotated axes (..., E, 3, 3), columns e1, e2, e3, from the nodal positions x
    (..., E, nn, 3) and (line frames) q (..., E, 3), the mean of the nodal rotations applied to
    the initial y axis (module docstring)."""
    if frame == "line":
        e1 = _unit(x[..., 1, :] - x[..., 0, :])
        e2 = _unit(q - (q * e1).sum(-1, keepdim=True) * e1)
        return torch.stack((e1, e2, _cross(e1, e2)), dim=-1)
    if frame == "quad":
        e3 = _unit(_cross(x[..., 2, :] - x[..., 0, :], x[..., 3, :] - x[..., 1, :]))
        a = (x[..., 1, :] + x[..., 2, :]) - (x[..., 0, :] + x[..., 3, :])
        return _complete(_unit(a - (a * e3).sum(-1, keepdim=True) * e3), e3)
    e1 = x[..., 1, :] - x[..., 0, :]
    e3 = _unit(_cross(e1, x[..., 2, :] - x[..., 0, :]))
    return _complete(_unit(e1), e3)


def _single_thread():
    """One intra-op thread: these are many small element operations, for which torch's thread
    pool costs far more than it gives on a loaded machine (the element energy of 1,960 quads:
    12 ms on one thread, 220 ms on two with the machine's two cores busy)."""
    from ...periodic.newton import single_thread

    return single_thread()


def _per_element(K: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """K_e d_e (..., E, k) for K (E, k, k): one batched product over the elements."""
    lead = d.shape[:-2]
    dm = d.reshape(-1, *d.shape[-2:]).movedim(0, -1)  # (E, k, B)
    return (K @ dm).movedim(-1, 0).reshape(*lead, *d.shape[-2:])


class CorotKernel:
    """Torch evaluation of one :class:`CorotElements` family on all-grid vectors
    (..., n_grid · 6), basic axes (T1..T3, R1..R3 per grid)."""

    def __init__(self, els: CorotElements, xyz: np.ndarray, dtype=torch.float64, device=None):
        if els.frame not in FRAMES:
            raise ValueError(f"frame: expected one of {FRAMES}, got {els.frame!r}")
        self.els = els
        self.n_all = xyz.shape[0] * 6
        self.nn = els.conn.shape[1]
        opts = dict(dtype=dtype, device=device)
        self.w = torch.as_tensor(els.offsets, **opts)
        self.has_offsets = bool(np.any(els.offsets))
        self.X = torch.as_tensor(xyz[els.conn], **opts) + self.w  # element nodes (E, nn, 3)
        self.K = torch.as_tensor(els.K, **opts)
        self.ref = torch.as_tensor(els.ref, **opts)
        self.E0 = element_frame(els.frame, self.X, self.ref)
        self.loc0 = torch.einsum("eij,eni->enj", self.E0,
                                 self.X - self.X.mean(-2, keepdim=True))
        self.dof_np = els.dof_index()
        self.dof = torch.as_tensor(self.dof_np.reshape(-1), device=device)
        self.k = self.dof_np.shape[1]
        #: The shells' force and tangent in closed form (:mod:`.corot_shell`: the same
        #: functions, 4-14 times faster than their automatic differentiation, which stays for
        #: the beams, the rigid arms, the damping derivative and the differentiable force)
        self.shell = (ShellMap(els.frame, self.X, self.E0, self.loc0)
                      if els.frame in ("quad", "tria") and not self.has_offsets else None)

    # -- element functions of the gathered element DOFs ue (..., E, 6nn) --------------------------
    def local_d(self, ue: torch.Tensor) -> torch.Tensor:
        """Local deformational displacements and rotations d (..., E, 6nn)."""
        u = ue.reshape(*ue.shape[:-1], self.nn, 6)
        theta = u[..., 3:]
        abc = rodrigues(theta)
        x = self.X + u[..., :3]
        if self.has_offsets:
            x = x + rotate(theta, abc, self.w) - self.w
        q = None
        if self.els.frame == "line":
            q = 0.5 * rotate(theta, abc, self.ref[:, None, :]).sum(-2)
        E = element_frame(self.els.frame, x, q)  # (..., E, 3, 3)
        dt = (x - x.mean(-2, keepdim=True)) @ E - self.loc0
        # Q = Eᵀ R E⁰ = c M + b η ζᵀ + a [η×] M with M = Eᵀ E⁰, η = Eᵀ θ, ζ = E⁰ᵀ θ
        # (Eᵀ [θ×] = [(Eᵀθ)×] Eᵀ). Its logarithm needs only tr Q and axial(Q), which are
        # vectors per node (no 3 × 3 matrix per node, the bulk of a tangent's arithmetic):
        # tr Q = c tr M + b η·ζ − a η·m and axial(Q) = c m + b ζ × η + a (tr M η − M η),
        # m = axial(M), from tr([η×] M) = −η·m and [η×] M + Mᵀ [η×] = [((tr M) I − M) η ×]
        M = E.transpose(-1, -2) @ self.E0  # (..., E, 3, 3)
        tr_M = M.diagonal(dim1=-2, dim2=-1).sum(-1)[..., None]  # (..., E, 1)
        m = axial(M)[..., None, :]  # (..., E, 1, 3)
        eta, zeta = theta @ E, theta @ self.E0  # (..., E, nn, 3)
        a, b, c = abc
        tr_Q = c * tr_M + b * (eta * zeta).sum(-1) - a * (eta * m).sum(-1)
        ax_Q = (c[..., None] * m + b[..., None] * _cross(zeta, eta)
                + a[..., None] * (tr_M[..., None] * eta - eta @ M.transpose(-1, -2)))
        rot = log_from_parts(0.5 * (3.0 - tr_Q), 0.5 * ax_Q)
        return torch.cat((dt, rot), -1).reshape(ue.shape)

    def element_energy(self, ue: torch.Tensor) -> torch.Tensor:
        """½ dᵀ K_e d (..., E)."""
        d = self.local_d(ue)
        return 0.5 * (d * _per_element(self.K, d)).sum(-1)

    def _element_force(self, ue: torch.Tensor) -> torch.Tensor:
        return grad(lambda z: self.element_energy(z).sum())(ue)

    def _element_material_force(self, ue: torch.Tensor, ve: torch.Tensor) -> torch.Tensor:
        """Bᵀ K_e B v with B = ∂d/∂u at ue."""
        dv = jvp(self.local_d, (ue,), (ve,))[1]
        pull = vjp(self.local_d, ue)[1]
        return pull(_per_element(self.K, dv))[0]

    # -- all-grid vectors -------------------------------------------------------------------------
    def gather(self, u_all: torch.Tensor) -> torch.Tensor:
        return u_all.index_select(-1, self.dof).reshape(*u_all.shape[:-1], len(self.els), self.k)

    def scatter(self, fe: torch.Tensor) -> torch.Tensor:
        flat = fe.reshape(*fe.shape[:-2], -1)
        out = torch.zeros(*flat.shape[:-1], self.n_all, dtype=flat.dtype, device=flat.device)
        return out.index_add(-1, self.dof, flat)

    def energy(self, u_all: torch.Tensor) -> torch.Tensor:
        with _single_thread():
            return self.element_energy(self.gather(u_all)).sum(-1)

    def internal_force(self, u_all: torch.Tensor) -> torch.Tensor:
        with _single_thread():
            return self.scatter(self._element_force(self.gather(u_all)))

    def force_values(self, u_all: torch.Tensor) -> torch.Tensor:
        """:meth:`internal_force`'s values (no graph through them: the shells' closed form,
        Bᵀ K_e d, where there is one)."""
        if self.shell is None:
            return self.internal_force(u_all)
        with _single_thread():
            ue = self.gather(u_all)
            flat = ue.reshape(-1, *ue.shape[-2:])
            parts = self.shell.parts(flat, second=False)
            fe = self.shell.pull(parts, _per_element(self.K, parts["d"]))
            return self.scatter(fe.reshape(ue.shape))

    def material_force(self, u_all: torch.Tensor, v_all: torch.Tensor) -> torch.Tensor:
        with _single_thread():
            return self.scatter(self._element_material_force(self.gather(u_all),
                                                             self.gather(v_all)))

    # -- element matrices (numpy, for sparse assembly) -----------------------------------------
    def _second_order(self, ue: torch.Tensor, s: torch.Tensor, ve: torch.Tensor | None = None):
        """Per element (..., E, 6nn, 6nn) each, from one batched forward-over-reverse pass over
        the element DOFs ue (..., E, 6nn; leading axes: several states at once): G = Σ_i s_i
        ∂²d_i/∂u² at fixed weights s (..., E, 6nn), B = ∂d/∂u and, with a velocity ve,
        C = ∂(B ve)/∂u. With s = K_e d, Bᵀ K_e B + G is the Hessian of the energy; with
        s = K_e B ve, G + Bᵀ K_e C is ∂(Bᵀ K_e B ve)/∂u. K_e stays out of the differentiated
        functions: its (E, k, k) product under the transforms cost twice the rest of the
        tangent."""

        def parts(z):
            def work(w):
                d = self.local_d(w)
                return (s * d).sum(), d

            g, d = grad(work, has_aux=True)(z)
            if ve is None:
                return g, d
            return g, d, jvp(self.local_d, (z,), (ve,))[1]

        directions = self._directions(ue)
        m = len(directions)
        tangents = directions.reshape(m, *[1] * (ue.dim() - 1), self.k).expand(m, *ue.shape)
        cols = vmap(lambda t: jvp(parts, (ue,), (t,))[1])(tangents)  # (m, ..., E, k) each
        cols = [c.movedim(0, -1) for c in cols]  # (..., E, k, m)
        if m == self.k:
            return tuple(cols)
        lead = cols[0].shape[:-2]
        flat = [c.reshape(-1, self.k, m) for c in cols]
        return (self._spread(flat[0], symmetric=True).reshape(*lead, self.k, self.k),
                *(self._spread(c, symmetric=False).reshape(*lead, self.k, self.k)
                  for c in flat[1:]))

    def _directions(self, ue: torch.Tensor) -> torch.Tensor:
        """The unit directions of the second-order pass (m, 6nn). A shell's frame follows its
        nodes' positions alone and its node n's local rotation depends on θ_n alone, so no
        output couples the rotations of two nodes: the rotations are probed by three directions
        shared by all nodes (a colouring). Its outputs are unchanged by a translation of all
        its nodes together (frame and local displacements are of position differences), so
        the last node's translation columns are minus the sum of the others' (:meth:`_spread`)
        and are not probed: 3nn entries fewer than 6nn, 3(nn − 1) + 3 directions (12 for a
        quad instead of 24). A beam's frame takes the mean of its nodal triads: all 6nn."""
        eye = torch.eye(self.k, dtype=ue.dtype, device=ue.device)
        if self.els.frame == "line" or self.has_offsets:
            return eye
        t_idx, _ = self._node_indices(ue.device)
        shared = torch.zeros(3, self.nn, 6, dtype=ue.dtype, device=ue.device)
        shared[:, :, 3:] = eye[:3, None, :3]  # direction j: component j of every node's θ
        return torch.cat((eye[t_idx[: 3 * (self.nn - 1)]], shared.reshape(3, self.k)))

    def _node_indices(self, device):
        """Element-DOF indices of the translations (3nn,), node-major, and of each node's
        rotations (nn, 3)."""
        node = torch.arange(self.nn, device=device)[:, None] * 6
        return ((node + torch.arange(3, device=device)).reshape(-1),
                node + 3 + torch.arange(3, device=device))

    def _spread(self, cols: torch.Tensor, symmetric: bool) -> torch.Tensor:
        """(E, k, k) from the columns (E, k, 3(nn − 1) + 3) of :meth:`_directions`' colouring:
        the translation columns as they are, the last node's minus the sum of the others'
        (translation invariance); a shared rotation column's rows of node n's rotations into
        node n's rotation column (the other rows of those columns are zero, or, for a
        symmetric matrix, the transposed translation columns)."""
        nn, k = self.nn, self.k
        out = torch.zeros(cols.shape[0], k, k, dtype=cols.dtype, device=cols.device)
        t_idx, r_idx = self._node_indices(cols.device)
        probed = cols[:, :, : 3 * (nn - 1)]
        last = -probed.reshape(*probed.shape[:2], nn - 1, 3).sum(2)
        out[:, :, t_idx] = torch.cat((probed, last), -1)
        shared = cols[:, :, 3 * (nn - 1):]  # (E, k, 3)
        for n in range(nn):
            rows = r_idx[n]
            out[:, rows[:, None], rows[None, :]] = shared[:, rows, :]
        if symmetric:
            r_all = r_idx.reshape(-1)
            out[:, t_idx[:, None], r_all[None, :]] = out[:, r_all[:, None], t_idx[None, :]
                                                         ].transpose(1, 2)
        return out

    def element_matrices(self, u_all: np.ndarray, material: float = 1.0, geometric: float = 1.0,
                         damping: float = 0.0, v_all: np.ndarray | None = None) -> np.ndarray:
        """Per-element blocks (..., E, 6nn, 6nn) of material · Bᵀ K_e B + geometric · G
        + damping · ∂(Bᵀ K_e B v)/∂u: Bᵀ K_e B + G is the Hessian of the element energy
        (K_T, :meth:`_second_order`). ``u_all`` (..., n_all): leading axes are several states,
        evaluated in one pass (:data:`BATCH_ELEMENTS`)."""
        with _single_thread():
            return self._element_matrices(u_all, material, geometric, damping, v_all)

    def _element_matrices(self, u_all, material, geometric, damping, v_all,
                          closed_form: bool = True) -> np.ndarray:
        """``closed_form``: the shells' blocks from :mod:`.corot_shell` (all but the damping
        derivative); False: from automatic differentiation (the reference in the tests)."""
        opts = dict(dtype=self.K.dtype, device=self.K.device)
        ue = self.gather(torch.as_tensor(u_all, **opts))
        if closed_form and self.shell is not None and not damping:
            return self._shell_matrices(ue, material, geometric).cpu().numpy()
        out = torch.zeros(*ue.shape[:-2], len(self.els), self.k, self.k, **opts)
        if material or geometric:
            G, B = self._second_order(ue, _per_element(self.K, self.local_d(ue)))
            out += material * (B.transpose(-1, -2) @ self.K @ B) + geometric * G
        if damping:
            ve = self.gather(torch.as_tensor(v_all, **opts))
            sv = _per_element(self.K, jvp(self.local_d, (ue,), (ve,))[1])
            Gv, B, C = self._second_order(ue, sv, ve)
            out += damping * (Gv + B.transpose(-1, -2) @ self.K @ C)
        return out.cpu().numpy()

    def _shell_matrices(self, ue: torch.Tensor, material: float, geometric: float):
        """material · Bᵀ K_e B + geometric · G of the shells in closed form
        (:mod:`.corot_shell`)."""
        flat = ue.reshape(-1, *ue.shape[-2:])
        parts = self.shell.parts(flat, second=bool(geometric))
        out = None
        if material:
            B = self.shell.jacobian(parts)
            out = B.transpose(-1, -2) @ self.K @ B
            out = out if material == 1.0 else material * out
        if geometric:
            G = self.shell.weighted_hessian(parts, _per_element(self.K, parts["d"]))
            G = G if geometric == 1.0 else geometric * G
            out = G if out is None else out + G
        if out is None:
            out = torch.zeros(*flat.shape, self.k, dtype=flat.dtype, device=flat.device)
        return out.reshape(*ue.shape, self.k)
