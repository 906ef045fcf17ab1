"""Element-level checks of the Green-strain (St Venant–Kirchhoff) kernels and linear elements.

Independent references: rigid-body invariance (exact zero), the linear stiffness (small-
displacement limit), central finite differences and autograd for the tangents, exact polynomial
structure of the internal force, and closed-form beam / rigid-body results.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from .fe_decks import model_of, new_deck, rotation, single_element

KINDS = ["rod", "membrane", "shear", "tria"]


def _rigid_displacement(fe, R, c):
    """Free-DOF vector of the rigid motion x -> R x + c of every grid (translations only)."""
    u = np.zeros(fe.n_dof)
    X = fe.grid_xyz
    disp = X @ R.T + c - X
    for k, (gid, comp) in enumerate(fe.free_dofs()):
        if comp <= 3:
            u[k] = disp[fe.mesh.grid_row()[gid], comp - 1]
    return u


def _random_u(fe, scale, seed=0):
    rng = np.random.default_rng(seed)
    size = np.ptp(fe.grid_xyz, axis=0).max()
    return scale * size * rng.standard_normal(fe.n_dof)


@pytest.mark.parametrize("kind", KINDS)
def test_large_rigid_rotation_gives_no_force(kind):
    fe = model_of(single_element(kind))
    R = rotation([0.3, -1.0, 0.7], np.pi / 2)  # 90 degrees about a skew axis
    u = _rigid_displacement(fe, R, np.array([0.5, -1.0, 2.0]))
    f = fe.internal_force(u)
    # Scale: the force of a 1 % strain of the same element.
    ref = np.linalg.norm(fe.stiffness_matrix() @ _random_u(fe, 0.01))
    assert np.linalg.norm(f) <= 1e-10 * ref  # exact zero up to rounding
    # The tangent there has no initial stress: K_T equals the material tangent.
    KT, Km = fe.tangent_stiffness(u).toarray(), fe.material_tangent(u).toarray()
    assert np.abs(KT - Km).max() <= 1e-10 * np.abs(Km).max()


@pytest.mark.parametrize("kind", KINDS)
def test_small_displacement_limit_is_linear_stiffness(kind):
    fe = model_of(single_element(kind))
    u = _random_u(fe, 1.0)
    K = fe.stiffness_matrix()
    eps = 1e-7
    lin = K @ u
    # f(εu)/ε = K u + O(ε): relative error of order ε · |u| / size.
    assert np.linalg.norm(fe.internal_force(eps * u) / eps - lin) <= 1e-5 * np.linalg.norm(lin)
    np.testing.assert_allclose(fe.material_tangent(np.zeros(fe.n_dof)).toarray(), K.toarray(),
                               rtol=0, atol=1e-12 * abs(K).max())


@pytest.mark.parametrize("kind", KINDS)
def test_tangents_match_finite_differences_and_autograd(kind):
    fe = model_of(single_element(kind))
    u = _random_u(fe, 0.05, seed=1)
    v = _random_u(fe, 1.0, seed=2)
    KT = fe.tangent_stiffness(u)
    h = 1e-6 * np.linalg.norm(u) / np.linalg.norm(v)
    fd = (fe.internal_force(u + h * v) - fe.internal_force(u - h * v)) / (2 * h)
    # Central differences of a cubic: error h² |f'''| ~ 1e-12 relative; rounding ~ 1e-9.
    assert np.linalg.norm(KT @ v - fd) <= 1e-7 * np.linalg.norm(fd)
    J = torch.autograd.functional.jacobian(fe.internal_force_torch, torch.tensor(u)).numpy()
    assert np.abs(J - KT.toarray()).max() <= 1e-12 * np.abs(J).max()
    Km = fe.material_tangent(u)
    mf = fe.material_force(u, v)
    assert np.linalg.norm(Km @ v - mf) <= 1e-12 * np.linalg.norm(mf)
    assert abs(Km - Km.T).max() <= 1e-12 * abs(Km).max()
    # ∂(K_mat(u) w)/∂u against finite differences (used by the Kelvin–Voigt transient).
    w = _random_u(fe, 1.0, seed=3)
    D = fe.damping_derivative(u, w)
    fdD = (fe.material_force(u + h * v, w) - fe.material_force(u - h * v, w)) / (2 * h)
    assert np.linalg.norm(D @ v - fdD) <= 1e-7 * np.linalg.norm(fdD)


@pytest.mark.parametrize("kind", KINDS)
def test_material_tangent_is_BtCB_of_the_green_strain(kind):
    """K_mat(u) = Σ B(u)ᵀ C B(u) with B = ∂E/∂u obtained here by autograd of the strains."""
    fe = model_of(single_element(kind))
    u = torch.tensor(_random_u(fe, 0.05, seed=4))
    st = fe._state()
    (kern,) = st.kernels

    def strains(x):
        return kern.strain(fe._all_torch(x, st)).reshape(-1)

    B = torch.autograd.functional.jacobian(strains, u).numpy()  # (P*nv, n_dof)
    C = torch.block_diag(*kern.C).numpy()
    ref = B.T @ C @ B
    Km = fe.material_tangent(u.numpy()).toarray()
    assert np.abs(Km - ref).max() <= 1e-12 * np.abs(ref).max()


@pytest.mark.parametrize("kind", KINDS)
def test_internal_force_is_an_exact_cubic(kind):
    fe = model_of(single_element(kind))
    u = _random_u(fe, 0.2, seed=6)
    s = np.array([0.0, 1.0, 2.0, 3.0])
    F = np.array([fe.internal_force(si * u) for si in s])
    coef = np.polyfit(s, F, 3)
    for s_new in (-1.5, 4.0):
        pred = np.array([np.polyval(coef[:, i], s_new) for i in range(F.shape[1])])
        ref = fe.internal_force(s_new * u)
        assert np.linalg.norm(pred - ref) <= 1e-10 * np.linalg.norm(ref)


@pytest.mark.parametrize("kind", KINDS)
def test_force_is_gradient_of_strain_energy(kind):
    fe = model_of(single_element(kind))
    u = torch.tensor(_random_u(fe, 0.1, seed=7), requires_grad=True)
    (g,) = torch.autograd.grad(fe.strain_energy_torch(u), u)
    f = fe.internal_force_torch(u.detach())
    assert torch.allclose(g, f, rtol=0, atol=1e-12 * f.abs().max())


def test_forward_mode_autograd_gives_taylor_coefficients():
    """torch.func.jvp/jacfwd work on internal_force_torch: the third directional derivative of
    a cubic is 6 × its cubic coefficient and constant (independent of the base point)."""
    fe = model_of(single_element("membrane"))
    u = torch.tensor(_random_u(fe, 0.1, seed=8))
    v = torch.tensor(_random_u(fe, 0.1, seed=9))

    def g(s):
        return fe.internal_force_torch(u + s * v)

    d3 = torch.func.jacfwd(torch.func.jacfwd(torch.func.jacfwd(g)))
    s0, s1 = torch.tensor(0.0, dtype=torch.float64), torch.tensor(0.7, dtype=torch.float64)
    a, b = d3(s0), d3(s1)
    assert torch.allclose(a, b, rtol=1e-10, atol=1e-10 * a.abs().max())
    F = np.array([fe.internal_force((u + si * v).numpy()) for si in (0.0, 1.0, 2.0, 3.0)])
    c3 = np.polyfit([0.0, 1.0, 2.0, 3.0], F, 3)[0]
    np.testing.assert_allclose(a.numpy(), 6 * c3, rtol=1e-7, atol=1e-9 * np.abs(6 * c3).max())


def test_batched_torch_force_matches_loop():
    fe = model_of(single_element("shear"))
    U = torch.tensor(np.stack([_random_u(fe, 0.1, seed=s) for s in range(4)]))
    batched = fe.internal_force_torch(U)
    for k in range(4):
        assert torch.allclose(batched[k], fe.internal_force_torch(U[k]), rtol=1e-14, atol=0)


def test_cbar_cantilever_closed_form():
    """Skew CBAR cantilever: tip loads along the element y, z, x axes and a tip torque give
    PL³/(3EI1), PL³/(3EI2), PL/(EA), TL/(GJ) (Hermite elements are exact for these)."""
    m = new_deck()
    axis = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    n, L = 4, 3.0
    for i in range(n + 1):
        m.add_grid(i + 1, list(axis * L * i / n))
    E, G, A, I1, I2, J = 2.0e11, 8.0e10, 1e-3, 2e-6, 5e-7, 1e-6
    m.add_mat1(1, E, G, None, rho=7800.0)
    m.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J)
    v = np.array([0.0, 0.0, 1.0])
    for i in range(n):
        m.add_cbar(i + 1, 1, [i + 1, i + 2], list(v), None)
    m.add_spc1(1, "123456", [1])
    fe = model_of(m)
    ey = v - (v @ axis) * axis
    ey /= np.linalg.norm(ey)
    ez = np.cross(axis, ey)
    tip = n + 1
    cases = [(ey, 0, L**3 / (3 * E * I1)), (ez, 0, L**3 / (3 * E * I2)), (axis, 0, L / (E * A)),
             (axis, 3, L / (G * J))]
    for direction, offset, flex in cases:
        load = fe.nodal_load({(tip, offset + c + 1): direction[c] for c in range(3)})
        U = fe.expand(fe.linear_static(load))
        disp = U[fe.mesh.grid_row()[tip], offset:offset + 3] @ direction
        assert disp == pytest.approx(flex, rel=1e-9)


def test_conm2_offset_rigid_body_kinetic_energy():
    """CONM2 with an offset (CID 0 and CID -1) and products of inertia: for a rigid velocity
    field (v at the grid, ω) the kinetic energy is ½ m |v + ω × r|² + ½ ωᵀ I ω with Nastran's
    sign convention I = [[I11, -I21, -I31], [-I21, I22, -I32], [-I31, -I32, I33]]."""
    I6 = [2.0, 0.3, 3.0, -0.2, 0.1, 4.0]
    Icg = np.array([[2.0, -0.3, 0.2], [-0.3, 3.0, -0.1], [0.2, -0.1, 4.0]])
    grid, r, mass = np.array([1.0, 2.0, 3.0]), np.array([0.4, -0.5, 0.6]), 5.0
    for cid, X in ((0, r), (-1, grid + r)):
        m = new_deck()
        m.add_grid(1, list(grid))
        m.add_conm2(1, 1, mass, cid=cid, X=list(X), I=I6)
        fe = model_of(m, autospc=False)
        M = fe.mass_matrix().toarray()
        rng = np.random.default_rng(0)
        vel, om = rng.standard_normal(3), rng.standard_normal(3)
        q = np.concatenate((vel, om))
        ke = 0.5 * mass * np.sum((vel + np.cross(om, r)) ** 2) + 0.5 * om @ Icg @ om
        assert 0.5 * q @ M @ q == pytest.approx(ke, rel=1e-12)


def test_dkt_bending_patch_test_and_rigid_modes():
    """CTRIA3 bending (DKT): a quadratic w (constant curvature) gives the exact strain energy
    ½ ∫ κᵀ D κ dA, and the element has exactly the three rigid modes of plate bending."""
    from torchrom.fe.elements.tria3 import dkt_local

    xy = np.array([[[0.0, 0.0], [1.3, 0.2], [0.4, 0.9]]])
    E, nu, t = 7e10, 0.3, 0.01
    K = dkt_local(xy, np.array([E]), np.array([nu]), np.array([t]))[0]
    a, b, c = 0.3, -0.2, 0.5  # w = a x² + b x y + c y²; θx = ∂w/∂y, θy = −∂w/∂x
    u = np.concatenate([[a * x * x + b * x * y + c * y * y, b * x + 2 * c * y,
                         -(2 * a * x + b * y)] for x, y in xy[0]])
    D = E * t**3 / (12 * (1 - nu**2))
    kxx, kyy, kxy = -2 * a, -2 * c, -2 * b
    area = 0.5 * abs(1.3 * 0.9 - 0.2 * 0.4)
    W = 0.5 * D * (kxx**2 + kyy**2 + 2 * nu * kxx * kyy + 0.5 * (1 - nu) * kxy**2) * area
    assert 0.5 * u @ K @ u == pytest.approx(W, rel=1e-12)
    lam = np.linalg.eigvalsh(K)
    assert np.all(np.abs(lam[:3]) <= 1e-12 * lam[-1]) and lam[3] > 1e-3 * lam[-1]


def _mitc4_with_rbf(xy, E, nu, t):
    from torchrom.fe.elements.quad4 import _mitc4_local

    n = len(xy)
    return _mitc4_local(xy, np.full(n, E), np.full(n, nu), np.full(n, t),
                        np.full(n, E / (2 * (1 + nu)) * 5 / 6))


def test_mitc4_bending_patch_test_and_rigid_modes():
    """CQUAD4 bending (MITC4 with the residual bending flexibility on its constant shear), one
    distorted quad (t = 0.1 on a unit element; the added flexibility ℓ²/(12 D) is about 30
    times the shear's own 1/(κ G t), so a leak into these states would show): a quadratic w
    with Kirchhoff rotations (constant curvature, no shear) gives the exact strain energy
    ½ ∫ κᵀ D κ dA (rounding only: the MITC4 tying-point shears of such a field are exactly
    zero, so the correction, which acts on them, adds nothing), and the element has exactly
    the three rigid modes of plate bending (the correction makes no new zero-energy mode and
    no negative one)."""
    xy = np.array([[[0.0, 0.0], [1.2, 0.1], [1.0, 0.9], [-0.1, 0.8]]])
    xy = xy - xy.mean(axis=1, keepdims=True)
    E, nu, t = 7e10, 0.3, 0.1
    K = _mitc4_with_rbf(xy, E, nu, t)[0]
    a, b, c = 0.3, -0.2, 0.5  # w = a x² + b x y + c y²; θx = ∂w/∂y, θy = −∂w/∂x
    u = np.concatenate([[a * x * x + b * x * y + c * y * y, b * x + 2 * c * y,
                         -(2 * a * x + b * y)] for x, y in xy[0]])
    D = E * t**3 / (12 * (1 - nu**2))
    kxx, kyy, kxy = -2 * a, -2 * c, -2 * b
    x, y = xy[0, :, 0], xy[0, :, 1]
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    W = 0.5 * D * (kxx**2 + kyy**2 + 2 * nu * kxx * kyy + 0.5 * (1 - nu) * kxy**2) * area
    assert 0.5 * u @ K @ u == pytest.approx(W, rel=1e-12)
    lam = np.linalg.eigvalsh(K)
    assert np.all(np.abs(lam[:3]) <= 1e-12 * lam[-1]) and lam[3] > 1e-4 * lam[-1]


def test_mitc4_constant_shear_has_the_residual_bending_flexibility():
    """A rectangle a × b in a constant transverse shear (w = γ x, no rotation): its energy is
    ½ γ² A / (1/(κ G t) + a²/(12 D)), D = E t³/(12(1 − ν²)), MacNeal's shear flexibility plus
    the bending flexibility a bilinear rotation field lacks (rounding only). Without the
    correction it is ½ γ² A κ G t, 30 times larger here (t/a = 0.1)."""
    a, b = 1.0, 0.6
    xy = np.array([[[-a / 2, -b / 2], [a / 2, -b / 2], [a / 2, b / 2], [-a / 2, b / 2]]])
    E, nu, t = 7e10, 0.3, 0.1
    K = _mitc4_with_rbf(xy, E, nu, t)[0]
    gamma = 1e-3
    u = np.concatenate([[gamma * x, 0.0, 0.0] for x, _ in xy[0]])
    ds = E / (2 * (1 + nu)) * 5 / 6 * t
    D = E * t**3 / (12 * (1 - nu**2))
    W = 0.5 * gamma**2 * a * b / (1 / ds + a**2 / (12 * D))
    assert 0.5 * u @ K @ u == pytest.approx(W, rel=1e-12)


def test_cquad4_shell_tangent_at_zero_is_linear_stiffness():
    """A CQUAD4 with bending: the nonlinear model's tangent at u = 0 is the linear stiffness (the
    bending and transverse shear, residual bending flexibility included, are one linear block of
    both), and f(εu)/ε → K u (relative O(ε))."""
    fe = model_of(single_element("shell"))
    K = fe.stiffness_matrix()
    np.testing.assert_allclose(fe.material_tangent(np.zeros(fe.n_dof)).toarray(), K.toarray(),
                               rtol=0, atol=1e-12 * abs(K).max())
    np.testing.assert_allclose(fe.tangent_stiffness(np.zeros(fe.n_dof)).toarray(), K.toarray(),
                               rtol=0, atol=1e-12 * abs(K).max())
    u = _random_u(fe, 1.0)
    eps = 1e-7
    lin = K @ u
    assert np.linalg.norm(fe.internal_force(eps * u) / eps - lin) <= 1e-5 * np.linalg.norm(lin)


@pytest.mark.parametrize("coupled", [False, True])
def test_rod_mass_is_msc_coupled_or_lumped(coupled):
    """CROD mass (MSC Nastran's, as CoFE's Crod.m writes it and the ten-bar truss of
    tests/decks/cofe_ten_bar_truss confirms to 1e-6 against MSC's f06): with PARAM COUPMASS
    m/12 [5 1; 1 5] along the rod and m/2 per end across it; lumped m/2 per end otherwise.
    Exact (round-off) on a skew rod with non-structural mass; and the closed-form frequency of
    the one-element fixed-free rod, ω² = (E A / L) / M₂₂ with M₂₂ = 5 m / 12 (coupled) or m / 2."""
    from torchrom.fe.model import assemble_mass

    m = single_element("rod")
    m.properties[1].nsm = 0.05
    if coupled:
        m.add_param("COUPMASS", [1])
    fe = model_of(m)
    x1, x2 = fe.grid_xyz
    L = np.linalg.norm(x2 - x1)
    e = (x2 - x1) / L
    mass = (2700.0 * 1e-4 + 0.05) * L
    M = assemble_mass(fe.mesh).toarray()
    T = np.ix_([0, 1, 2, 6, 7, 8], [0, 1, 2, 6, 7, 8])
    axial = np.array([[5.0, 1.0], [1.0, 5.0]]) / 12.0 if coupled else np.eye(2) / 2.0
    P = np.outer(e, e)
    expected = mass * (np.kron(axial, P) + np.kron(np.eye(2) / 2.0, np.eye(3) - P))
    np.testing.assert_allclose(M[T], expected, rtol=0, atol=1e-14 * mass)
    assert np.abs(M).sum() == pytest.approx(np.abs(M[T]).sum(), rel=1e-15)  # no rotary mass

    rod = new_deck()
    rod.add_mat1(1, 7.0e10, None, 0.3, rho=2700.0)
    rod.add_grid(1, [0.0, 0.0, 0.0], ps="123456")
    rod.add_grid(2, [2.0, 0.0, 0.0], ps="23456")
    rod.add_prod(1, 1, 1e-4)
    rod.add_crod(1, 1, [1, 2])
    if coupled:
        rod.add_param("COUPMASS", [1])
    M22 = 2700.0 * 1e-4 * 2.0 * (5.0 / 12.0 if coupled else 0.5)
    omega = np.sqrt(7.0e10 * 1e-4 / 2.0 / M22)
    assert model_of(rod).modes(1).frequencies_hz[0] == pytest.approx(omega / (2 * np.pi),
                                                                    rel=1e-10)
