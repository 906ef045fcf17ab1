"""Synthetic FE models for the identification tests, independent of torchrom.fe.

- :class:`TrussWing`: a cantilevered 3-D box truss ("wing") of St Venant–Kirchhoff bars with exact
  Green strain, translational DOFs only. Its internal force is an exact cubic polynomial of the
  displacements, it has a material tangent, and its intrusive ROM is known in closed form
  (per-bar strains e^(n) = d0·ΔΦ_n/L0², h^(nl) = ½ ΔΦ_n·ΔΦ_l/L0², "material" EA·L0), so the
  non-intrusive identification can be checked against an independent reference.
- :func:`touze_backend`: REFERENCE Sec. 5, the two-mode system with forces written out as printed
  there, tangents by automatic differentiation and the analytic Kelvin–Voigt damping tensors.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import torch

from torchrom.identify.backend import CallableBackend, FEBackend
from torchrom.rom import NonlinearROM

from .rom_fixtures import touze_force


class TrussWing(FEBackend):
    """Cantilever box truss along y: span ``span``, chord ``chord`` (x), depth ``depth`` (z)."""

    name = "truss-wing"
    has_material_tangent = True

    def __init__(self, n_bays: int = 6, span: float = 20.0, chord: float = 4.0,
                 depth: float = 1.0, EA: float = 1e7, mass_per_node: float = 1.0,
                 tip_mass: float = 5.0):
        super().__init__()
        corners = np.array([[0, 0], [chord, 0], [chord, depth], [0, depth]], float)
        X = np.array([[cx, span * k / n_bays, cz] for k in range(n_bays + 1)
                      for cx, cz in corners])
        node = lambda k, c: 4 * k + c  # noqa: E731
        bars = []
        for k in range(n_bays + 1):
            bars += [(node(k, c), node(k, (c + 1) % 4)) for c in range(4)]
            bars.append((node(k, 0), node(k, 2)))
        for k in range(n_bays):
            bars += [(node(k, c), node(k + 1, c)) for c in range(4)]
            bars += [(node(k, c), node(k + 1, (c + 1) % 4)) for c in range(4)]
        bars = np.array(bars)
        # the root station is clamped: drop bars between two root nodes
        bars = bars[~((bars[:, 0] < 4) & (bars[:, 1] < 4))]
        self.X, self.bars = X, bars
        self.d0 = X[bars[:, 1]] - X[bars[:, 0]]
        self.L0 = np.linalg.norm(self.d0, axis=1)
        self.EA = np.full(len(bars), EA)
        self.n_nodes = len(X)
        self.free_nodes = np.arange(4, self.n_nodes)
        self.n_dof = 3 * len(self.free_nodes)
        m = np.full(len(self.free_nodes), mass_per_node)
        m[-4:] += tip_mass / 4
        self._M = scipy.sparse.diags(np.repeat(m, 3)).tocsr()
        self.reference_length = span
        self._transverse_dofs = np.arange(2, self.n_dof, 3)
        self._translational_dofs = np.arange(self.n_dof)
        # point A: the tip leading-edge top corner
        a = 3 * (self.n_nodes - 1 - 4)
        self._outputs = {"A_Tx": a, "A_Ty": a + 1, "A_Tz": a + 2}
        self._load_shapes = {"uniform": self.pressure_like_load(1.0),
                             "step": self.pressure_like_load(1.0, step=True)}
        # scatter index of each bar end into the free DOFs (-1: clamped)
        full = -np.ones((self.n_nodes, 3), int)
        full[4:] = np.arange(self.n_dof).reshape(-1, 3)
        self._dof_i, self._dof_j = full[bars[:, 0]], full[bars[:, 1]]

    # ------------------------------------------------------------------------------------------
    def _du(self, u):
        U = np.zeros((self.n_nodes, 3))
        U[4:] = u.reshape(-1, 3)
        return U[self.bars[:, 1]] - U[self.bars[:, 0]]

    def _state(self, u):
        du = self._du(u)
        w = (self.d0 + du) / self.L0[:, None]                     # ∂E/∂Δu × L0
        E = (np.einsum("bi,bi->b", self.d0, du) + 0.5 * np.einsum("bi,bi->b", du, du)) / (
            self.L0**2)
        return w, E

    def _scatter_vec(self, fb):
        f = np.zeros(self.n_dof + 1)
        np.add.at(f, self._dof_j.ravel(), fb.ravel())
        np.add.at(f, self._dof_i.ravel(), -fb.ravel())
        return f[:-1]

    def _scatter_mat(self, kb):
        idx = np.concatenate([self._dof_i, self._dof_j], axis=1)  # (nb, 6)
        full = np.concatenate([np.concatenate([kb, -kb], 2), np.concatenate([-kb, kb], 2)], 1)
        rows = np.broadcast_to(idx[:, :, None], full.shape).ravel()
        cols = np.broadcast_to(idx[:, None, :], full.shape).ravel()
        keep = (rows >= 0) & (cols >= 0)
        return scipy.sparse.csr_matrix((full.ravel()[keep], (rows[keep], cols[keep])),
                                       shape=(self.n_dof, self.n_dof))

    def _internal_force(self, u):
        w, E = self._state(u)
        return self._scatter_vec((self.EA * E)[:, None] * w)

    def _material_tangent(self, u):
        w, _ = self._state(u)
        return self._scatter_mat((self.EA / self.L0)[:, None, None] * w[:, :, None] * w[:, None, :])

    def _tangent_stiffness(self, u):
        w, E = self._state(u)
        geo = (self.EA * E / self.L0)[:, None, None] * np.eye(3)[None]
        kb = (self.EA / self.L0)[:, None, None] * w[:, :, None] * w[:, None, :] + geo
        return self._scatter_mat(kb)

    def _mass(self):
        return self._M

    def _stiffness(self):
        return self._material_tangent(np.zeros(self.n_dof))

    def dofmap(self):
        """Nastran g-set map: grids 1..n_nodes, free DOFs = T1..T3 of the non-root grids."""
        from torchrom.identify.nastran import DofMap

        grid_ids = np.arange(1, self.n_nodes + 1)
        free = np.array([(g + 1, c) for g in self.free_nodes for c in (1, 2, 3)])
        T = np.zeros((6 * self.n_nodes, self.n_dof))
        T[6 * (free[:, 0] - 1) + free[:, 1] - 1, np.arange(self.n_dof)] = 1.0
        return DofMap(grid_ids, free, T)

    # ------------------------------------------------------------------------------------------
    def intrusive_rom(self, Phi: np.ndarray) -> NonlinearROM:
        """The exact projection, from the energy form of the bars (independent of any fit)."""
        n = Phi.shape[1]
        P = np.zeros((self.n_nodes, 3, n))
        P[4:] = Phi.reshape(-1, 3, n)
        dP = P[self.bars[:, 1]] - P[self.bars[:, 0]]             # (nb, 3, n)
        e = np.einsum("bi,bin->bn", self.d0, dP) / self.L0[:, None] ** 2
        h = 0.5 * np.einsum("bin,bil->bnl", dP, dP) / self.L0[:, None, None] ** 2
        c = self.EA * self.L0
        K1 = np.einsum("b,bm,bn->mn", c, e, e)
        G = np.einsum("b,bm,bnl->mnl", c, e, h)
        H = np.einsum("b,bms,bnl->msnl", c, h, h)
        M = Phi.T @ (self._M @ Phi)
        return NonlinearROM.from_gram(M, K1, G, H, symmetrize=True)

    def pressure_like_load(self, p: float, step: bool = False) -> np.ndarray:
        """Transverse nodal loads ∝ p on all free nodes; ``step``: sign flips behind mid-chord."""
        load = np.zeros((len(self.free_nodes), 3))
        x = self.X[self.free_nodes, 0]
        mid = 0.5 * (x.min() + x.max())
        load[:, 2] = p * (np.where(x < mid, 1.0, -1.0) if step else 1.0)
        return load.ravel()


def touze_backend(w1: float = 1.13, w2: float = 2.0) -> CallableBackend:
    """REFERENCE Sec. 5 as user callables: f as printed, K_T by autograd, K_mat = BᵀCB."""

    def force(u):
        return np.array(touze_force(u[0], u[1], w1, w2))

    def tangent(u):
        return torch.autograd.functional.jacobian(
            lambda x: torch.stack(touze_force(x[0], x[1], w1, w2)), torch.as_tensor(u)).numpy()

    C = np.diag([w1**2, w2**2])

    def kmat(u):
        # strains e_k = q_k + (q1² + q2²)/2: B_kj = δ_kj + q_j
        B = np.eye(2) + np.ones((2, 1)) * np.asarray(u)[None, :]
        return B.T @ C @ B

    return CallableBackend(force, tangent, np.eye(2), material_tangent=kmat, name="touze")


def touze_damping_tensors(w1: float = 1.13, w2: float = 2.0):
    """Analytic Kelvin–Voigt tensors of REFERENCE Sec. 5 with D = C (γ = 1), by hand:
    D_T(q) = (I + 1qᵀ)ᵀ C (I + 1qᵀ) = C + q cᵀ + c qᵀ + s q qᵀ, c = C1, s = 1ᵀC1."""
    c = np.array([w1**2, w2**2])
    s = c.sum()
    D1 = np.diag(c)
    I2 = np.eye(2)
    D2 = np.einsum("ml,n->mln", I2, c) + np.einsum("m,ln->mln", c, I2)
    D3 = 0.5 * s * (np.einsum("ml,pn->mlpn", I2, I2) + np.einsum("mp,ln->mlpn", I2, I2))
    return D1, D2, D3
