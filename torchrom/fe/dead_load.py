"""Dead loads under large rotations: the generalized force of forces and moments that keep their
direction and size (Nastran's FORCE, MOMENT and GRAV in SOL 106/400).

A load set is a vector on the all-grid DOFs (forces and moments, basic axes). Its generalized
force on the free DOFs is Tᵀ f while rotations are small. Under large rotations
(``FEModel(rotations="large")``), where a grid's rotation DOFs are its total rotation vector θ
(:mod:`torchrom.fe.elements.corotational`), two things change with the state u:

- a moment M does the work M·δω with the spatial spin δω = T(θ) δθ, so its generalized force
  is T(θ)ᵀ M (:func:`~torchrom.fe.elements.corotational.spin_map`), not M;
- a force F on a grid that an RBE2 arm d ties to its independent grid acts at the end of the
  turned arm, u_m = u_n + (R_n − I) d (:mod:`torchrom.fe.rigid_arms`): its generalized force on
  the independent rotations is ∂(F · (R_n − I) d)/∂θ_n, not the linear arm's d × F.

Applied to the linear elimination's Tᵀ f both are wrong by terms of the order of the rotation,
except for a moment about a fixed axis (planar problems): a tip mass behind the Pazy wing's
trailing edge under 45° of bending twisted the tip 21 % too much (issue 45).
The load stiffness −∂g/∂u is left out of the tangents (it is not symmetric for moments); Newton
then converges linearly where the loads turn much in one step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class DeadLoad:
    """A dead load set of FE model ``fe``: ``f_all`` (n_all,) forces and moments on every grid's
    six DOFs, basic axes. ``at(u)`` is its generalized free-DOF force at the state u; scaled and
    added like a vector (``F_w + m * F_1``)."""

    fe: object
    f_all: np.ndarray

    def __post_init__(self):
        f = np.asarray(self.f_all, dtype=float).reshape(-1)
        if f.shape != (self.fe.n_all,):
            raise InputError(f"dead load: expected {self.fe.n_all} all-grid entries, got "
                             f"{f.shape}")
        object.__setattr__(self, "f_all", f)

    @property
    def linear(self) -> np.ndarray:
        """Tᵀ f: the generalized force at rest (and of a small-rotation model everywhere)."""
        return self.fe.T.T @ self.f_all

    def at(self, u) -> np.ndarray:
        """The generalized free-DOF force at the free-DOF state ``u``."""
        return self.fe.generalized_load(u, self.f_all)

    def _same_model(self, other: DeadLoad) -> None:
        if other.fe is not self.fe:
            raise InputError("dead load: the two loads belong to different FE models")

    def __add__(self, other: DeadLoad) -> DeadLoad:
        self._same_model(other)
        return DeadLoad(self.fe, self.f_all + other.f_all)

    def __sub__(self, other: DeadLoad) -> DeadLoad:
        self._same_model(other)
        return DeadLoad(self.fe, self.f_all - other.f_all)

    def __mul__(self, scale: float) -> DeadLoad:
        return DeadLoad(self.fe, float(scale) * self.f_all)

    __rmul__ = __mul__

    def __neg__(self) -> DeadLoad:
        return DeadLoad(self.fe, -self.f_all)


def applied(load, u) -> np.ndarray:
    """The generalized force of ``load`` (a free-DOF vector, or a :class:`DeadLoad`) at ``u``."""
    return load.at(u) if isinstance(load, DeadLoad) else load


def reference(load) -> np.ndarray:
    """A free-DOF vector for the size of ``load`` (its value at rest): convergence scales."""
    return load.linear if isinstance(load, DeadLoad) else load
