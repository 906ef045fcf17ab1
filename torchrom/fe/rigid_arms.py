"""Rigid arms under large rotations: the RBE2 dependent translations of a co-rotational model.

:func:`~torchrom.fe.constraints.build_constraints` eliminates an RBE2 linearly,
u_m = u_n + θ_n × d (d = x_m − x_n): at a rotation θ the arm is stretched by |d| (sec θ − 1)
and does not turn out of its plane. Under large rotations (``FEModel(rotations="large")``) the
dependent translations are instead those of the rigid arm turned by the independent grid's
rotation R_n = exp([θ_n×]) (the co-rotational layer's total rotation vector,
:func:`~torchrom.fe.elements.corotational.rodrigues`):

    u_m = u_n + (R_n − I) d = T u + c(θ_n),   c = (R_n − I − [θ_n×]) d
      = b (θ (θ·d) − φ² d) + (a − 1) θ × d,     a = sin φ/φ, b = (1 − cos φ)/φ², φ = |θ_n|

— the linear elimination T plus a correction c of second order in θ_n (module
``lift``). The dependent rotations equal θ_n already (R_m = R_n). Applied to RBE2s whose
dependent components include the three translations; a chain of them is followed to its root
(:func:`rigid_arms`). On the Pazy wing (114 two-grid RBE2s with 9 mm arms from the
spar plate to the beams' neutral axes) the linear arms store a spurious 0.15 J at a rigid
rotation of 0.1 rad and 12 J at 0.3 rad, more than the 3.5 kg tip mass's bending energy (~5 J),
and stiffened the 0.5 kg tip deflection by 40 %.

The internal force on the free DOFs is Tᵀ Jᵀ f_all(T u + c) with J = I + ∂c/∂u_all, and the
tangent Tᵀ (Jᵀ K_all J + G) T with G = Σ_m ∂²(f_m · c_m)/∂θ_n² (the arms' initial-stress part).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import torch
from torch.func import hessian, jacfwd, vmap

from .elements.corotational import _cross, rodrigues


@dataclass(frozen=True)
class RigidArms:
    """The RBE2 arms turned by large rotations: ``dependent`` and ``independent`` grid rows
    (k,) and ``arms`` d = x_m − x_n (k, 3, basic axes, the model's length unit)."""

    dependent: np.ndarray
    independent: np.ndarray
    arms: np.ndarray

    def __len__(self) -> int:
        return len(self.dependent)


def _translation_parents(mesh) -> dict[int, int]:
    """Grid row → the independent grid row of the RBE2 that sets its three translations."""
    return {m: rb.independent for rb in mesh.rbe2 if {0, 1, 2} <= set(rb.comps)
            for m in rb.dependent}


def rigid_arms(mesh) -> RigidArms | None:
    """The arms of ``mesh``'s RBE2s (module docstring); None when there is none.

    A chain (an RBE2 whose independent grid is another's dependent) is followed to its root:
    exactly, u_m = u_n + (R_n − I)(x_m − x_n) with u_n itself turned by its own independent
    grid, so m's correction is the sum of one arm per link, each turned by that link's
    independent rotation (equal to the root's where the links carry rotations). Each link is
    one (dependent, independent, arm) entry; the lift adds entries with the same dependent.
    """
    parent = _translation_parents(mesh)
    dep, ind, arms = [], [], []
    for m in sorted(parent):
        child, n, depth = m, parent[m], 0
        while True:
            d = mesh.xyz[child] - mesh.xyz[n]
            if np.any(d != 0.0):
                dep.append(m)
                ind.append(n)
                arms.append(d)
            if n not in parent:
                break
            depth += 1
            if depth > len(parent):  # a cycle: the constraint builder refuses it
                break
            child, n = n, parent[n]
    if not dep:
        return None
    return RigidArms(np.array(dep, dtype=np.int64), np.array(ind, dtype=np.int64),
                     np.array(arms, dtype=np.float64).reshape(-1, 3))


def linear_rigid_elements(mesh) -> dict[str, int]:
    """Rigid elements whose constraint stays the linear elimination under large rotations:
    RBE2s that leave a translation free (their arm has no rigid length to keep), RBE1/RBAR
    (several independent grids) and RBE3 (an interpolation, not a rigid body)."""
    partial = sum(1 for rb in mesh.rbe2 if not {0, 1, 2} <= set(rb.comps))
    return {k: v for k, v in {"RBE2 without all three translations": partial,
                              "RBE1/RBAR": len(mesh.rbe1), "RBE3": len(mesh.rbe3)}.items()
            if v}


def arm_correction(theta: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """c = (exp([θ×]) − I − [θ×]) d (..., 3) for rotation vectors θ and arms d (..., 3)."""
    a, b, _ = rodrigues(theta)
    phi2 = (theta * theta).sum(-1, keepdim=True)
    return (b[..., None] * (theta * (theta * d).sum(-1, keepdim=True) - phi2 * d)
            + (a[..., None] - 1.0) * _cross(theta, d))


class ArmLift:
    """u_all = T u + c(u_all) for one dtype/device: ``lift`` (torch, differentiable) and the
    sparse Jacobian and arm stiffness of :meth:`jacobian`, :meth:`stiffness` (numpy)."""

    def __init__(self, arms: RigidArms, n_all: int, dtype=torch.float64, device=None):
        self.n_all = n_all
        opts = dict(dtype=dtype, device=device)
        k3 = np.arange(3)
        self.rot = torch.as_tensor((6 * arms.independent[:, None] + 3 + k3).reshape(-1),
                                   device=device)
        self.trans = torch.as_tensor((6 * arms.dependent[:, None] + k3).reshape(-1),
                                     device=device)
        self.d = torch.as_tensor(arms.arms, **opts)
        self._rot_np = (6 * arms.independent[:, None] + 3 + k3)
        self._trans_np = (6 * arms.dependent[:, None] + k3)

    def lift(self, u_lin: torch.Tensor) -> torch.Tensor:
        """u_lin (..., n_all) → u_lin + c at the dependent translations."""
        theta = u_lin.index_select(-1, self.rot).reshape(*u_lin.shape[:-1], -1, 3)
        c = arm_correction(theta, self.d).reshape(*u_lin.shape[:-1], -1)
        return u_lin.index_add(-1, self.trans, c)

    def _theta(self, u_lin: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(np.asarray(u_lin)[self._rot_np], dtype=self.d.dtype)

    def jacobian(self, u_lin: np.ndarray) -> sp.csr_matrix:
        """J = I + ∂c/∂u_all (n_all × n_all) at ``u_lin`` (numpy, one state)."""
        with torch.no_grad():
            C = vmap(jacfwd(arm_correction))(self._theta(u_lin), self.d).numpy()  # (k, 3, 3)
        rows = np.repeat(self._trans_np, 3, axis=1).reshape(-1)
        cols = np.tile(self._rot_np, (1, 3)).reshape(-1)
        n = self.n_all
        return (sp.identity(n, format="csr")
                + sp.csr_matrix((C.reshape(-1), (rows, cols)), shape=(n, n)))

    def stiffness(self, u_lin: np.ndarray, f_all: np.ndarray) -> sp.csr_matrix:
        """G = Σ_m ∂²(f_m · c_m)/∂θ_n² (n_all × n_all) with f_all the elements' force on the
        lifted state (the arms' initial-stress stiffness)."""
        def work(theta, d, f):
            return (f * arm_correction(theta, d)).sum()

        f = torch.as_tensor(np.asarray(f_all)[self._trans_np], dtype=self.d.dtype)
        with torch.no_grad():
            H = vmap(hessian(work))(self._theta(u_lin), self.d, f).numpy()  # (k, 3, 3)
        rows = np.repeat(self._rot_np, 3, axis=1).reshape(-1)
        cols = np.tile(self._rot_np, (1, 3)).reshape(-1)
        n = self.n_all
        return sp.csr_matrix((H.reshape(-1), (rows, cols)), shape=(n, n))
