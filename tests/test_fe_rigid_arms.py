"""RBE2 arms under large rotations (torchrom.fe.rigid_arms) in the co-rotational FEModel.

Independent references: the rotation matrix written out (Rodrigues, tests/fe_decks.rotation),
rigid-body motions of an unconstrained model (no force), and central finite differences of the
internal force (the tangent).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.fe.rigid_arms import arm_correction

from .fe_decks import assert_tangent_is_consistent, model_of, rotation
from .test_fe_corotational import _mixed_deck


def _with_rbe2(spc: bool = True):
    """The co-rotational test's mixed deck plus a CBAR hung from grid 2 on an RBE2 arm
    (grid 8, 0.3 off grid 2 in a skew direction) to grid 9."""
    m = _mixed_deck(spc)
    x2 = np.array(m.nodes[2].xyz)
    m.add_grid(8, list(x2 + [0.1, -0.2, 0.2]))
    m.add_grid(9, list(x2 + [0.8, -0.3, 0.5]))
    m.add_rbe2(10, 2, "123456", [8])
    m.add_cbar(11, 3, [8, 9], [0.0, 0.0, 1.0], None)
    return m


def _free_values(fe, u_grid: np.ndarray) -> np.ndarray:
    """The free-DOF vector whose free components are those of ``u_grid`` (n_grid, 6)."""
    g, c = fe.constraints.free.T
    return u_grid[g, c]


def test_arm_correction_is_the_rotated_arm_minus_the_linear_one():
    """c = (R − I − [θ×]) d against the rotation matrix written out (1e-14; angles up to 3 rad,
    and 1e-4 rad through the series branch, where c ≈ ½ θ × (θ × d))."""
    rng = np.random.default_rng(3)
    for phi in (1e-4, 0.3, 1.5, 3.0):
        axis = rng.normal(size=3)
        theta = phi * axis / np.linalg.norm(axis)
        d = rng.normal(size=3)
        ref = rotation(axis, phi) @ d - d - np.cross(theta, d)
        got = arm_correction(torch.tensor(theta), torch.tensor(d)).numpy()
        assert np.abs(got - ref).max() <= 1e-14 * max(1.0, np.abs(ref).max()), phi


@pytest.mark.parametrize("angle", [0.5, 2.0])
def test_rigid_rotation_with_an_rbe2_arm_produces_no_force(angle):
    """The unconstrained model with the RBE2 arm turned rigidly (0.5 and 2 rad about a skew
    axis): the internal force vanishes to rounding (1e-10 of ‖K‖ ‖u‖). With the linear arm
    (rotations="small" constraints) the CBAR on the arm would be stretched by 0.3 (sec θ − 1)."""
    fe = model_of(_with_rbe2(spc=False), autospc=False)
    assert len(fe._arms) == 1
    axis = np.array([0.4, -1.0, 0.8]) / np.linalg.norm([0.4, -1.0, 0.8])
    Q = rotation(axis, angle)
    X = fe.grid_xyz
    u = np.zeros((len(X), 6))
    u[:, :3] = X @ Q.T - X + np.array([0.1, 0.2, -0.3])
    u[:, 3:] = angle * axis
    uf = _free_values(fe, u)
    # the arm follows the rotation exactly
    np.testing.assert_allclose(fe.expand(uf, large=True), u, rtol=0, atol=1e-14)
    f = fe.internal_force(uf)
    K = fe.stiffness_matrix()
    assert np.abs(f).max() <= 1e-10 * abs(K).max() * np.abs(u).max()


def test_tangent_with_arms_matches_finite_differences():
    """K_T(u) with the arm's Jacobian and initial-stress part against central differences of
    f(u) at a state with rotations of about a radian (1e-6 relative; symmetric to rounding)."""
    fe = model_of(_with_rbe2(), autospc=False)
    rng = np.random.default_rng(7)
    u_grid = np.zeros((len(fe.grid_xyz), 6))
    u_grid[:, :3] = 0.05 * rng.normal(size=(len(u_grid), 3))
    u_grid[:, 3:] = 0.8 * rng.normal(size=(len(u_grid), 3))
    u = _free_values(fe, u_grid)
    scale = assert_tangent_is_consistent(fe, u, symmetry_rtol=1e-10)
    # the energy's gradient is the force (the lift enters both the same way)
    ut = torch.tensor(u, requires_grad=True)
    (g,) = torch.autograd.grad(fe.strain_energy_torch(ut), ut)
    np.testing.assert_allclose(g.numpy(), fe.internal_force(u), rtol=0, atol=1e-9 * scale)
