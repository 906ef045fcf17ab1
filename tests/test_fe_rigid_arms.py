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


def _assert_rigid_rotation_is_force_free(fe, angle: float) -> None:
    """The model turned rigidly by ``angle`` about a skew axis (and shifted): every dependent
    grid follows the rotation exactly (1e-14) and the internal force vanishes to rounding
    (1e-10 of ‖K‖ ‖u‖)."""
    axis = np.array([0.4, -1.0, 0.8]) / np.linalg.norm([0.4, -1.0, 0.8])
    Q = rotation(axis, angle)
    X = fe.grid_xyz
    u = np.zeros((len(X), 6))
    u[:, :3] = X @ Q.T - X + np.array([0.1, 0.2, -0.3])
    u[:, 3:] = angle * axis
    uf = _free_values(fe, u)
    np.testing.assert_allclose(fe.expand(uf, large=True), u, rtol=0, atol=1e-14)
    f = fe.internal_force(uf)
    K = fe.stiffness_matrix()
    assert np.abs(f).max() <= 1e-10 * abs(K).max() * np.abs(u).max()


@pytest.mark.parametrize("angle", [0.5, 2.0])
def test_rigid_rotation_with_an_rbe2_arm_produces_no_force(angle):
    """The unconstrained model with the RBE2 arm turned rigidly (0.5 and 2 rad about a skew
    axis): the internal force vanishes to rounding (1e-10 of ‖K‖ ‖u‖). With the linear arm
    (rotations="small" constraints) the CBAR on the arm would be stretched by 0.3 (sec θ − 1)."""
    fe = model_of(_with_rbe2(spc=False), autospc=False)
    assert len(fe._arms) == 1
    _assert_rigid_rotation_is_force_free(fe, angle)


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


def _with_rbe2_chain(spc: bool = True, rotations_carried: bool = True):
    """:func:`_with_rbe2` with the arm extended by a second RBE2 (grid 8 → grid 12, 0.25 further
    in another skew direction) carrying another CBAR to grid 13: a two-link chain."""
    m = _with_rbe2(spc)
    x8 = np.array(m.nodes[8].xyz)
    m.add_grid(12, list(x8 + [0.2, 0.15, -0.1]))
    m.add_grid(13, list(x8 + [0.6, 0.4, 0.3]))
    m.add_rbe2(14, 8, "123456" if rotations_carried else "123", [12])
    m.add_cbar(15, 3, [12, 13], [0.0, 0.0, 1.0], None)
    return m


@pytest.mark.parametrize("angle", [0.5, 2.0])
def test_rigid_rotation_of_an_rbe2_chain_produces_no_force(angle):
    """A chain grid 2 → 8 → 12 of two RBE2s turned rigidly: every dependent grid sits at its
    rotated place (1e-14) and the internal force vanishes (1e-10 of ‖K‖ ‖u‖). Linear at the
    second link, grid 12 would be off by |x12 − x8| (1 − cos θ)."""
    fe = model_of(_with_rbe2_chain(spc=False), autospc=False)
    assert len(fe._arms) == 3  # 8 ← 2, and 12 ← 8 ← 2 as two links
    _assert_rigid_rotation_is_force_free(fe, angle)


def test_tangent_with_an_rbe2_chain_matches_finite_differences():
    """The chain whose second link carries translations only (grid 8's rotation, not 2's,
    turns the second arm): the tangent against central differences (1e-6 relative)."""
    fe = model_of(_with_rbe2_chain(rotations_carried=False), autospc=False)
    rng = np.random.default_rng(11)
    u_grid = np.zeros((len(fe.grid_xyz), 6))
    u_grid[:, :3] = 0.05 * rng.normal(size=(len(u_grid), 3))
    u_grid[:, 3:] = 0.8 * rng.normal(size=(len(u_grid), 3))
    assert_tangent_is_consistent(fe, _free_values(fe, u_grid), symmetry_rtol=1e-10)


def test_linear_rigid_elements_are_named_in_the_warning():
    """An RBE2 that leaves a translation free stays the linear elimination, and the nonlinear
    analysis says so (LinearElementWarning naming it)."""
    from torchrom.fe.model import LinearElementWarning

    m = _mixed_deck(True)
    x2 = np.array(m.nodes[2].xyz)
    m.add_grid(8, list(x2 + [0.1, -0.2, 0.2]))
    m.add_grid(9, list(x2 + [0.8, -0.3, 0.5]))
    m.add_rbe2(10, 2, "12456", [8])
    m.add_cbar(11, 3, [8, 9], [0.0, 0.0, 1.0], None)
    fe = model_of(m, autospc=False)
    assert fe.linear_elements() == {"RBE2 without all three translations": 1}
    with pytest.warns(LinearElementWarning, match="RBE2 without all three translations"):
        fe.internal_force(np.zeros(fe.n_dof))
