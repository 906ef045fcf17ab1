"""St Venant–Kirchhoff (Green–Lagrange strain) kernel shared by rods, membranes and shear panels.

Vectorised over integration points in torch float64 (so that autograd, including
forward mode, gives exact Taylor coefficients of the internal forces), total Lagrangian
(DIGEST Eqs. 1–2, 4 with D = 0).

Every nonlinear element is described by its integration points. A point of an element with
``nn`` nodes and ``nd`` in-element directions (1 for a rod, 2 for a membrane or shear panel)
carries

- ``dN (nn, nd)``: shape-function derivatives with respect to orthonormal in-element coordinates
  (arc length along a rod; local Cartesian x, y in the plane of a quad);
- ``C (nv, nv)``: the constitutive matrix in Voigt form, multiplied by the integration weight
  (nv = 1: E11; nv = 3: [E11, E22, 2 E12]).

With undeformed tangent vectors g0_a = Σ_n X_n dN_na, displacement gradients h_a = Σ_n u_n dN_na
and deformed tangent vectors g_a = g0_a + h_a, the Green strain is
E_ab = ½ (g_a · g_b − g0_a · g0_b) = ½ (g0_a · h_b + h_a · g0_b + h_a · h_b), evaluated in the
second form (no cancellation at small strains; exact also for a slightly warped quad). It is
quadratic in the nodal displacements, the second Piola–Kirchhoff stress S = C E is quadratic,
and the nodal force f_n = Σ_ab S_ab dN_na g_b is exactly cubic.
A rigid motion leaves every g_a · g_b unchanged, so it produces no force.

Tangents (analytic, per point, for sparse assembly; computed with numpy because these small
batched products are faster without torch's thread pool):
- material tangent K_mat = Bᵀ C B with B = ∂E/∂u (depends on u through g);
- geometric (initial-stress) tangent K_geo = (dN S dNᵀ) ⊗ I3;
- K_T = K_mat + K_geo. For Kelvin–Voigt damping D = γ C the damping force is γ K_mat(u) u̇
  (NOTES-damping.md), and its derivative with respect to u (needed by an implicit integrator) is
  K_geo(Ṡ) + Bᵀ C B_v with Ṡ = C Ė(u; u̇) and B_v the strain operator built from the velocity
  gradients alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


@dataclass
class GreenPoints:
    """Integration points of one family of Green-strain elements (same ``nn`` and ``nd``).

    ``conn`` holds grid rows (not grid ids); ``eids`` the element id owning each point (for
    messages); ``kind`` the card name (CROD, CQUAD4, CSHEAR).
    """

    kind: str
    eids: np.ndarray  # (P,)
    conn: np.ndarray  # (P, nn) grid rows
    dN: np.ndarray  # (P, nn, nd)
    C: np.ndarray  # (P, nv, nv), weight folded in

    @property
    def n_points(self) -> int:
        return int(self.conn.shape[0])

    @property
    def n_nodes(self) -> int:
        return int(self.conn.shape[1])

    @property
    def n_dir(self) -> int:
        return int(self.dN.shape[2])

    def dof_index(self) -> np.ndarray:
        """(P, nn*3) indices of the translational DOFs in the all-grid vector (6 per grid)."""
        idx = self.conn[:, :, None] * 6 + np.arange(3)[None, None, :]
        return idx.reshape(self.n_points, -1)

    @staticmethod
    def concat(groups: list[GreenPoints]) -> GreenPoints:
        """One family from several with the same ``nn`` and ``nd`` (fewer, larger torch ops)."""
        if len(groups) == 1:
            return groups[0]
        return GreenPoints(
            kind="+".join(dict.fromkeys(g.kind for g in groups)),
            eids=np.concatenate([g.eids for g in groups]),
            conn=np.concatenate([g.conn for g in groups]),
            dN=np.concatenate([g.dN for g in groups]),
            C=np.concatenate([g.C for g in groups]),
        )


def voigt(E: torch.Tensor) -> torch.Tensor:
    """Tensor strain (..., nd, nd) -> Voigt (..., nv) with engineering shear."""
    if E.shape[-1] == 1:
        return E[..., 0, :]
    return torch.stack((E[..., 0, 0], E[..., 1, 1], E[..., 0, 1] + E[..., 1, 0]), dim=-1)


def unvoigt(S: torch.Tensor) -> torch.Tensor:
    """Voigt stress (..., nv) -> symmetric tensor (..., nd, nd)."""
    if S.shape[-1] == 1:
        return S[..., None]
    row0 = torch.stack((S[..., 0], S[..., 2]), dim=-1)
    row1 = torch.stack((S[..., 2], S[..., 1]), dim=-1)
    return torch.stack((row0, row1), dim=-2)


class GreenKernel:
    """Torch evaluation of one :class:`GreenPoints` family on all-grid displacement vectors.

    Vectors are laid out as (..., n_grid * 6) in basic axes (T1..T3, R1..R3 per grid); only the
    translations enter the Green strain.
    """

    def __init__(self, pts: GreenPoints, xyz: np.ndarray, dtype=torch.float64, device=None):
        self.pts = pts
        self.n_all = xyz.shape[0] * 6
        opts = dict(dtype=dtype, device=device)
        self.dN = torch.as_tensor(pts.dN, **opts)
        self.C = torch.as_tensor(pts.C, **opts)
        X = torch.as_tensor(xyz[pts.conn], **opts)  # (P, nn, 3)
        self.g0 = torch.einsum("pni,pna->pia", X, self.dN)  # (P, 3, nd)
        self.dof = torch.as_tensor(pts.dof_index().reshape(-1), device=device)
        self.dof_np = pts.dof_index()

    # -- gathering -------------------------------------------------------------------------
    def _nodal(self, u_all: torch.Tensor) -> torch.Tensor:
        """(..., n_all) -> (..., P, nn, 3) element translations."""
        ue = u_all.index_select(-1, self.dof)
        return ue.reshape(*u_all.shape[:-1], self.pts.n_points, self.pts.n_nodes, 3)

    def tangents(self, u_all: torch.Tensor) -> torch.Tensor:
        """Deformed tangent vectors g (..., P, 3, nd)."""
        return self.g0 + torch.einsum("...pni,pna->...pia", self._nodal(u_all), self.dN)

    def _grad(self, v_all: torch.Tensor) -> torch.Tensor:
        """Gradient of a displacement increment along the in-element directions (..., P, 3, nd)."""
        return torch.einsum("...pni,pna->...pia", self._nodal(v_all), self.dN)

    # -- strains and stresses ----------------------------------------------------------------
    def strain(self, u_all: torch.Tensor) -> torch.Tensor:
        """Green strain in Voigt form (..., P, nv)."""
        h = self._grad(u_all)
        gh = torch.einsum("pia,...pib->...pab", self.g0, h)
        E = 0.5 * (gh + gh.transpose(-1, -2) + torch.einsum("...pia,...pib->...pab", h, h))
        return voigt(E)

    def strain_rate(self, u_all: torch.Tensor, v_all: torch.Tensor) -> torch.Tensor:
        """Directional derivative of the Green strain at u along v: B(u) v (..., P, nv)."""
        g = self.tangents(u_all)
        gv = self._grad(v_all)
        Ed = torch.einsum("...pia,...pib->...pab", g, gv)
        return voigt(0.5 * (Ed + Ed.transpose(-1, -2)))

    def stress(self, strain_v: torch.Tensor) -> torch.Tensor:
        """S = C E (weighted), Voigt (..., P, nv)."""
        return torch.einsum("pvw,...pw->...pv", self.C, strain_v)

    def energy(self, u_all: torch.Tensor) -> torch.Tensor:
        """Strain energy ½ Σ Eᵀ C E (...,)."""
        E = self.strain(u_all)
        return 0.5 * (E * self.stress(E)).sum(dim=(-1, -2))

    def work_conjugate(self, u_all: torch.Tensor, stress_v: torch.Tensor) -> torch.Tensor:
        """Nodal forces B(u)ᵀ S scattered to (..., n_all) for a given (weighted) stress."""
        g = self.tangents(u_all)
        P1 = torch.einsum("...pia,...pab->...pib", g, unvoigt(stress_v))
        fe = torch.einsum("...pib,pnb->...pni", P1, self.dN)
        flat = fe.reshape(*fe.shape[:-3], -1)
        out = torch.zeros(*flat.shape[:-1], self.n_all, dtype=flat.dtype, device=flat.device)
        return out.index_add(-1, self.dof, flat)

    def internal_force(self, u_all: torch.Tensor) -> torch.Tensor:
        return self.work_conjugate(u_all, self.stress(self.strain(u_all)))

    def material_force(self, u_all: torch.Tensor, v_all: torch.Tensor) -> torch.Tensor:
        """K_mat(u) v = B(u)ᵀ C B(u) v."""
        return self.work_conjugate(u_all, self.stress(self.strain_rate(u_all, v_all)))

    # -- per-point matrices (numpy: small batched products, no thread-pool overhead) -----------
    def _np(self):
        if not hasattr(self, "_np_cache"):
            self._np_cache = (
                self.dN.cpu().numpy().astype(np.float64),
                self.C.cpu().numpy().astype(np.float64),
                self.g0.cpu().numpy().astype(np.float64),
            )
        return self._np_cache

    def _grad_np(self, v_all: np.ndarray) -> np.ndarray:
        dN = self._np()[0]
        ve = v_all[self.dof_np].reshape(self.pts.n_points, self.pts.n_nodes, 3)
        return np.einsum("pni,pna->pia", ve, dN)

    def _B_np(self, g: np.ndarray) -> np.ndarray:
        """Strain operator (P, nv, nn*3) for tangent vectors g (P, 3, nd)."""
        dN = self._np()[0]
        P, nn, nd = dN.shape
        if nd == 1:
            B = dN[:, None, :, 0, None] * g[:, None, None, :, 0]
        else:
            b0 = dN[:, :, 0, None] * g[:, None, :, 0]
            b1 = dN[:, :, 1, None] * g[:, None, :, 1]
            b2 = dN[:, :, 0, None] * g[:, None, :, 1] + dN[:, :, 1, None] * g[:, None, :, 0]
            B = np.stack((b0, b1, b2), axis=1)
        return B.reshape(P, -1, nn * 3)

    def _stress_np(self, Ed: np.ndarray) -> np.ndarray:
        """Weighted stress tensor (P, nd, nd) of a symmetric strain tensor (P, nd, nd)."""
        C = self._np()[1]
        if Ed.shape[-1] == 1:
            return C[:, :1, :1] * Ed
        ev = np.stack((Ed[:, 0, 0], Ed[:, 1, 1], Ed[:, 0, 1] + Ed[:, 1, 0]), axis=1)
        sv = np.einsum("pvw,pw->pv", C, ev)
        return np.stack(
            (np.stack((sv[:, 0], sv[:, 2]), -1), np.stack((sv[:, 2], sv[:, 1]), -1)), axis=1
        )

    def _geo_np(self, S: np.ndarray) -> np.ndarray:
        """(dN S dNᵀ) ⊗ I3 as (P, nn*3, nn*3)."""
        dN = self._np()[0]
        P, nn = dN.shape[:2]
        s = np.matmul(np.matmul(dN, S), dN.transpose(0, 2, 1))
        return (s[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]).reshape(
            P, nn * 3, nn * 3
        )

    def _bcb(self, B: np.ndarray, B2: np.ndarray) -> np.ndarray:
        C = self._np()[1]
        return np.matmul(B.transpose(0, 2, 1), np.matmul(C, B2))

    def point_matrices(self, u_all: np.ndarray, material: float = 1.0, geometric: float = 1.0,
                       damping: float = 0.0, v_all: np.ndarray | None = None) -> np.ndarray:
        """Per-point blocks (P, nn*3, nn*3) of the weighted sum
        material · K_mat(u) + geometric · K_geo(u) + damping · ∂(K_mat(u) v)/∂u (numpy).

        K_T = K_mat + K_geo; the last term is K_geo(C Ė(u; v)) + B(u)ᵀ C B_v (Kelvin–Voigt).
        """
        g0 = self._np()[2]
        h = self._grad_np(u_all)
        g = g0 + h
        B = self._B_np(g)
        K = np.zeros((B.shape[0], B.shape[2], B.shape[2]))
        if material:
            K += material * self._bcb(B, B)
        if geometric:
            gh = np.matmul(g0.transpose(0, 2, 1), h)
            E = 0.5 * (gh + gh.transpose(0, 2, 1) + np.matmul(h.transpose(0, 2, 1), h))
            K += geometric * self._geo_np(self._stress_np(E))
        if damping:
            gv = self._grad_np(v_all)
            Ed = np.matmul(g.transpose(0, 2, 1), gv)
            K += damping * (self._bcb(B, self._B_np(gv))
                            + self._geo_np(self._stress_np(0.5 * (Ed + Ed.transpose(0, 2, 1)))))
        return K
