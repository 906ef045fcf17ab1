"""Co-rotational large rotations (torchrom.fe.elements.corotational) in FEModel.

Independent references: the inextensible elastica of a cantilever under a dead tip force
(closed form in elliptic integrals, written here with scipy.special; Mattiasson's 1981 table
is reproduced to his 5 digits at P L²/EI = 1: tip deflection 0.30172 L, shortening 0.05643 L),
the circle into which an end moment M bends a cantilever (curvature M/EI: tip at
(L sin φ/φ, L (1 − cos φ)/φ), φ = M L/EI, a full circle at M = 2π EI/L), central finite
differences of the internal force, rigid-body motions and the linear stiffness matrix.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from torchrom.errors import InputError
from torchrom.fe.elements.corotational import rotation_exp, rotation_log
from torchrom.fe.model import LinearElementWarning

from .fe_decks import assert_tangent_is_consistent, model_of, new_deck, plate_strip, rotation


def elastica_tip(alpha: float) -> tuple[float, float, float]:
    """Tip of an inextensible cantilever of unit length under a dead tip force normal to its
    initial axis, α = P L²/EI: (rotation θ₀, x/L, y/L). With k² = (1 + sin θ₀)/2 and
    sin φ₁ = 1/(√2 k): √α = K(k) − F(φ₁, k), x = √(2 sin θ₀/α),
    y = 1 − 2 (E(k) − E(φ₁, k))/√α (EI θ'' = −P cos θ integrated once)."""
    lam = np.sqrt(alpha)

    def phi1(m):
        return np.arcsin(1.0 / np.sqrt(2.0 * m))

    m = brentq(lambda m: ellipk(m) - ellipkinc(phi1(m), m) - lam, 0.5 + 1e-15, 1.0 - 1e-15,
               xtol=1e-15)
    sin0 = 2.0 * m - 1.0
    return (np.arcsin(sin0), np.sqrt(2.0 * sin0) / lam,
            1.0 - 2.0 * (ellipe(m) - ellipeinc(phi1(m), m)) / lam)


def test_elastica_reproduces_mattiasson():
    """Mattiasson (IJNME 17, 1981), Table 1 at P L²/EI = 1: v/L = 0.30172, 1 − u/L = 0.94357,
    θ₀ = 0.46135 rad (his 5 digits)."""
    theta, x, y = elastica_tip(1.0)
    assert (theta, x, y) == pytest.approx((0.46135, 0.94357, 0.30172), abs=6e-6)


# -- models ------------------------------------------------------------------------------------
E_BEAM, L_BEAM, I_BEAM = 1.0e7, 1.0, 1.0e-7


def _cantilever(n: int, planar: bool = False, card: str = "CBAR"):
    """n CBARs (or CBEAMs without shear flexibility) along x, clamped at x = 0; EA/EI = 1e6 /
    L², so that the axial strain (≤ 1e-5 here) leaves the elastica's inextensibility exact to
    far below the tolerances."""
    m = new_deck()
    m.add_mat1(1, E_BEAM, None, 0.3)
    if card == "CBAR":
        m.add_pbar(1, 1, A=0.1, i1=I_BEAM, i2=I_BEAM, j=2 * I_BEAM)
    else:
        m.add_pbeam(1, 1, [0.0], ["C"], [0.1], [I_BEAM], [I_BEAM], [0.0], [2 * I_BEAM],
                    k1=0.0, k2=0.0)
    for i in range(n + 1):
        m.add_grid(i + 1, [L_BEAM * i / n, 0.0, 0.0], ps="345" if planar else "")
    for i in range(n):
        (m.add_cbar if card == "CBAR" else m.add_cbeam)(i + 1, 1, [i + 1, i + 2],
                                                        [0.0, 0.0, 1.0], None)
    m.add_spc1(1, "123456", [1])
    return model_of(m)


def _tip(fe, u, gid):
    return fe.expand(u)[fe.mesh.grid_row()[gid]]


@pytest.mark.parametrize("card", ["CBAR", "CBEAM"])
def test_cantilever_tip_force_follows_the_elastica(card):
    """20 elements, α = P L²/EI = 5 in 8 load steps: tip rotation 69.6°, deflection 0.714 L.
    Measured (both cards): tip x within 0.004 % of L, y 0.02 % of L, rotation 0.025 % of the
    elastica's (the linear element in its co-rotated frame converges as h²); asserted 0.5 %
    (of L for positions)."""
    n, alpha = 20, 5.0
    fe = _cantilever(n, card=card)
    P = alpha * E_BEAM * I_BEAM / L_BEAM**2
    res = fe.static_solve(fe.nodal_load({(n + 1, 2): P}), n_steps=8, raise_on_failure=True)
    tip = _tip(fe, res.u, n + 1)
    theta, x, y = elastica_tip(alpha)
    assert np.degrees(theta) > 60.0
    assert L_BEAM + tip[0] == pytest.approx(x * L_BEAM, abs=5e-3 * L_BEAM)
    assert tip[1] == pytest.approx(y * L_BEAM, abs=5e-3 * L_BEAM)
    assert tip[5] == pytest.approx(theta, rel=5e-3)
    assert np.abs(tip[[2, 3, 4]]).max() < 1e-9  # stays in its plane


def test_end_moment_rolls_the_cantilever_into_a_circle():
    """M = 2π EI/L in 16 load steps, planar (components 3-5 fixed: the rotation vector of the
    tip reaches 2π, where exp's tangent map is singular about the other axes). 40 elements:
    each is a chord of the circle of length L/n, so the nodes lie on a circle of radius
    (L/n)/(2 sin(φ/2n)) instead of L/φ (0.1 % at φ = 2π). Measured: tip within 0.018 % of L at
    every step, rotation to rounding; asserted 0.5 % of L at every step and for the full circle
    (tip back at the root, rotation 2π)."""
    n = 40
    fe = _cantilever(n, planar=True)
    M = 2 * np.pi * E_BEAM * I_BEAM / L_BEAM
    seen = []

    def check(lam, u):
        phi = lam * M * L_BEAM / (E_BEAM * I_BEAM)
        tip = _tip(fe, u, n + 1)
        exact = L_BEAM * np.array([np.sin(phi) / phi, (1 - np.cos(phi)) / phi])
        seen.append(phi)
        np.testing.assert_allclose(tip[:2] + [L_BEAM, 0.0], exact, atol=5e-3 * L_BEAM)
        assert tip[5] == pytest.approx(phi, rel=5e-3)

    res = fe.static_solve(fe.nodal_load({(n + 1, 6): M}), n_steps=16, callback=check,
                          raise_on_failure=True)
    assert seen[-1] == pytest.approx(2 * np.pi)
    tip = _tip(fe, res.u, n + 1)
    assert np.hypot(tip[0] + L_BEAM, tip[1]) < 5e-3 * L_BEAM


# -- shell strips --------------------------------------------------------------------------------
E_S, L_S, B_S, T_S = 1.2e6, 10.0, 1.0, 0.1  # Sze, Liu & Lo (2004), Sec. 4.1 and 4.2
EI_S = E_S * B_S * T_S**3 / 12.0  # ν = 0: the strip bends as a beam, no anticlastic curvature


def _strip(n: int, triangles: bool, planar: bool = False):
    m = plate_strip(n, 1, L_S, B_S, T_S, E_S, 0.0, 1.0, triangles=triangles)
    if planar:
        m.add_spc1(1, "246", [g for g in m.nodes if m.nodes[g].xyz[0] > 0])
    return model_of(m)


def _tip_grids(fe):
    x = fe.grid_xyz[:, 0]
    return fe.grid_ids[np.isclose(x, x.max())]


@pytest.mark.parametrize("triangles", [False, True])
def test_shell_strip_tip_force_follows_the_elastica(triangles):
    """Sze, Liu & Lo's "cantilever subjected to end shear force" (L = 10, b = 1, t = 0.1,
    E = 1.2e6, ν = 0, P = 4: α = P L²/EI = 4) on 16 CQUAD4 (MITC4) or 32 CTRIA3 (DKT) along
    the strip; the elastica is the reference (ν = 0 and b ≪ L: a beam). Measured: the quads'
    tip within 0.03 % of L of the elastica, rotation 0.03 % (MITC4's shear flexibility
    (E/G)(t/L)² ~ 1e-4 and the element's h²), the triangles' within 0.05 % of L and 0.02 %;
    asserted 0.5 % of L, rotation 1 % (the shell's extra error sources over the beam: its
    membrane, drilling and transverse shear)."""
    fe = _strip(16, triangles)
    P = 4.0
    tips = _tip_grids(fe)
    F = fe.nodal_load({(int(g), 3): P / len(tips) for g in tips})
    res = fe.static_solve(F, n_steps=6, raise_on_failure=True)
    u = np.mean([_tip(fe, res.u, g) for g in tips], axis=0)
    theta, x, y = elastica_tip(P * L_S**2 / EI_S)
    assert L_S + u[0] == pytest.approx(x * L_S, abs=5e-3 * L_S)
    assert u[2] == pytest.approx(y * L_S, abs=5e-3 * L_S)
    assert -u[4] == pytest.approx(theta, rel=1e-2)


@pytest.mark.parametrize("triangles", [False, True])
def test_shell_strip_end_moment_rolls_into_a_circle(triangles):
    """Sze et al.'s end-moment roll-up: M = 2π EI/L (EI = E b t³/12, ν = 0) rolls the strip
    into a full circle; planar (components 2, 4, 6 fixed, exact for ν = 0: the
    rotation vector reaches 2π about y). 20 elements along: chords of the circle as for the
    beam (0.4 % of the radius). Measured: within 0.07 % of L at every step (quads and
    triangles), rotation 2e-7; asserted 1 % of L and of the rotation at each of the 10 steps,
    the full circle within 0.5 % of L."""
    n = 20
    fe = _strip(n, triangles, planar=True)
    tips = _tip_grids(fe)
    M = 2 * np.pi * EI_S / L_S

    def check(lam, u):
        phi = lam * M * L_S / EI_S
        tip = np.mean([_tip(fe, u, g) for g in tips], axis=0)
        exact = L_S * np.array([np.sin(phi) / phi, (1 - np.cos(phi)) / phi])
        np.testing.assert_allclose([L_S + tip[0], tip[2]], exact, atol=1e-2 * L_S)
        assert -tip[4] == pytest.approx(phi, rel=1e-2)

    res = fe.static_solve(fe.nodal_load({(int(g), 5): -M / len(tips) for g in tips}),
                          n_steps=10, callback=check, raise_on_failure=True)
    tip = np.mean([_tip(fe, res.u, g) for g in tips], axis=0)
    assert np.hypot(L_S + tip[0], tip[2]) < 5e-3 * L_S


# -- consistency, rigid motions, rest state --------------------------------------------------------
def _mixed_deck(spc: bool = True):
    """A warped quad, a triangle, a CBAR with offsets, a CBEAM with a pin flag and a CROD with
    torsion (J > 0) sharing grids, in general position."""
    m = new_deck()
    m.add_mat1(1, 7.0e10, None, 0.3, rho=2700.0)
    Rz = rotation([0.3, -0.5, 1.0], 0.7)
    pts = np.array([[0, 0, 0], [1.1, 0.1, 0.05], [1.0, 0.9, -0.03], [-0.1, 0.8, 0.02],
                    [2.0, 0.5, 0.1], [1.5, -0.6, 0.3], [0.4, 1.6, -0.2]]) @ Rz.T
    for k, p in enumerate(pts):
        m.add_grid(k + 1, list(p))
    m.add_pshell(1, mid1=1, t=0.02, mid2=1, mid3=1)
    m.add_cquad4(1, 1, [1, 2, 3, 4])
    m.add_ctria3(2, 1, [2, 5, 3])
    m.add_pbar(3, 1, A=1e-3, i1=2e-7, i2=1e-7, j=2e-7, k1=0.8, k2=0.8)
    m.add_cbar(3, 3, [2, 6], [0.0, 0.0, 1.0], None, offt="GGG", wa=[0.0, 0.05, 0.02],
               wb=[0.01, -0.03, 0.04])
    m.add_pbeam(4, 1, [0.0], ["C"], [1e-3], [2e-7], [1e-7], [0.0], [1e-7])
    m.add_cbeam(4, 4, [4, 7], [1.0, 0.0, 0.0], None, pb=5)
    m.add_prod(5, 1, 1e-4, j=1e-8)
    m.add_crod(5, 5, [5, 7])
    if spc:
        m.add_spc1(1, "123456", [1])
    return m


@pytest.fixture(scope="module")
def mixed():
    return model_of(_mixed_deck(), autospc=False)


def _large_state(fe, scale=1.0, seed=0):
    """A state with rotations of about a radian and translations of a tenth of the size."""
    rng = np.random.default_rng(seed)
    u = fe.expand(np.zeros(fe.n_dof)).copy()
    u[:, :3] = 0.1 * scale * rng.normal(size=(len(u), 3))
    u[:, 3:] = 0.8 * scale * rng.normal(size=(len(u), 3))
    return np.linalg.lstsq(fe.T.toarray(), u.reshape(-1), rcond=None)[0]


def test_consistent_tangent_matches_finite_differences(mixed):
    """K_T(u) (the Hessian of the energy) against central differences of f(u) at a state with
    rotations of about a radian: measured 1e-11 relative (truncation and rounding of the
    differences with h = 1e-6); asserted 1e-6. Symmetric to rounding."""
    assert_tangent_is_consistent(mixed, _large_state(mixed), symmetry_rtol=1e-12)


def test_material_and_damping_tangents_are_consistent(mixed):
    """K_mat(u) v (material_force) equals the assembled material tangent times v; the damping
    derivative ∂(K_mat(u) v)/∂u matches central differences along three random directions
    (1e-6 relative; measured 1e-10)."""
    fe = mixed
    u, v = _large_state(fe, seed=1), _large_state(fe, seed=2)
    Km = fe.material_tangent(u)
    np.testing.assert_allclose(Km @ v, fe.material_force(u, v), rtol=0,
                               atol=1e-12 * np.abs(Km @ v).max())
    Dm = fe.damping_derivative(u, v)
    h = 1e-6
    for w in np.random.default_rng(5).normal(size=(3, fe.n_dof)):  # directional differences
        Dfd = (fe.material_force(u + h * w, v) - fe.material_force(u - h * w, v)) / (2 * h)
        assert np.abs(Dm @ w - Dfd).max() <= 1e-6 * np.abs(Dm @ w).max()


@pytest.mark.parametrize("angle", [np.pi / 2, 2.5])
def test_rigid_rotation_produces_no_force(angle):
    """The whole (unconstrained) model turned by 90° (and 143°) about a skew axis through a
    point away from it, each grid's rotation vector the rigid rotation's: the internal force
    vanishes to rounding (1e-10 of ‖K‖ ‖u‖; measured 1e-15), offsets and pin flags included."""
    fe = model_of(_mixed_deck(spc=False), autospc=False)
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    Q = rotation(axis, angle)
    X = fe.grid_xyz
    centre = np.array([0.3, -1.0, 0.7])
    u = np.zeros((len(X), 6))
    u[:, :3] = (X - centre) @ Q.T + centre - X + np.array([0.2, -0.1, 0.4])
    u[:, 3:] = angle * axis
    f = fe.internal_force(u.reshape(-1))
    K = fe.stiffness_matrix()
    assert np.abs(f).max() <= 1e-10 * abs(K).max() * np.abs(u).max()


def test_tangent_at_rest_is_the_linear_stiffness(mixed):
    """K_T(0) equals the linear stiffness matrix (the elements' local matrices have the
    rigid motions in their null space); f(0) = 0."""
    fe = mixed
    K0 = fe.stiffness_matrix().toarray()
    KT = fe.tangent_stiffness(np.zeros(fe.n_dof)).toarray()
    assert np.abs(KT - K0).max() <= 1e-12 * np.abs(K0).max()
    assert np.abs(fe.internal_force(np.zeros(fe.n_dof))).max() <= 1e-12 * np.abs(K0).max()


def test_autograd_taylor_coefficients_at_rest(mixed):
    """The intrusive identification's nested forward-mode derivatives of f at u = 0
    (torchrom.identify.intrusive: jacfwd up to three levels) exist; the first is K (to rounding)
    and, projected on two vectors of a cantilever, the remainder of the cubic Taylor polynomial
    falls as |q|⁵ (the quartic term vanishes by the symmetry f(−u) = −f(u) of a straight beam):
    measured 32.0 on halving q; asserted 24-40."""
    fe = mixed
    q0 = torch.zeros(fe.n_dof, dtype=torch.float64)
    K1 = torch.func.jacfwd(fe.internal_force_torch)(q0).numpy()
    K0 = fe.stiffness_matrix().toarray()
    assert np.abs(K1 - K0).max() <= 1e-12 * np.abs(K0).max()
    beam = _cantilever(6)
    P = torch.as_tensor(np.linalg.eigh(beam.stiffness_matrix().toarray())[1][:, :2])

    def g(q):
        return P.T @ beam.internal_force_torch(P @ q)

    z = torch.zeros(2, dtype=torch.float64)
    jac = torch.func.jacfwd
    D1, D2, D3 = jac(g)(z), jac(jac(g))(z), jac(jac(jac(g)))(z)
    rest = []
    for s in (0.1, 0.05):
        a = s * torch.tensor([1.0, 0.5], dtype=torch.float64)
        taylor = (D1 @ a + torch.einsum("mab,a,b->m", D2, a, a) / 2
                  + torch.einsum("mabc,a,b,c->m", D3, a, a, a) / 6)
        rest.append(float((g(a) - taylor).abs().max()))
    assert 24.0 < rest[0] / rest[1] < 40.0


def test_batched_and_reverse_mode_forces(mixed):
    """f(u) for a batch of states equals the states' forces one by one; reverse-mode autograd
    through f gives K_Tᵀ w (to rounding)."""
    fe = mixed
    U = torch.as_tensor(np.stack([_large_state(fe, seed=s) for s in range(3)]))
    F = fe.internal_force_torch(U)
    for i in range(3):
        np.testing.assert_allclose(F[i].numpy(), fe.internal_force_torch(U[i]).numpy(),
                                   rtol=0, atol=1e-13 * float(F.abs().max()))
    w = torch.as_tensor(np.random.default_rng(6).normal(size=fe.n_dof))
    u = U[0].clone().requires_grad_(True)
    (fe.internal_force_torch(u) * w).sum().backward()
    ref = fe.tangent_stiffness(U[0].numpy()).T @ w.numpy()
    np.testing.assert_allclose(u.grad.numpy(), ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_rotation_maps_are_inverse_and_smooth():
    """log(exp(θ)) = θ for |θ| < π, across the series/closed-form switch and at 0."""
    rng = np.random.default_rng(4)
    theta = torch.as_tensor(rng.normal(size=(200, 3)))
    theta = theta * torch.as_tensor(rng.uniform(0, 3.0, size=(200, 1))) / theta.norm(dim=1,
                                                                                     keepdim=True)
    theta = torch.cat((theta, torch.zeros(1, 3), 0.099 * theta[:1] / theta[:1].norm(),
                       0.101 * theta[:1] / theta[:1].norm()))
    R = rotation_exp(theta)
    np.testing.assert_allclose(rotation_log(R).numpy(), theta.numpy(), rtol=0, atol=1e-12)
    eye = torch.eye(3, dtype=R.dtype)
    assert (R.transpose(1, 2) @ R - eye).abs().max() < 1e-14
    np.testing.assert_allclose(R[0].numpy(), rotation(theta[0].numpy(),
                                                      float(theta[0].norm())), atol=1e-14)


# -- options -------------------------------------------------------------------------------------
def test_small_rotations_keep_beams_and_bending_linear():
    """rotations="small": a beam's internal force is K u exactly (the paper's Goland option),
    and the model says so in its notes."""
    fe = model_of(_mixed_deck(), autospc=False, rotations="small")
    u = _large_state(fe)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LinearElementWarning)
        beams = _cantilever(4)
    small = model_of(beams.bdf, rotations="small")
    ub = _large_state(small)
    np.testing.assert_allclose(small.internal_force(ub), small.stiffness_matrix() @ ub,
                               rtol=1e-12, atol=1e-12 * np.abs(small.stiffness_matrix() @ ub).max())
    assert fe.rotations == "small" and "CBAR/CBEAM" in fe.linear_elements()
    assert np.isfinite(fe.internal_force(u)).all()
    with pytest.raises(InputError, match="rotations: expected one of large, small"):
        model_of(_mixed_deck(), rotations="medium")


def test_only_springs_and_solids_warn_as_linear():
    """With large rotations the warning names the springs (and solids) that stay linear, not the
    beams and plates; with small rotations the beams are named too."""
    m = _mixed_deck()
    m.add_celas2(10, 1e5, [3, 0], c1=1)
    for rotations, beams in (("large", False), ("small", True)):
        fe = model_of(m, autospc=False, rotations=rotations)
        with pytest.warns(LinearElementWarning) as rec:
            fe.internal_force(np.zeros(fe.n_dof))
        text = str(rec[0].message)
        assert "CELAS" in text and ("CBAR" in text) == beams


# -- batched tangents, the shells' colouring, the rotations' logarithm ----------------------------
def test_tangents_of_several_states_equal_one_by_one(mixed):
    """tangent_stiffnesses (the co-rotational blocks of several states in one pass) gives each
    state's tangent_stiffness, to 1e-13 of its largest entry (measured 1e-16: the batched
    products round differently), beams with offsets, quad and triangle together."""
    fe = mixed
    U = np.stack([_large_state(fe, seed=s) for s in range(3)])
    batch = fe.tangent_stiffnesses(U)
    assert len(batch) == 3
    for u, K in zip(U, batch):
        ref = fe.tangent_stiffness(u).toarray()
        assert np.abs(K.toarray() - ref).max() <= 1e-13 * np.abs(ref).max()


def test_shell_colouring_matches_every_direction(mixed, monkeypatch):
    """The shells' second-order pass probes 3(nn − 1) + 3 directions (the last node's
    translation columns from translation invariance, the rotations shared by the nodes):
    G, B equal those of all 6nn unit directions (no colouring) at a state with rotations of
    about a radian, to 1e-13 of their largest entries (measured 1e-16)."""
    from torchrom.fe.elements.corotational import CorotKernel, _per_element

    fe = mixed
    u_all = torch.as_tensor(fe.T @ _large_state(fe, seed=3))
    shells = [k for k in fe._state().corot if k.els.frame in ("quad", "tria")]
    assert {k.els.frame for k in shells} == {"quad", "tria"}
    for kern in shells:
        ue = kern.gather(u_all)
        s = _per_element(kern.K, kern.local_d(ue))
        assert len(kern._directions(ue)) == 3 * kern.nn
        coloured = kern._second_order(ue, s)
        monkeypatch.setattr(CorotKernel, "_directions",
                            lambda self, ue: torch.eye(self.k, dtype=ue.dtype))
        full = kern._second_order(ue, s)
        monkeypatch.undo()
        for a, b in zip(coloured, full):
            assert float((a - b).abs().max()) <= 1e-13 * float(b.abs().max()), kern.els.kind


def test_local_rotations_are_the_logarithm_of_the_rotated_frame(mixed):
    """local_d's rotations (from tr Q and axial(Q) as vectors) equal log(Eᵀ exp([θ×]) E⁰)
    formed from the 3 × 3 matrices (rotation_exp, element_frame, rotation_log), nodal
    rotations of about a radian and of 1e-4 rad (the logarithm's series), to 1e-12 rad."""
    from torchrom.fe.elements.corotational import element_frame

    fe = mixed
    for scale in (1.0, 1e-4):
        u_all = torch.as_tensor(fe.T @ _large_state(fe, scale=scale, seed=4))
        for kern in fe._state().corot:
            if kern.els.frame == "line":
                continue
            ue = kern.gather(u_all)
            u = ue.reshape(len(kern.els), kern.nn, 6)
            E = element_frame(kern.els.frame, kern.X + u[..., :3])
            Q = E.transpose(-1, -2)[:, None] @ rotation_exp(u[..., 3:]) @ kern.E0[:, None]
            rot = kern.local_d(ue).reshape(len(kern.els), kern.nn, 6)[..., 3:]
            assert float((rot - rotation_log(Q)).abs().max()) <= 1e-12, (kern.els.kind, scale)
