"""The shells' closed-form co-rotational force and tangent (torchrom.fe.elements.corot_shell)
against the automatic differentiation of the same energy (CorotKernel's forward-over-reverse
pass, the previous kernel), against central differences of the force, and its pieces (the
rotation's derivatives, the scalar factors) against forward-mode differentiation and
high-precision arithmetic."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import torch

from torchrom.fe.elements.corot_shell import (
    EXP_SERIES_BELOW,
    FRAME_DIFFERENCES,
    LOG_SERIES_BELOW,
    frame_derivatives,
    log_factor,
    rodrigues_factors,
    rotation_derivatives,
)
from torchrom.fe.elements.corotational import _per_element, element_frame, rotation_exp

from .fe_decks import assert_tangent_is_consistent, model_of, new_deck, rotation


def _shell_deck():
    """Two warped quads and a triangle sharing grids, in general position, one grid clamped."""
    m = new_deck()
    m.add_mat1(1, 7.0e10, None, 0.3, rho=2700.0)
    Rz = rotation([0.3, -0.5, 1.0], 0.7)
    pts = np.array([[0, 0, 0], [1.1, 0.1, 0.05], [1.0, 0.9, -0.03], [-0.1, 0.8, 0.02],
                    [2.1, 0.2, 0.1], [2.0, 1.0, -0.1], [1.6, 1.8, 0.2]]) @ Rz.T
    for k, p in enumerate(pts):
        m.add_grid(k + 1, list(p))
    m.add_pshell(1, mid1=1, t=0.02, mid2=1, mid3=1)
    m.add_cquad4(1, 1, [1, 2, 3, 4])
    m.add_cquad4(2, 1, [2, 5, 6, 3])
    m.add_ctria3(3, 1, [3, 6, 7])
    m.add_spc1(1, "123456", [1])
    return m


@pytest.fixture(scope="module")
def shells():
    return model_of(_shell_deck(), autospc=False)


def _state(fe, scale: float, seed: int) -> np.ndarray:
    """Rotations of about ``scale`` rad (0.8 × a normal draw: some above 1 rad, past the
    series' switch), translations a tenth of that."""
    rng = np.random.default_rng(seed)
    u = np.zeros((len(fe.grid_xyz), 6))
    u[:, :3] = 0.1 * scale * rng.normal(size=(len(u), 3))
    u[:, 3:] = 0.8 * scale * rng.normal(size=(len(u), 3))
    return np.linalg.lstsq(fe.T.toarray(), u.reshape(-1), rcond=None)[0]


@pytest.mark.parametrize("scale", [1.5, 1.0, 1e-3, 0.0])
def test_closed_form_equals_automatic_differentiation(shells, scale):
    """Per element, in one batch of three states: the closed-form tangent Bᵀ K_e B + G, its
    material and geometric parts alone, the force Bᵀ K_e d and d itself equal those of the
    automatic differentiation to 1e-10 of the largest tangent entry, force and d (measured
    4e-16 .. 2e-11 for the tangent, the largest with rotations near π in the 1.5 rad draw,
    where φ/sin φ amplifies the rounding of either; rounding in a different order), rotations
    from 0 (rest) to beyond the series' switch (|θ| of 1 rad) and the logarithm's
    (1 − cos φ = 0.1), quads and triangles.
    At rest, where d, f and G vanish, the closed form's d is its rounding (1e-14 m of
    positions near 1 m, the frame from differences of positions): asserted below 1e-13 m,
    and f, G below 1e-13 of the element stiffness."""
    fe = shells
    U = np.stack([fe.T @ _state(fe, scale, seed) for seed in range(3)])
    kernels = fe._state().corot
    assert sorted(k.els.frame for k in kernels) == ["quad", "tria"]
    assert all(k.shell is not None for k in kernels)
    for kern in kernels:
        stiff = float(kern.K.abs().max())
        full = kern._element_matrices(U, 1.0, 1.0, 0.0, None, closed_form=False)
        for material, geometric in ((1.0, 1.0), (1.0, 0.0), (0.0, 1.0)):
            closed = kern.element_matrices(U, material, geometric)
            ref = kern._element_matrices(U, material, geometric, 0.0, None, closed_form=False)
            assert closed.shape == ref.shape == (3, len(kern.els), kern.k, kern.k)
            assert np.abs(closed - ref).max() <= 1e-10 * np.abs(full).max() + 1e-13 * stiff, \
                (kern.els.kind, material)
        for u_all in torch.as_tensor(U):
            f, f_ref = kern.force_values(u_all), kern.internal_force(u_all)
            assert float((f - f_ref).abs().max()) <= (1e-10 * float(f_ref.abs().max())
                                                      + 1e-13 * stiff)
            ue = kern.gather(u_all)[None]
            d, d_ref = kern.shell.parts(ue, second=False)["d"], kern.local_d(ue)
            assert float((d - d_ref).abs().max()) <= 1e-10 * float(d_ref.abs().max()) + 1e-13


def test_model_force_and_tangent_are_consistent(shells):
    """FEModel.internal_force (the closed-form values) equals the differentiable
    internal_force_torch to 1e-12 of its largest entry; tangent_stiffness matches central
    differences of internal_force (1e-6 relative; measured 3e-11) and is symmetric to
    1e-12 at rotations of about a radian."""
    fe = shells
    u = _state(fe, 1.0, 7)
    f = fe.internal_force(u)
    f_ad = fe.internal_force_torch(torch.as_tensor(u)).detach().numpy()
    assert np.abs(f - f_ad).max() <= 1e-12 * np.abs(f_ad).max()
    assert_tangent_is_consistent(fe, u, symmetry_rtol=1e-12)


def test_weighted_hessian_matches_differences_of_the_jacobian(shells):
    """Σ_i s_i ∂²d_i/∂u² of the closed form against central differences of Bᵀ s (fixed s),
    each element DOF in turn: 1e-6 of its largest entry (h = 1e-6; measured 4e-10)."""
    fe = shells
    u_all = torch.as_tensor(fe.T @ _state(fe, 0.7, 3))
    h = 1e-6
    for kern in fe._state().corot:
        sm = kern.shell
        ue = kern.gather(u_all)[None]
        parts = sm.parts(ue, second=True)
        s = _per_element(kern.K, parts["d"])
        G = sm.weighted_hessian(parts, s)[0].numpy()
        cols = []
        for j in range(kern.k):
            e = torch.zeros(kern.k, dtype=ue.dtype)
            e[j] = h
            fp = sm.pull(sm.parts(ue + e, second=False), s)
            fm = sm.pull(sm.parts(ue - e, second=False), s)
            cols.append(((fp - fm) / (2 * h))[0].numpy())
        Gfd = np.stack(cols, -1)
        assert np.abs(G - Gfd).max() <= 1e-6 * np.abs(G).max(), kern.els.kind


def test_rotation_derivatives_match_forward_mode():
    """∂R/∂z and ∂²R/∂z² of R = exp([z×]) in closed form against nested forward-mode
    differentiation of rotation_exp (the kernel's Rodrigues formula), |z| from 0 to 3 rad across
    the series' switch at |z| = 1, all in one batch and each alone: 1e-12 (measured 5e-16)."""
    rng = np.random.default_rng(2)
    z = rng.normal(size=(40, 3))
    z *= rng.uniform(0.0, 3.0, size=(40, 1)) / np.linalg.norm(z, axis=1, keepdims=True)
    z = torch.as_tensor(np.vstack([z, np.zeros(3), 0.999 * z[0] / np.linalg.norm(z[0]),
                                   1.001 * z[0] / np.linalg.norm(z[0])]))
    R, dR, d2R = rotation_derivatives(z, second=True)
    jac = torch.func.jacfwd
    for i, zi in enumerate(z):
        np.testing.assert_allclose(R[i].numpy(), rotation_exp(zi).numpy(), rtol=0, atol=1e-14)
        np.testing.assert_allclose(dR[i].numpy(), jac(rotation_exp)(zi).numpy(), rtol=0,
                                   atol=1e-12)
        np.testing.assert_allclose(d2R[i].numpy(), jac(jac(rotation_exp))(zi).numpy(), rtol=0,
                                   atol=1e-12)
        alone = rotation_derivatives(zi[None], second=True)
        for a, b in zip(alone, (R, dR, d2R)):
            np.testing.assert_allclose(a[0].numpy(), b[i].numpy(), rtol=0, atol=1e-15)


@pytest.mark.parametrize("frame", ["quad", "tria"])
def test_frame_derivatives_match_forward_mode(frame):
    """The hand-chained frame E of the position differences w = Λ x, its gradient and Hessian
    chained to the nodal positions x (∂E/∂w Λ, Λᵀ ∂²E/∂w² Λ: the quad's three differences are
    dependent, so only their chain to x is unique), against element_frame of x (the kernel's
    own frame function) and nested forward-mode differentiation of it: warped elements in
    general position, a batch of two states, 1e-12 of the largest entry (measured 2e-14 for the
    Hessian: rounding in a different order)."""
    rng = np.random.default_rng(5)
    nn = 4 if frame == "quad" else 3
    base = (np.array([[0, 0, 0], [1, 0.1, 0.05], [1.1, 0.9, -0.1], [-0.1, 1, 0.1]])[:nn]
            @ rotation([0.2, -0.4, 1.0], 0.9).T)
    weights = torch.tensor(FRAME_DIFFERENCES[frame], dtype=torch.float64)
    Lam = torch.kron(weights, torch.eye(3, dtype=torch.float64))  # ∂w/∂x
    X = torch.as_tensor(base + 0.2 * rng.normal(size=(2, 5, nn, 3)))  # (states, elements)
    E, JE, HE = frame_derivatives(frame, weights @ X, second=True)
    E1, JE1, H1 = frame_derivatives(frame, weights @ X, second=False)
    assert torch.equal(E, E1) and torch.equal(JE, JE1) and H1 is None
    JEx, HEx = JE @ Lam, Lam.T @ HE @ Lam

    def of_x(x):
        return element_frame(frame, x.reshape(nn, 3)[None])[0]

    jac = torch.func.jacfwd
    for p in range(2):
        for e in range(5):
            x = X[p, e].reshape(-1)
            ref = (of_x(x), jac(of_x)(x), jac(jac(of_x))(x))
            for got, want in zip((E[p, e], JEx[p, e], HEx[p, e]), ref):
                assert float((got - want).abs().max()) <= 1e-12 * float(want.abs().max())


def _mp_derivatives(f, x: float):
    return [float(mpmath.diff(f, mpmath.mpf(x), n)) for n in range(3)]


def test_scalar_factors_match_high_precision():
    """a = sin φ/φ, b = (1 − cos φ)/φ² (in s = φ²) and f = φ/sin φ (in x = 1 − cos φ) with
    their first two derivatives, on both sides of their series' switches, against mpmath's at
    30 digits: 1e-12 relative (measured 3e-14 just above the switches, the closed forms'
    cancellation; 2e-16 below them)."""
    mpmath.mp.dps = 30
    a = lambda s: mpmath.sin(mpmath.sqrt(s)) / mpmath.sqrt(s)  # noqa: E731
    b = lambda s: (1 - mpmath.cos(mpmath.sqrt(s))) / s  # noqa: E731
    f = lambda x: mpmath.acos(1 - x) / mpmath.sqrt(x * (2 - x))  # noqa: E731
    s_pts = [1e-6, 0.3, 0.999 * EXP_SERIES_BELOW, 1.001 * EXP_SERIES_BELOW, 2.5, 8.0]
    x_pts = [1e-7, 0.05, 0.999 * LOG_SERIES_BELOW, 1.001 * LOG_SERIES_BELOW, 0.9, 1.8]
    got = rodrigues_factors(torch.tensor(s_pts, dtype=torch.float64))
    for k, s in enumerate(s_pts):
        want = _mp_derivatives(a, s) + _mp_derivatives(b, s)
        np.testing.assert_allclose([float(g[k]) for g in got], want, rtol=1e-12, atol=0)
    got = log_factor(torch.tensor(x_pts, dtype=torch.float64))
    for k, x in enumerate(x_pts):
        np.testing.assert_allclose([float(g[k]) for g in got], _mp_derivatives(f, x),
                                   rtol=1e-12, atol=0)
