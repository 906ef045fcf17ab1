"""Validation of the FE solvers against closed-form structural mechanics.

- CQUAD4 plate-bending cantilever and in-plane (membrane) cantilever vs Euler–Bernoulli
  (+ Timoshenko shear for the in-plane case): tip deflection and bending frequencies within 2 %.
- Rod-flange / shear-web cantilever vs Euler–Bernoulli + web shear flexibility within 2 %.
- Two-bar (von Mises) truss: St Venant–Kirchhoff closed form P(w), load- and
  displacement-controlled Newton (past the limit point).
- Modes: mass normalisation, eigen-residual, sparse vs dense solvers.
- Newmark: damped single-DOF free vibration vs the exact solution; nonlinear energy balance with
  Kelvin–Voigt damping (dissipated energy = ∫ γ u̇ᵀ K_mat(u) u̇ dt).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.fe.solvers import _dense_modes

from .fe_decks import (
    flange_web_beam,
    model_of,
    new_deck,
    plate_strip,
    simply_supported_plate,
    two_bar_truss,
)

BETA = (1.8751040687, 4.6940911330)  # cantilever eigenvalues β_n L


def _tip_load(fe, x_tip, comp, total):
    """Consistent (trapezoidal) distribution of a tip force over the tip grids along their line."""
    row = fe.mesh.grid_row()
    tip = [g for g in fe.grid_ids if abs(fe.grid_xyz[row[g], 0] - x_tip) < 1e-9]
    w = np.ones(len(tip))
    w[0] = w[-1] = 0.5
    return fe.nodal_load({(g, comp): total * wi / w.sum() for g, wi in zip(tip, w)}), tip


def _bending_freqs(fe, n_modes=6):
    modes = fe.modes(n_modes)
    return [f for f, k in zip(modes.frequencies_hz, modes.kinds) if k == "bending"]


def test_cquad4_plate_cantilever_matches_euler_bernoulli():
    L, b, t, E, rho = 1.0, 0.1, 0.01, 2.0e11, 7800.0
    fe = model_of(plate_strip(20, 2, L, b, t, E, 0.0, rho))  # ν = 0: plate = beam
    EI, m = E * b * t**3 / 12, rho * b * t
    F, tip = _tip_load(fe, L, 3, 1.0)
    U = fe.expand(fe.linear_static(F))
    w = np.mean([U[fe.mesh.grid_row()[g], 2] for g in tip])
    assert w == pytest.approx(L**3 / (3 * EI), rel=0.02)
    fb = _bending_freqs(fe)
    for k in range(2):
        exact = BETA[k] ** 2 / (2 * np.pi * L**2) * np.sqrt(EI / m)
        assert fb[k] == pytest.approx(exact, rel=0.02)


def test_ctria3_plate_cantilever_matches_euler_bernoulli():
    """The same strip meshed with CTRIA3 (DKT bending, CST membrane): tip deflection and the first
    two bending modes within 2 % of Euler–Bernoulli (ν = 0: plate = beam)."""
    L, b, t, E, rho = 1.0, 0.1, 0.01, 2.0e11, 7800.0
    fe = model_of(plate_strip(20, 2, L, b, t, E, 0.0, rho, triangles=True))
    EI, m = E * b * t**3 / 12, rho * b * t
    F, tip = _tip_load(fe, L, 3, 1.0)
    U = fe.expand(fe.linear_static(F))
    w = np.mean([U[fe.mesh.grid_row()[g], 2] for g in tip])
    assert w == pytest.approx(L**3 / (3 * EI), rel=0.02)
    fb = _bending_freqs(fe)
    for k in range(2):
        exact = BETA[k] ** 2 / (2 * np.pi * L**2) * np.sqrt(EI / m)
        assert fb[k] == pytest.approx(exact, rel=0.02)


@pytest.mark.parametrize("n", [1, 2, 4])
def test_cquad4_timoshenko_cantilever_is_exact(n):
    """One row of n CQUAD4 (ν = 0: the plate is a beam), thick (t/L = 0.05), tip shear load:
    tip deflection P L³/(3 E I) + P L/(κ G A) and rotation P L²/(2 E I) exactly (rel 1e-9:
    rounding only), for any n. The residual bending flexibility L_e²/(12 E I) added to the
    constant shear's flexibility makes the element's stiffness the exact Timoshenko beam
    stiffness (MacNeal); without it one element gives 3/4 of the bending deflection."""
    L, b, t, E, rho = 1.0, 0.1, 0.05, 2.0e11, 7800.0
    fe = model_of(plate_strip(n, 1, L, b, t, E, 0.0, rho))
    EI, kGA = E * b * t**3 / 12, 5 / 6 * E / 2 * b * t
    F, tip = _tip_load(fe, L, 3, 1.0)
    U = fe.expand(fe.linear_static(F))
    row = fe.mesh.grid_row()
    w = np.mean([U[row[g], 2] for g in tip])
    theta_y = np.mean([U[row[g], 4] for g in tip])
    assert w == pytest.approx(L**3 / (3 * EI) + L / kGA, rel=1e-9)
    assert theta_y == pytest.approx(-(L**2) / (2 * EI), rel=1e-9)


def test_cquad4_simply_supported_plate_against_navier():
    """Square plate, hard simple support, t/a = 0.01, ν = 0.3, lumped mass, against Kirchhoff's
    closed forms (Navier): centre deflection under uniform pressure (the double sine series,
    odd terms to 199, converged far below the tolerances) and the first frequency
    (π/2)(2/a²)√(D/ρt). Shear deformation and rotary inertia change these by ~5e-4 at this
    t/a. Measured: 8 × 8 deflection +1.02 %, frequency −1.67 %; 16 × 16 +0.50 %, −0.55 %
    (without the residual bending flexibility: −0.46 %, −0.87 % and −0.07 %, −0.24 %: the added
    flexibility is MacNeal's beam value for the shear from a moment gradient; where the shear
    comes from a twist gradient, which a bilinear rotation field does represent, it is too
    flexible, and the error it adds falls like the element size). Tolerances: the measured
    errors rounded up (2 % and 1.5 % at 8 × 8, 0.75 % at 16 × 16), and both must fall under
    refinement."""
    a, t, E, nu, rho, q = 1.0, 0.01, 2.0e11, 0.3, 7800.0, 1.0
    D = E * t**3 / (12 * (1 - nu**2))
    odd = np.arange(1, 200, 2)
    m, k = np.meshgrid(odd, odd)
    w_navier = np.sum(16 * q * a**4 / (np.pi**6 * D) * np.sin(m * np.pi / 2) * np.sin(k * np.pi / 2)
                      / (m * k * (m**2 + k**2) ** 2))
    f_navier = np.pi / 2 * (2 / a**2) * np.sqrt(D / (rho * t))
    errors = {}
    for n, tol_w, tol_f in ((8, 1.5, 2.0), (16, 0.75, 0.75)):
        fe = model_of(simply_supported_plate(n, a, t, E, nu, rho))
        U = fe.expand(fe.linear_static(fe.pressure_load(q)))
        centre = 1 + (n // 2) * (n + 1) + n // 2
        dw = 100 * (U[fe.mesh.grid_row()[centre], 2] / w_navier - 1)
        df = 100 * (fe.modes(1).frequencies_hz[0] / f_navier - 1)
        print(f"{n} x {n}: deflection {dw:+.3f} %, frequency {df:+.3f} %")
        assert abs(dw) <= tol_w and abs(df) <= tol_f
        errors[n] = (abs(dw), abs(df))
    assert errors[16][0] < errors[8][0] and errors[16][1] < errors[8][1]


def test_cquad4_membrane_cantilever_in_plane_bending():
    """Membrane-only strip loaded in its plane: selective reduced integration removes shear
    locking; what remains is the bilinear field's Poisson stiffening (it cannot represent the
    transverse contraction −ν y of bending), −2.9 % with 2 elements across the depth, −1.1 %
    with 4 (used here), −0.6 % with 6."""
    L, b, t, E, nu = 1.0, 0.1, 0.01, 2.0e11, 0.3
    fe = model_of(plate_strip(20, 4, L, b, t, E, nu, 7800.0, bending=False))
    F, tip = _tip_load(fe, L, 2, 1.0)
    U = fe.expand(fe.linear_static(F))
    v = np.mean([U[fe.mesh.grid_row()[g], 1] for g in tip])
    G = E / (2 * (1 + nu))
    exact = L**3 / (3 * E * t * b**3 / 12) + L / (5 / 6 * G * b * t)
    assert v == pytest.approx(exact, rel=0.02)


def test_rod_and_shear_panel_cantilever():
    L, h, A, t, E, nu, rho = 10.0, 1.0, 0.01, 0.05, 7.0e10, 0.3, 2700.0
    fe = model_of(flange_web_beam(20, L, h, A, t, E, nu, rho))
    # a vertical web: its thinnest direction (y) is not the up axis of its bending (z)
    fe.set_wing_axes(up="z")
    EI = 2 * A * (h / 2) ** 2 * E
    G = E / (2 * (1 + nu))
    F = fe.nodal_load({(100 + 20, 3): 0.5, (200 + 20, 3): 0.5})
    U = fe.expand(fe.linear_static(F))
    w = 0.5 * (U[fe.mesh.grid_row()[120], 2] + U[fe.mesh.grid_row()[220], 2])
    assert w == pytest.approx(L**3 / (3 * EI) + L / (G * t * h), rel=0.02)
    m = rho * (2 * A + t * h + (A / 100) * h / (L / 20))  # flanges, web, light posts
    fb = _bending_freqs(fe, 4)
    exact = BETA[0] ** 2 / (2 * np.pi * L**2) * np.sqrt(EI / m)
    assert fb[0] == pytest.approx(exact, rel=0.02)


def _truss_force(z, h, L0, EA):
    """Vertical force at the apex of the SVK two-bar truss for apex height z: 2 EA E z / L0."""
    return EA * z * (z**2 - h**2) / L0**3


def test_two_bar_truss_load_and_displacement_control():
    a, h, EA = 1.0, 0.3, 1.0e6
    fe = model_of(two_bar_truss(a, h, EA))
    assert fe.n_dof == 1
    L0 = np.hypot(a, h)
    z_lim = h / np.sqrt(3)
    P_lim = -_truss_force(z_lim, h, L0, EA)
    # Load control below the limit point: downward load 0.6 P_lim.
    P = 0.6 * P_lim
    res = fe.static_solve(np.array([-P]), n_steps=2)
    assert res.converged
    roots = np.roots([EA / L0**3, 0.0, -EA * h**2 / L0**3, P])  # F(z) = -P
    z = max(r.real for r in roots if abs(r.imag) < 1e-12 and r.real < h + 1e-12)
    assert res.u[0] == pytest.approx(z - h, rel=1e-9)
    # Displacement control past the snap-through: reaction = closed-form force.
    for w in (0.5 * h, 1.5 * h, 2.5 * h):
        res = fe.static_solve(None, prescribed={0: -w}, n_steps=4)
        assert res.converged
        assert res.reactions[0] == pytest.approx(_truss_force(h - w, h, L0, EA), rel=1e-9)


def test_static_solve_reports_failure():
    fe = model_of(two_bar_truss(1.0, 0.3, 1.0e6))
    res = fe.static_solve(np.array([-1.0e6]), max_iter=2, max_cuts=1)  # far past the limit
    assert not res.converged and res.load_factor < 1.0 and "no convergence" in res.message


def test_nothing_applied_to_a_structure_at_rest_is_rest():
    """A zero load from rest is u = 0, converged, with no Newton iteration: the co-rotational
    shells' forces at rest are rounding, not exactly 0 (the closed-form kernel's frames), and
    with no load to measure it by Newton could not tell it — the condensation about a state
    starts its reference's Newton from p = 0 this way (it stopped the skinned Pazy's
    identification at load factor 0, residual 7.6e-14). A zero load from a deformed state is
    still solved back to rest."""
    fe = model_of(plate_strip(8, 2, 1.0, 0.1, 0.01, 2.0e11, 0.3, 7800.0))
    res = fe.static_solve(np.zeros(fe.n_dof))
    assert res.converged and res.iterations == 0 and not res.u.any()
    F, _ = _tip_load(fe, 1.0, 3, 50.0)
    bent = fe.static_solve(F)
    assert bent.converged and np.abs(bent.u).max() > 1e-3
    back = fe.static_solve(np.zeros(fe.n_dof), u0=bent.u)
    assert back.converged and np.abs(back.u).max() < 1e-9 * np.abs(bent.u).max()


def test_modes_are_mass_normalised_and_solvers_agree():
    fe = model_of(plate_strip(12, 2, 1.0, 0.2, 0.01, 7e10, 0.3, 2700.0))
    assert fe.n_dof > 200  # sparse shift-invert path
    modes = fe.modes(8)
    K, M = fe.stiffness_matrix(), fe.mass_matrix()
    Phi = modes.shapes
    np.testing.assert_allclose(Phi.T @ (M @ Phi), np.eye(8), atol=1e-10)
    resid = K @ Phi - (M @ Phi) * modes.eigenvalues
    assert np.abs(resid).max() <= 1e-8 * np.abs(K @ Phi).max()
    vals, _, _ = _dense_modes(K, M, 8)  # dense, massless rotations condensed
    np.testing.assert_allclose(vals, modes.eigenvalues, rtol=1e-9)


def _oscillator(k=4.0e4, mass=2.0):
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0], ps="123456")
    m.add_grid(2, [1.0, 0.0, 0.0], ps="23456")
    m.add_mat1(1, k, None, 0.3, rho=0.0)
    m.add_prod(1, 1, 1.0)
    m.add_crod(1, 1, [1, 2])
    m.add_conm2(2, 2, mass)
    return model_of(m)


def test_massless_dofs_without_stiffness_and_all_modes_of_a_small_model():
    """A massless rod carrying a point mass, AUTOSPC off: the grid's rotations have neither
    stiffness nor mass (a singular massless block: LinAlgError before) and its lateral
    translations neither stiffness (two rigid-body modes, counted apart). Asking for every mode
    (6 > the 3 finite ones) returns them, as Nastran does: the two rigid-body modes and the
    axial ω² = (EA/L)/m exactly, with notes."""
    k, mass = 4.0e4, 2.0
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0], ps="123456")
    m.add_grid(2, [1.0, 0.0, 0.0])
    m.add_mat1(1, k, None, 0.3, rho=0.0)
    m.add_prod(1, 1, 1.0)
    m.add_crod(1, 1, [1, 2])
    m.add_conm2(2, 2, mass)
    fe = model_of(m, autospc=False)
    assert fe.n_dof == 6
    modes = fe.modes(6)
    assert modes.n_rigid == 2 and len(modes.frequencies_hz) == 1
    np.testing.assert_allclose(modes.rigid_eigenvalues, [0.0, 0.0], atol=1e-6 * k / mass)
    np.testing.assert_allclose(modes.eigenvalues, [k / mass], rtol=1e-12)
    assert any("3 finite" in n for n in modes.notes)
    assert any("neither stiffness nor mass" in n for n in modes.notes)
    # with AUTOSPC only the axial DOF is left: asking for 10 modes gives it
    one = _oscillator(k, mass).modes(10)
    np.testing.assert_allclose(one.eigenvalues, [k / mass], rtol=1e-12)


def test_newmark_damped_free_vibration():
    k, mass, alpha = 4.0e4, 2.0, 3.0
    fe = _oscillator(k, mass)
    w = np.sqrt(k / mass)
    zeta = alpha / (2 * w)
    wd = w * np.sqrt(1 - zeta**2)
    T = 2 * np.pi / w
    u0 = 1e-4  # small: the rod's Green strain nonlinearity is negligible (1e-4 relative)
    res = fe.transient(t_end=2 * T, dt=T / 200, u0=np.array([u0]), alpha=alpha)
    t = res.t
    exact = u0 * np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2)
                                          * np.sin(wd * t))
    # Newmark's period error (ω dt)²/12 ≈ 8e-5 per radian: ~1e-3 after two periods.
    assert np.abs(res.u[:, 0] - exact).max() <= 3e-3 * u0


def test_newmark_kelvin_voigt_energy_balance():
    """Two-bar truss with an apex mass, large oscillation through the snap region: the drop of
    kinetic + strain energy equals ∫ γ u̇ᵀ K_mat(u) u̇ dt (trapezoid) to the time-step error."""
    a, h, EA, gamma = 1.0, 0.3, 1.0e6, 1e-3
    m = two_bar_truss(a, h, EA)
    m.add_conm2(10, 3, 50.0)
    fe = model_of(m)
    res = fe.transient(t_end=0.15, dt=5e-4, v0=np.array([-12.0]), gamma=gamma)
    M = fe.mass_matrix().toarray()
    W = np.array([fe.strain_energy_torch(torch.tensor(u)).item() for u in res.u])
    E = 0.5 * np.einsum("ti,ij,tj->t", res.v, M, res.v) + W
    P = np.array([gamma * v @ fe.material_force(u, v) for u, v in zip(res.u, res.v)])
    dissipated = np.concatenate(([0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(res.t))))
    assert np.ptp(res.u[:, 0]) > h  # really nonlinear: goes through the flat position
    assert E[-1] < 0.8 * E[0]  # and really damped
    assert np.abs(E[0] - E - dissipated).max() <= 2e-3 * E[0]  # measured 1.7e-4


def _free_free_pt145(pt145_deck, tmp_path):
    """pt145 with its root SPC1 and the GRID PS constraints dropped (CD kept)."""
    lines = []
    for ln in pt145_deck.read_text().splitlines():
        if ln.startswith("SPC1") or ln.replace(" ", "") == "SPC=1":
            continue
        lines.append(ln[:56] if ln.startswith("GRID") else ln)  # fields up to CD
    path = tmp_path / "pt145_free.bdf"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_free_free_pt145_rigid_body_and_elastic_modes(pt145_deck, tmp_path):
    """Free-free pt145: the bars have no in-plane bending stiffness (I2 = 0), so AUTOSPC removes
    the in-plane translation and rotation of every grid and the rigid-body modes are the four
    left (translation along and normal to the span, roll and pitch): counted, never reported as
    0 Hz elastic modes. The first elastic mode is the free-free bending mode: for a uniform
    Euler–Bernoulli beam its frequency is (4.7300/1.8751)² = 6.3627 times the clamped-free one
    (closed form; pt145's coupled bar mass is uniform, the CMASS2 are rotary inertia about the
    span and do not enter bending), to 0.5 % (10 elements; measured 0.005 %). The rigid-body
    eigenvalues come out at 5e-5 rad²/s², 2e-11 of the first elastic one."""
    from torchrom.fe import read_bdf

    free = read_bdf(_free_free_pt145(pt145_deck, tmp_path)).modes(4)
    clamped = read_bdf(pt145_deck).modes(1)
    assert free.n_rigid == 4 and clamped.n_rigid == 0
    assert np.all(np.abs(free.rigid_eigenvalues) < 1e-8 * free.eigenvalues[0])
    assert len(free.frequencies_hz) == 4 and free.frequencies_hz[0] > 100.0
    ratio = free.frequencies_hz[0] / clamped.frequencies_hz[0]
    assert abs(ratio / (4.7300 / 1.8751) ** 2 - 1) < 5e-3, ratio
    records = free.records()
    assert [r["kind"] for r in records[:4]] == ["rigid-body"] * 4
    assert records[4]["mode"] == 5 and records[4]["kind"] == "bending"


def test_rigid_body_modes_from_the_geometry(pt145_deck, tmp_path):
    """Free-free pt145's four rigid-body modes built from the grids' rigid motions
    (:func:`torchrom.fe.rigid.rigid_body_modes`): mass-orthonormal (GᵀMG = I to 1e-12: an
    eigen-decomposition of a 4 x 4 matrix), strain-free (GᵀKG ≤ 1e-10 of the first elastic ω²:
    exact rigid motions carry round-off energy only; the eigensolver's rigid modes have
    ω² = 7.7e-5, 1e-11 of it), expanded to the grids they are exact rigid motions (each grid's
    translation is t + θ × x with one (t, θ) for the whole model, to 1e-12), and they span the
    eigensolver's rigid modes (M-projection residual ≤ 1e-6). The elastic modes are
    M-orthogonal to them (1e-10)."""
    from torchrom.fe import read_bdf
    from torchrom.fe.rigid import rigid_body_modes

    fe = read_bdf(_free_free_pt145(pt145_deck, tmp_path))
    modes = fe.modes(4)
    G, how = rigid_body_modes(fe, modes)
    assert G.shape[1] == 4 and how.startswith("rigid motions")
    M, K = fe.mass_matrix(), fe.stiffness_matrix()
    assert np.abs(G.T @ (M @ G) - np.eye(4)).max() <= 1e-12
    assert np.abs(G.T @ (K @ G)).max() <= 1e-10 * modes.eigenvalues[0]
    u = fe.expand(G)  # (4, n_grid, 6) in basic axes
    x = fe.grid_xyz
    for ui in u:
        t, th = ui[0, :3] - np.cross(ui[0, 3:], x[0]), ui[0, 3:]
        assert np.abs(ui[:, 3:] - th).max() <= 1e-12 * np.abs(ui).max()
        assert np.abs(ui[:, :3] - (t + np.cross(th, x))).max() <= 1e-12 * np.abs(ui).max() * (
            1 + np.abs(x).max())
    rest = modes.rigid_shapes - G @ (G.T @ (M @ modes.rigid_shapes))
    assert np.sqrt(np.einsum("ik,ik->k", rest, M @ rest)).max() <= 1e-6
    assert np.abs(G.T @ (M @ modes.shapes)).max() <= 1e-10


def test_free_free_flutter_keeps_the_rigid_body_modes(pt145_deck, tmp_path, capsys):
    """``torchrom flutter`` on free-free pt145 (KE; LMODES raised to 7: the EIGR's 6 roots are
    4 rigid + 2 elastic, counted as Nastran counts them, and the 7th is a residual vector, as
    Nastran's default RESVEC gives): runs, lists the rigid-body modes at exactly 0 Hz and says
    so in a note; KE has no root for them (velocity 0, damping undefined, never a crossing).
    The free-free flutter of an aircraft by PK is checked against Nastran's f06 on bah_plane
    (tests/test_public_decks.py)."""
    from torchrom.aero.nastran_flutter import run_deck
    from torchrom.cli import main

    path = _free_free_pt145(pt145_deck, tmp_path)
    path.write_text(path.read_text().replace("PARAM   LMODES  3", "PARAM   LMODES  7"))
    res = run_deck(path, log=lambda *_: None)
    assert np.array_equal(res.frequencies_hz[:4], np.zeros(4)) and len(res.frequencies_hz) == 7
    assert res.frequencies_hz[4] > 100.0 and res.frequencies_hz[6] > res.frequencies_hz[5]
    assert any("residual vectors" in n and "1 used" in n for n in res.notes)
    sw = res.results[0].sweep
    assert np.all(sw.velocity[:, :4] == 0.0) and np.all(np.isnan(sw.damping[:, :4]))
    assert all(p.mode >= 4 for r in res.results for p in r.points)
    assert any("4 rigid-body mode(s) kept" in n for n in res.notes)
    rc = main(["flutter", str(path)])
    out = capsys.readouterr().out
    assert rc == 0 and "modal frequencies (Hz): 0  0  0  0  254" in out


def test_point_mass_on_a_massless_plate():
    """Density 0 and one point mass at the tip of a clamped plate strip (300 DOFs: the sparse
    solver): the mass matrix has rank 3, so there are exactly three modes — the tip mass on the
    plate's tip flexibility. Lanczos returns pseudo-pairs here (relative residual ≈ 1); they are
    detected and the dense solver condenses the massless DOFs. Independent check: ω² are the
    eigenvalues of (m F)⁻¹, F the 3 x 3 tip flexibility from three static solves (to 1e-8:
    both are exact linear algebra on the same K). A fourth mode does not exist: asking for it
    returns the three with a note (as Nastran does)."""
    from torchrom.fe.solvers import solve_linear

    from .fe_decks import model_of, plate_strip

    deck = plate_strip(10, 4, 1.0, 0.2, 0.01, 7e10, 0.3, rho=0.0)
    mass = 2.0
    deck.add_conm2(999, 55, mass)
    fe = model_of(deck)
    assert fe.n_dof > 200
    modes = fe.modes(3)
    assert modes.n_rigid == 0
    K = fe.stiffness_matrix()
    dofs = [fe.dof_index(55, c) for c in (1, 2, 3)]
    F = np.zeros((3, 3))
    for j, d in enumerate(dofs):
        e = np.zeros(fe.n_dof)
        e[d] = 1.0
        F[:, j] = solve_linear(K, e)[dofs]
    expected = np.sort(1.0 / np.linalg.eigvalsh(mass * F))
    np.testing.assert_allclose(modes.eigenvalues, expected, rtol=1e-8)
    more = fe.modes(4)
    np.testing.assert_allclose(more.eigenvalues, expected, rtol=1e-8)
    assert any("3 finite" in note for note in more.notes)


@pytest.mark.parametrize("deck", ["pynastran_ha144d/ha144da.bdf", "ekm_bar_beam/test_case.bdf",
                                  "ekm_swept_plane/sol103_swept_plane.bdf"])
def test_rigid_body_modes_span_nastrans_suport_shapes(deck):
    """The three public decks with SUPORT (free-free; Nastran ran them, so their r-sets are
    statically determinate): the rigid-body modes built from the geometry span the shapes
    Nastran computes from the r-set, Ψ = [-K_ll⁻¹ K_lr; I] (MSC Dynamic Analysis User's Guide,
    rigid-body modes from SUPORT), a second method on the same K (M-projection residual of Ψ
    on them ≤ 1e-8 of Ψ's size: linear algebra to round-off), and the flutter note says so."""
    from pathlib import Path

    from torchrom.fe import read_bdf
    from torchrom.fe.rigid import rigid_body_modes, suport_dofs, suport_note

    fe = read_bdf(Path(__file__).parent / "decks" / deck)
    modes = fe.modes(3)
    G, how = rigid_body_modes(fe, modes)
    dofs = suport_dofs(fe)
    assert how.startswith("rigid motions") and G.shape[1] == modes.n_rigid == len(dofs)
    r = np.array([fe.dof_index(g, c) for g, c in dofs])
    ll = np.setdiff1d(np.arange(fe.n_dof), r)
    K = fe.stiffness_matrix().toarray()
    M = fe.mass_matrix()
    psi = np.zeros((fe.n_dof, len(r)))
    psi[r] = np.eye(len(r))
    psi[ll] = -np.linalg.solve(K[np.ix_(ll, ll)], K[np.ix_(ll, r)])
    rest = psi - G @ (G.T @ (M @ psi))
    size = np.sqrt(np.einsum("ik,ik->k", psi, M @ psi))
    assert np.all(np.sqrt(np.einsum("ik,ik->k", rest, M @ rest)) <= 1e-8 * size)
    assert "statically determinate" in suport_note(fe, G)


@pytest.mark.parametrize("deck, n, nastran_hz", [
    # pt145 (clamped): the f06's augmented table has 1394.46, 1711.82, 3112.26 Hz
    ("pynastran_pt145/pt145.bdf", 6, 1711.823),
    # bah_plane (free-free, 2 rigid-body modes): 41.229, 56.557, 120.58, 180.32 Hz
    ("pynastran_bah_plane/bah_plane.bdf", 6, 56.55734),
])
def test_inertia_residual_vectors(deck, n, nastran_hz):
    """Residual vectors (RESVEC, inertia relief): the defining property, by a second route —
    the static response to each of the six inertia loads M D (relieved of its rigid-body part
    on a free-free structure, and taken orthogonal to the rigid-body modes) lies in the span of
    the modes and the residual vectors (M-projection residual relative to the largest response:
    measured 1.3e-6 on pt145, whose stiff bars make K ill-conditioned, 1e-12 on bah_plane;
    asserted 1e-5: round-off of two different linear solves of K); the vectors are
    mass-normalised, M- and K-orthogonal to the modes (1e-9, relative to ω² for K). Against
    the f06's augmented table one frequency is Nastran's (1e-5); the others are not (pt145
    1388.97, 2916.46 vs 1394.46, 3112.26; bah_plane 39.02, 119.31, 179.08 vs 41.229, 120.58,
    180.32): Nastran's load set differs, see torchrom.fe.resvec."""
    from pathlib import Path

    from torchrom.fe import read_bdf
    from torchrom.fe.resvec import inertia_residual_vectors
    from torchrom.fe.rigid import orthogonalise_against, rigid_body_modes, rigid_motions_on_free

    fe = read_bdf(Path(__file__).parent / "decks" / deck)
    modes = fe.modes(n)
    M, K = fe.mass_matrix(), fe.stiffness_matrix().toarray()
    rigid = rigid_body_modes(fe, modes)[0] if modes.n_rigid else np.zeros((fe.n_dof, 0))
    basis = np.concatenate([rigid, orthogonalise_against(modes.shapes, rigid, M)], axis=1)
    fr, U = inertia_residual_vectors(fe, basis, rigid)
    assert np.min(np.abs(fr / nastran_hz - 1)) <= 1e-5, fr
    assert np.abs(U.T @ (M @ U) - np.eye(len(fr))).max() <= 1e-9
    assert np.abs(basis.T @ (M @ U)).max() <= 1e-9
    assert np.abs(basis.T @ K @ U).max() <= 1e-9 * (2 * np.pi * fr.max()) ** 2
    X, _, _ = rigid_motions_on_free(fe.T, fe.grid_xyz)
    F = M @ X
    F = F - M @ (rigid @ (rigid.T @ F))
    if rigid.shape[1]:  # solve on the elastic subspace: K u = F, u ⟂ rigid (least squares)
        u = np.linalg.lstsq(K, F, rcond=None)[0]
        u = u - rigid @ (rigid.T @ (M @ u))
    else:
        u = np.linalg.solve(K, F)
    B = np.concatenate([basis, U], axis=1)
    rest = u - B @ (B.T @ (M @ u))
    size = np.sqrt(np.einsum("ik,ik->k", u, M @ u))
    # (a rigid-body direction's relieved load is zero: sizes are relative to the largest)
    assert np.all(np.sqrt(np.einsum("ik,ik->k", rest, M @ rest)) <= 1e-5 * size.max())


def test_rigid_body_modes_fall_back_on_a_mechanism():
    """A zero-energy mode that is not a rigid motion of the grids (a mechanism: here grid 3's
    vertical DOF has mass and no stiffness, grids 1-2 are a z-spring pair): the geometric
    shapes (the common z translation) do not span it, so the eigensolver's zero-frequency shapes
    are used, M-orthonormal (1e-12), and the reason is given."""
    from types import SimpleNamespace

    import scipy.sparse as sp

    from torchrom.fe.rigid import rigid_body_modes
    from torchrom.fe.solvers import Modes

    xyz = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    T = sp.lil_matrix((18, 3))
    for i in range(3):
        T[6 * i + 2, i] = 1.0  # the free DOFs: z of each grid
    K = sp.csr_matrix(np.array([[1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]))
    M = sp.csr_matrix(np.diag([1.0, 2.0, 3.0]))
    fe = SimpleNamespace(T=sp.csr_matrix(T), grid_xyz=xyz, mass_matrix=lambda: M,
                         stiffness_matrix=lambda: K)
    # the two zero-energy modes: z translation of grids 1-2, and grid 3 alone
    shapes = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    modes = Modes(np.zeros(0), np.zeros((3, 0)), [], np.zeros(0), rigid_eigenvalues=np.zeros(2),
                  rigid_shapes=shapes)
    G, how = rigid_body_modes(fe, modes)
    assert "not rigid motions" in how and G.shape == (3, 2)
    assert np.abs(G.T @ (M @ G) - np.eye(2)).max() <= 1e-12


def test_solve_symmetric_matches_dense_and_falls_back_on_zero_pivots():
    """solve_symmetric (SuperLU's symmetric mode, diagonal pivots) equals the dense solve on a
    symmetric positive definite matrix (1e-10) and on a symmetric indefinite one with zero
    diagonal entries, where diagonal pivoting fails and the general factorisation takes over."""
    import scipy.sparse as sp

    from torchrom.fe.solvers import solve_symmetric

    rng = np.random.default_rng(3)
    B = sp.random(40, 40, density=0.1, random_state=4)
    spd = (B @ B.T + 40 * sp.eye(40)).tocsc()
    r = rng.standard_normal((40, 2))
    np.testing.assert_allclose(solve_symmetric(spd, r), np.linalg.solve(spd.toarray(), r),
                               rtol=0, atol=1e-10 * np.abs(np.linalg.solve(spd.toarray(), r)).max())
    swap = sp.csc_matrix(np.kron(np.eye(20), [[0.0, 1.0], [1.0, 0.0]]))  # zero diagonal
    np.testing.assert_allclose(solve_symmetric(swap, r), np.linalg.solve(swap.toarray(), r),
                               rtol=0, atol=1e-12)


def _free_free_beam(n: int, L: float):
    """Uniform CBAR beam along x, free at both ends, bending in x-z only (components 1, 2, 4, 6
    constrained): two rigid-body modes, plunge and pitch."""
    m = new_deck()
    for i in range(n + 1):
        m.add_grid(i + 1, [L * i / n, 0.0, 0.0])
    m.add_mat1(1, 7.0e10, 2.7e10, None, rho=2700.0)
    m.add_pbar(1, 1, A=1e-3, i1=2e-6, i2=8e-6, j=4e-6)
    for i in range(n):
        m.add_cbar(i + 1, 1, [i + 1, i + 2], [0.0, 0.0, 1.0], None)
    m.add_spc1(1, "1246", list(range(1, n + 2)))
    # small rotations: the hand solution is linear, and so is the nonlinear solve checked below
    return model_of(m, "free_free_beam", rotations="small")


def test_inertia_relief_of_a_free_free_beam_under_a_tip_force():
    """Inertia relief (INREL) of a free-free uniform beam under a tip force P against the hand
    solution: the rigid-body accelerations a = P/(mL) and α = 6P/(mL²) give the inertia load
    q(x) = −(P/L)(6x/L − 2), so EI w'' = (P/L)(x² − x³/L) (M = 0 at both ends), w fixed by
    ∫ m w dx = 0 and ∫ m w (x − L/2) dx = 0 (M-orthogonal to plunge and pitch). Measured 0.70,
    0.18, 0.044 % at 20, 40, 80 elements (second order: the FE mass matrix's load
    distribution); tolerance 0.3 % at 40. The nonlinear solve (a linear CBAR model here) agrees
    with the linear one to 1e-9, and the response is M-orthogonal to the rigid-body modes."""
    from numpy.polynomial import Polynomial

    from torchrom.fe.rigid import rigid_body_modes
    from torchrom.fe.solvers import inertia_relief_solve, inertia_relief_static

    n, L, P, EI = 40, 2.0, 100.0, 7.0e10 * 2e-6
    fe = _free_free_beam(n, L)
    modes = fe.modes(2)
    assert modes.n_rigid == 2
    G, _ = rigid_body_modes(fe, modes)
    M, K = fe.mass_matrix(), fe.stiffness_matrix()
    f = fe.nodal_load({(n + 1, 3): P})
    u = inertia_relief_solve(K, M, G, f)
    x = np.asarray(fe.grid_xyz)[:, 0]
    w = np.array([u[fe.dof_index(g, 3)] for g in range(1, n + 2)])
    w0 = (Polynomial([0.0, 0.0, P / L, -P / L**2]) / EI).integ(2)
    xm = Polynomial([-L / 2, 1.0])
    moments = [(w0 * p).integ() for p in (Polynomial([1.0]), xm)]
    rhs = [-(mo(L) - mo(0.0)) for mo in moments]
    A = [[L, L**2 / 2], [0.0, L**3 / 12]]  # ∫ (c0 + c1 x) {1, x − L/2} dx
    wh = w0 + Polynomial(np.linalg.solve(A, rhs))
    assert np.abs(w - wh(x)).max() <= 3e-3 * np.abs(wh(x)).max()
    assert np.abs(G.T @ (M @ u)).max() <= 1e-12 * np.abs(u).max()
    with pytest.warns(UserWarning):  # CBAR: linear elements in a nonlinear solve
        res = inertia_relief_static(fe, f, G, tol=1e-10)
    assert res.converged
    assert np.abs(res.u - u).max() <= 1e-9 * np.abs(u).max()


def test_nonlinear_inertia_relief_of_a_free_plate():
    """inertia_relief_static on a free CQUAD4 strip (six rigid-body modes, total Lagrangian)
    under a tip force large enough to stiffen it (deflection spread 8.3 % of the length, 8.9 %
    linear): the response is M-orthogonal to the rigid-body modes (measured 1.5e-18; bound
    1e-12 relative) and the internal force balances the load up to inertia loads M G a only
    (the part of f(u) − F outside span(M G): measured 1.6e-11 of ‖F‖, bound 1e-8, the Newton
    tolerance 1e-9 of max(‖F‖, ‖f‖) plus rounding); the nonlinear response differs from the
    linear INREL one by 7 % (bound: more than 1 %, so the test sees the nonlinear path)."""
    from torchrom.fe.rigid import rigid_body_modes
    from torchrom.fe.solvers import inertia_relief_solve, inertia_relief_static

    m = plate_strip(8, 2, 1.0, 0.2, 0.002, 7e10, 0.3, 2700.0)
    m.spcs.clear()
    fe = model_of(m, "free_plate")
    modes = fe.modes(1)
    G, _ = rigid_body_modes(fe, modes)
    assert G.shape[1] == 6
    M = fe.mass_matrix()
    F, _ = _tip_load(fe, 1.0, 3, 60.0)
    res = inertia_relief_static(fe, F, G, tol=1e-9)
    assert res.converged
    u = res.u
    assert np.abs(G.T @ (M @ u)).max() <= 1e-12 * np.abs(u).max() * np.abs(M @ G).max()
    r = fe.internal_force(u) - F
    MG = np.asarray(M @ G)
    outside = r - MG @ np.linalg.lstsq(MG, r, rcond=None)[0]
    assert np.linalg.norm(outside) <= 1e-8 * np.linalg.norm(F)
    lin = inertia_relief_solve(fe.stiffness_matrix(), M, G, F)
    assert np.abs(u - lin).max() > 0.01 * np.abs(lin).max()

def test_inertia_relief_recovers_from_a_bad_guess_and_gives_up_in_bounded_work():
    """inertia_relief_static given a guess ``u0`` from which Newton diverges (the linear INREL
    response reversed and 30x too large, as a continuation's scaled previous solution can be)
    steps the load from the unloaded state instead of cutting steps around the bad guess (the
    BAH aircraft's dual-mode walk spent minutes there), and reaches the solution without a
    guess to 1e-8 (both converge to 1e-9 of the load). A solve that cannot converge
    (max_iter 1: never) gives up after max_cuts cuts, each tried once: at most
    (max_cuts + 2) x max_iter Newton iterations, with the load factor reached and why."""
    from torchrom.fe.rigid import rigid_body_modes
    from torchrom.fe.solvers import inertia_relief_solve, inertia_relief_static

    m = plate_strip(8, 2, 1.0, 0.2, 0.002, 7e10, 0.3, 2700.0)
    m.spcs.clear()
    fe = model_of(m, "free_plate")
    G, _ = rigid_body_modes(fe, fe.modes(1))
    F, _ = _tip_load(fe, 1.0, 3, 60.0)
    ref = inertia_relief_static(fe, F, G, tol=1e-9)
    bad = -30.0 * inertia_relief_solve(fe.stiffness_matrix(), fe.mass_matrix(), G, F)
    res = inertia_relief_static(fe, F, G, u0=bad, tol=1e-9)
    assert ref.converged and res.converged
    assert np.abs(res.u - ref.u).max() <= 1e-8 * np.abs(ref.u).max()
    stuck = inertia_relief_static(fe, F, G, u0=bad, tol=1e-9, max_iter=1, max_cuts=5)
    assert not stuck.converged and stuck.load_factor == 0.0
    assert stuck.iterations <= (5 + 2) * 1
    assert "no convergence after 5 step cuts at load factor 0" in stuck.message


def test_modified_newton_reaches_newtons_solution():
    """modified_newton (one reused factorisation, refactorised when the residual falls by less
    than half) reaches the full-Newton solution of a co-rotational cantilever bent to about
    40° (the elastica test's model, tip force P L²/EI = 1), to 1e-8 of the load (above the
    residual's rounding floor, 1e-9), to 1e-6 of the tip deflection, with
    fewer factorisations than residual evaluations; it says so when it cannot converge."""
    from torchrom.errors import ConvergenceError
    from torchrom.fe.solvers import modified_newton, static_solve

    from .test_fe_corotational import E_BEAM, I_BEAM, L_BEAM, _cantilever

    fe = _cantilever(8)
    F = fe.nodal_load({(9, 3): E_BEAM * I_BEAM / L_BEAM**2})
    ref = static_solve(fe, F, n_steps=4, tol=1e-10, raise_on_failure=True).u
    half = static_solve(fe, 0.5 * F, n_steps=2, tol=1e-10, raise_on_failure=True).u
    u, n_res, n_tan, factor = modified_newton(fe, F, half, tol=1e-8)  # rounding floor 1e-9
    k = fe.dof_index(9, 3)
    assert abs(u[k] - ref[k]) <= 1e-6 * abs(ref[k])
    assert factor is not None and 1 <= n_tan < n_res
    with pytest.raises(ConvergenceError):
        modified_newton(fe, F, np.zeros(fe.n_dof), tol=1e-10, max_iter=2)


def test_modified_newton_takes_back_a_stale_factorisations_step():
    """A factorisation from a far state (the tangent of the same cantilever bent the other
    way, P L²/EI = −1) and a start scaled from half the load (u(P/2) · 2, not an
    equilibrium): a step that raises the residual is taken back and replaced by a Newton step,
    and the solution is full Newton's to 1e-6 of the tip deflection; the work criterion
    (static_solve's WORK_TOL) stops it at the residual's rounding floor, here asked for
    below it (tol 1e-14)."""
    from torchrom.fe.solvers import WORK_TOL, factor_symmetric, modified_newton, static_solve

    from .test_fe_corotational import E_BEAM, I_BEAM, L_BEAM, _cantilever

    fe = _cantilever(8)
    F = fe.nodal_load({(9, 3): E_BEAM * I_BEAM / L_BEAM**2})
    ref = static_solve(fe, F, n_steps=4, tol=1e-10, raise_on_failure=True).u
    half = static_solve(fe, 0.5 * F, n_steps=2, tol=1e-10, raise_on_failure=True).u
    away = static_solve(fe, -F, n_steps=4, tol=1e-10, raise_on_failure=True).u
    stale = factor_symmetric(fe.tangent_stiffness(away))
    u, n_res, n_tan, _ = modified_newton(fe, F, 2.0 * half, tol=1e-14, factor=stale,
                                         work_tol=WORK_TOL, max_iter=40)
    k = fe.dof_index(9, 3)
    assert abs(u[k] - ref[k]) <= 1e-6 * abs(ref[k])
    assert 1 <= n_tan < n_res


def test_modified_newton_refactorises_wherever_the_residual_exceeds_the_load():
    """newton_above=1 (the identification's NEWTON_ABOVE): at every iterate whose residual is
    above ‖F‖ a tangent is taken there before the step, and the solution is the same (to 1e-6
    of the tip deflection, as above). Without it, the same far start (the scaled half-load
    solution, 6e4 ‖F‖ here) with a stale factorisation first takes the stale step (a NaN
    residual here), which the take-back rule then undoes: one residual evaluation more."""
    from torchrom.fe.solvers import (
        NEWTON_ABOVE,
        WORK_TOL,
        factor_symmetric,
        modified_newton,
        static_solve,
    )

    from .test_fe_corotational import E_BEAM, I_BEAM, L_BEAM, _cantilever

    fe = _cantilever(8)
    F = fe.nodal_load({(9, 3): E_BEAM * I_BEAM / L_BEAM**2})
    ref = static_solve(fe, F, n_steps=4, tol=1e-10, raise_on_failure=True).u
    half = static_solve(fe, 0.5 * F, n_steps=2, tol=1e-10, raise_on_failure=True).u
    away = static_solve(fe, -F, n_steps=4, tol=1e-10, raise_on_failure=True).u

    class Recorder:
        """The cantilever, logging each residual norm and each tangent's state."""

        n_dof = fe.n_dof

        def __init__(self):
            self.events = []

        def internal_force(self, u):
            f = fe.internal_force(u)
            self.events.append(("residual", float(np.linalg.norm(f - F)), u.copy()))
            return f

        def tangent_stiffness(self, u):
            self.events.append(("tangent", None, u.copy()))
            return fe.tangent_stiffness(u)

    runs = {}
    for rule in (None, NEWTON_ABOVE):
        rec = Recorder()
        u, n_res, _, _ = modified_newton(rec, F, 2.0 * half, tol=1e-14, work_tol=WORK_TOL,
                                         factor=factor_symmetric(fe.tangent_stiffness(away)),
                                         max_iter=40, newton_above=rule)
        k = fe.dof_index(9, 3)
        assert abs(u[k] - ref[k]) <= 1e-6 * abs(ref[k])
        runs[rule] = rec.events, n_res
    events, n_res = runs[NEWTON_ABOVE]
    norm_F = np.linalg.norm(F)
    assert events[0][1] > 1e4 * norm_F  # the start is far
    far = [i for i, (kind, res, _) in enumerate(events[:-1])
           if kind == "residual" and res > norm_F]
    assert far
    for i in far:
        kind, _, u = events[i + 1]
        assert kind == "tangent" and np.array_equal(u, events[i][2]), i
    stale_events, stale_res = runs[None]
    assert stale_events[1][0] == "residual"  # the stale factorisation's step first
    assert n_res == stale_res - 1
