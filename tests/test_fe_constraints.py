"""Constraint elimination: SPC/PS in rotated displacement systems, RBE2, RBE1, RBE3, chains,
AUTOSPC.

References: exact rigid-body kinematics (a rigid element must reproduce a rigid motion exactly),
the weighted-average property of the RBE3 for translations, the RBE2 that constrains the same
rigid body as an RBE1 (modes and static motion to 1e-10), and hand-built expectations.
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError

from .fe_decks import model_of, new_deck, rotation


def _rigid_free_vector(fe, t, w, grids=None):
    """Free-DOF values of the small rigid motion u = t + w × x, θ = w (CD components)."""
    u = np.zeros(fe.n_dof)
    row = fe.mesh.grid_row()
    for k, (gid, comp) in enumerate(fe.free_dofs()):
        if grids is not None and gid not in grids:
            continue
        g = row[gid]
        x = fe.grid_xyz[g]
        basic = np.concatenate((t + np.cross(w, x), w))
        axes = fe.mesh.cd_axes[g]
        c = comp - 1
        u[k] = axes[:, c % 3] @ basic[3 * (c // 3): 3 * (c // 3) + 3]
    return u


def _spring_deck(with_rbe: str):
    """Four independent grids carried by rods to ground-like supports, plus a dependent grid."""
    m = new_deck()
    pts = {1: [0.0, 0.0, 0.0], 2: [2.0, 0.0, 0.1], 3: [2.0, 1.5, -0.2], 4: [0.0, 1.0, 0.3],
           9: [0.7, 0.4, 0.5]}
    for nid, p in pts.items():
        m.add_grid(nid, p)
    m.add_mat1(1, 1e7, None, 0.3, rho=1.0)
    m.add_pshell(1, mid1=1, t=0.1, mid2=1, mid3=1)
    m.add_cquad4(1, 1, [1, 2, 3, 4])
    if with_rbe == "rbe3":
        m.add_rbe3(10, 9, "123456", [1.0, 3.0], ["123", "123"], [[1, 2], [3, 4]])
    elif with_rbe == "rbe2":
        m.add_rbe2(10, 1, "123456", [9])
    m.add_conm2(20, 9, 2.0, I=[1.0, 0.0, 1.0, 0.0, 0.0, 1.0])
    return m


@pytest.mark.parametrize("kind", ["rbe2", "rbe3"])
def test_rigid_elements_reproduce_rigid_motion(kind):
    fe = model_of(_spring_deck(kind), autospc=False)
    with pytest.raises(InputError, match="not an independent DOF"):
        fe.dof_index(9, 1)
    t, w = np.array([0.1, -0.2, 0.3]), np.array([0.02, 0.05, -0.03])
    U = fe.expand(_rigid_free_vector(fe, t, w))
    x9 = fe.grid_xyz[fe.mesh.grid_row()[9]]
    expected = np.concatenate((t + np.cross(w, x9), w))
    np.testing.assert_allclose(U[fe.mesh.grid_row()[9]], expected, rtol=0, atol=1e-13)


def test_rbe3_translation_is_the_weighted_average():
    """For pure translations of the independent grids (no rigid part), the reference grid's
    translation is the weighted mean when the weighted centroid is the reference point."""
    m = new_deck()
    pts = {1: [-1.0, 0.0, 0.0], 2: [1.0, 0.0, 0.0], 3: [0.0, 1.0, 0.0], 4: [0.0, -1.0, 0.0],
           9: [0.0, 0.0, 0.0]}
    for nid, p in pts.items():
        m.add_grid(nid, p)
    m.add_mat1(1, 1e7, None, 0.3, rho=1.0)
    m.add_prod(1, 1, 1e-2)
    for e, (a, b) in enumerate([(1, 3), (3, 2), (2, 4), (4, 1)]):
        m.add_crod(e + 1, 1, [a, b])
    m.add_rbe3(10, 9, "123", [1.0, 2.0], ["123", "123"], [[1, 2], [3, 4]])
    fe = model_of(m, autospc=False)  # a planar rod frame: T3 has no stiffness
    u = np.zeros(fe.n_dof)
    vals = {1: 1.0, 2: 3.0, 3: -2.0, 4: 5.0}
    for gid, val in vals.items():
        u[fe.dof_index(gid, 3)] = val
    U = fe.expand(u)
    mean = (1.0 * (1.0 + 3.0) + 2.0 * (-2.0 + 5.0)) / (2 * 1.0 + 2 * 2.0)
    assert U[fe.mesh.grid_row()[9], 2] == pytest.approx(mean, rel=1e-13)


def test_rbe_chain_and_cycle():
    m = _spring_deck("rbe3")
    m.add_grid(11, [1.0, 1.0, 1.0])
    m.add_rbe2(12, 9, "123456", [11])  # independent grid 9 is itself RBE3-dependent
    fe = model_of(m, autospc=False)
    t, w = np.array([0.0, 0.1, 0.0]), np.array([0.01, 0.0, 0.02])
    U = fe.expand(_rigid_free_vector(fe, t, w))
    x = fe.grid_xyz[fe.mesh.grid_row()[11]]
    np.testing.assert_allclose(U[fe.mesh.grid_row()[11], :3], t + np.cross(w, x), atol=1e-13)
    m.add_rbe2(13, 11, "123", [2])  # 2 -> 11 -> 9 -> (1, 2, 3, 4): a cycle through grid 2
    with pytest.raises(InputError, match="cycle"):
        model_of(m, autospc=False)


def test_rbe3_needs_a_rigid_fit():
    m = new_deck()
    for nid, x in ((1, 0.0), (2, 1.0), (3, 2.0), (9, 1.0)):
        m.add_grid(nid, [x, 0.0, 0.0 if nid != 9 else 0.5])
    m.add_rbe3(10, 9, "123456", [1.0], ["123"], [[1, 2, 3]])  # collinear: twist undetermined
    with pytest.raises(InputError, match="RBE3 10"):
        model_of(m)


def test_spc_in_rotated_displacement_system():
    """GRID CD in a rotated CORD2R: SPC/PS components and dof_index refer to that system and
    expand() returns basic components."""
    m = new_deck()
    R = rotation([0.0, 0.0, 1.0], np.deg2rad(30.0))
    m.add_cord2r(5, [0.0, 0.0, 0.0], list(R[:, 2]), list(R[:, 0]))
    m.add_grid(1, [0.0, 0.0, 0.0], cd=5, ps="123456")
    m.add_grid(2, [1.0, 0.0, 0.0], cd=5, ps="3456")
    m.add_mat1(1, 1e6, None, 0.3, rho=1.0)
    m.add_prod(1, 1, 1.0)
    m.add_crod(1, 1, [1, 2])
    m.add_spc1(1, "2", [2])  # local y of grid 2 constrained
    fe = model_of(m)
    assert fe.free_dofs() == [(2, 1)]
    U = fe.expand(np.array([1.0]))
    np.testing.assert_allclose(U[1, :3], R[:, 0], atol=1e-15)
    # Axial stiffness of the rod seen along the local x axis (30 degrees off the rod axis).
    assert fe.stiffness_matrix()[0, 0] == pytest.approx(1e6 * np.cos(np.deg2rad(30)) ** 2)
    with pytest.raises(InputError, match="SPC1 1"):
        fe.dof_index(2, 2)


def test_autospc_removes_dofs_without_stiffness():
    m = new_deck()
    for nid, p in enumerate([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], start=1):
        m.add_grid(nid, p)
    m.add_mat1(1, 1e6, None, 0.3, rho=1.0)
    m.add_pshell(1, mid1=1, t=0.1)  # membrane only: rotations and out-of-plane are singular
    m.add_cquad4(1, 1, [1, 2, 3, 4])
    fe = model_of(m)
    assert {c for _, c in fe.free_dofs()} == {1, 2}
    assert len(fe.autospc) == 4 * 4
    fe_all = model_of(m, autospc=False)
    assert fe_all.n_dof == 24


def test_mpc_makes_the_first_term_dependent():
    """MPC u2 − 2 u1 = 0 (T1 of two spring-mass grids): one DOF with k = k1 + 4 k2 and
    m = m1 + 4 m2; MPCADD and the case control select the set."""
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0])
    m.add_grid(2, [1.0, 0.0, 0.0])
    m.add_celas2(1, 300.0, [1, 0], "1", "")
    m.add_celas2(2, 50.0, [2, 0], "1", "")
    m.add_cmass2(3, 2.0, [1, 0], "1", "")
    m.add_cmass2(4, 0.5, [2, 0], "1", "")
    m.add_mpc(7, [2, 1], ["1", "1"], [1.0, -2.0])
    m.add_mpcadd(8, [7])
    fe = model_of(m)
    assert fe.n_dof == 1 and fe.constraints.status[(1, 0)] == "MPC 7"
    np.testing.assert_allclose(fe.modes(1).eigenvalues, [(300 + 4 * 50) / (2 + 4 * 0.5)],
                               rtol=1e-12)
    m.add_mpcadd(9, [7])
    with pytest.raises(InputError, match="several MPC sets"):
        model_of(m)


def _rigid_body_deck(kind: str):
    """A rigid body of grids 1-4 (grid 3 in a rotated CD system) on three bars to clamped
    grids, with point masses: held by an RBE2 (GN = 1, all of grid 2-4's components dependent)
    or by an RBE1 whose six independent components come from three grids (1: 123, 2: 23,
    3: 3), every other component dependent."""
    m = new_deck()
    R = rotation([1.0, -0.5, 0.3], 0.6)
    m.add_cord2r(6, [0.0, 0.0, 0.0], list(R[:, 2]), list(R[:, 0]))
    body = {1: [0.0, 0.0, 0.0], 2: [1.0, 0.2, 0.0], 3: [0.3, 0.9, 0.1], 4: [0.5, 0.4, 0.7]}
    for nid, x in body.items():
        m.add_grid(nid, x, cd=6 if nid == 3 else 0)
        m.add_grid(10 + nid, list(np.array(x) + [0.2, -0.3, -1.0]))
        m.add_conm2(20 + nid, nid, 1.0 + nid, I=[0.1, 0.0, 0.2, 0.0, 0.0, 0.3])
    m.add_mat1(1, 7e10, 2.7e10, None, rho=2700.0)
    m.add_pbar(1, 1, A=1e-4, i1=1e-8, i2=2e-8, j=1e-8)
    for nid in (1, 2, 4):
        m.add_cbar(30 + nid, 1, [nid, 10 + nid], [1.0, 0.0, 0.0], None)
    m.add_spc1(1, "123456", [11, 12, 13, 14])
    if kind == "rbe2":
        m.add_rbe2(40, 1, "123456", [2, 3, 4])
    else:
        m.add_rbe1(40, [1, 2, 3], ["123", "23", "3"], [1, 2, 3, 4],
                   ["456", "1456", "12456", "123456"])
    return m


def test_rbe1_equals_the_equivalent_rbe2():
    """An RBE1 taking its six independent components from three grids constrains the same
    rigid body as an RBE2 from one grid: the same modes and the same static motion of every
    grid (1e-10), though the two keep different DOFs."""
    fa = model_of(_rigid_body_deck("rbe1"))
    fb = model_of(_rigid_body_deck("rbe2"))
    assert fa.summary()["RBE1"] == 1 and fa.n_dof == fb.n_dof == 6
    assert fa.free_dofs() != fb.free_dofs()
    np.testing.assert_allclose(fa.modes(6).eigenvalues, fb.modes(6).eigenvalues, rtol=1e-10)
    load = {(4, 1): 3.0, (3, 2): -1.0, (2, 6): 0.5, (1, 3): 2.0}
    Ua = fa.expand(fa.linear_static(fa.nodal_load(load)))
    Ub = fb.expand(fb.linear_static(fb.nodal_load(load)))
    np.testing.assert_allclose(Ua, Ub, rtol=0, atol=1e-10 * np.abs(Ub).max())
    # and the body moves rigidly: grid 4 from grid 1's translation and rotation
    row = fa.mesh.grid_row()
    d = fa.grid_xyz[row[4]] - fa.grid_xyz[row[1]]
    u1 = Ua[row[1]]
    np.testing.assert_allclose(Ua[row[4]], np.concatenate((u1[:3] + np.cross(u1[3:], d),
                                                          u1[3:])), atol=1e-12 * np.abs(Ua).max())


def test_rbe1_needs_six_independent_components_fixing_a_rigid_motion():
    m = _rigid_body_deck("rbe1")
    rb = m.rigid_elements[40]
    # the translations of grids 1 and 2 only: the twist about the line 1-2 is left free
    rb.Gni, rb.Cni, rb.Cmi = [1, 2], ["123", "123"], ["456", "456", "123456", "123456"]
    with pytest.raises(InputError, match="RBE1 40: the independent components"):
        model_of(m)
    m = _rigid_body_deck("rbe1")
    m.rigid_elements[40].Cni = ["123", "23", "23"]
    with pytest.raises(InputError, match="RBE1 40: fields CN: expected six"):
        model_of(m)
