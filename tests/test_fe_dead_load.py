"""Dead loads under large rotations (torchrom.fe.dead_load, FEModel.generalized_load).

Independent references: the spatial spin of the rotation matrix written out (Rodrigues,
tests/fe_decks.rotation) by central differences; the virtual work of the loads by central
differences of the grids' positions and rotations (a force's work is F · δx of its grid on the
turned arm, a moment's M · δω); and a Kirchhoff rod solved by its own shooting-free integration
(tests/kirchhoff_rod.py), through ``torchrom static``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.fe.dead_load import DeadLoad
from torchrom.fe.elements.corotational import spin_map

from .fe_decks import model_of, rotation
from .kirchhoff_rod import cantilever_tip
from .test_fe_rigid_arms import _free_values, _with_rbe2


def _rotation_of(theta: np.ndarray) -> np.ndarray:
    phi = float(np.linalg.norm(theta))
    return np.eye(3) if phi == 0.0 else rotation(theta, phi)


def _axial(W: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])


@pytest.mark.parametrize("phi", [0.0, 1e-3, 0.05, 0.8, 2.5])
def test_spin_map_is_the_spatial_spin_of_the_rotation_vector(phi):
    """T(θ) e_i = axial(∂R/∂θ_i Rᵀ) by central differences (h = 1e-6: error ~1e-11), through
    the series branch (|θ| < 0.1) and the closed form up to 2.5 rad."""
    rng = np.random.default_rng(7)
    axis = rng.normal(size=3)
    theta = phi * axis / np.linalg.norm(axis)
    R = _rotation_of(theta)
    h = 1e-6
    ref = np.column_stack([
        _axial((_rotation_of(theta + h * e) - _rotation_of(theta - h * e)) / (2 * h) @ R.T)
        for e in np.eye(3)])
    got = spin_map(torch.tensor(theta)).numpy()
    assert np.abs(got - ref).max() <= 1e-9, (phi, got, ref)


def _grid_positions(fe, u):
    """Positions (n_grid, 3) and rotation matrices (n_grid, 3, 3) of free-DOF state u, the RBE2
    arms turned."""
    full = fe.expand(u, large=True)
    return fe.grid_xyz + full[:, :3], np.stack([_rotation_of(t) for t in full[:, 3:]])


def test_generalized_load_does_the_virtual_work_of_dead_forces_and_moments():
    """At a large-rotation state of a model with an RBE2 arm, g(u) · δu equals the work of a
    force on the arm's dependent grid, F · δx, and of moments on two grids, M · δω (δω the
    spin, axial(δR Rᵀ)), by central differences along random δu (h = 1e-6; agreement 1e-8 of
    |F| |δu|). Tᵀ f (the linear elimination) misses it by ~10 % of the work here; at rest
    g = Tᵀ f."""
    fe = model_of(_with_rbe2(), rotations="large")
    rng = np.random.default_rng(11)
    u_grid = np.zeros((fe.mesh.n_grid, 6))
    u_grid[:, :3] = 0.05 * rng.normal(size=(fe.mesh.n_grid, 3))
    u_grid[:, 3:] = 0.6 * rng.normal(size=(fe.mesh.n_grid, 3))
    u = _free_values(fe, u_grid)
    row = fe.mesh.grid_row()
    load = fe.nodal_dead_load({(8, 1): 3.0, (8, 2): -2.0, (8, 3): 5.0, (2, 4): 1.5,
                               (2, 6): -2.5, (9, 5): 4.0})
    f = load.f_all.reshape(-1, 6)
    g = load.at(u)
    h = 1e-6
    worst = 0.0
    for _ in range(4):
        du = rng.normal(size=fe.n_dof)
        (xp, Rp), (xm, Rm) = _grid_positions(fe, u + h * du), _grid_positions(fe, u - h * du)
        _, R0 = _grid_positions(fe, u)
        work = 0.0
        for gid in (8, 2, 9):
            k = row[gid]
            work += f[k, :3] @ (xp[k] - xm[k]) / (2 * h)
            work += f[k, 3:] @ _axial((Rp[k] - Rm[k]) / (2 * h) @ R0[k].T)
        worst = max(worst, abs(g @ du - work) / (np.linalg.norm(f) * np.linalg.norm(du)))
        assert abs(load.linear @ du - work) > 1e-3 * abs(work)  # the linear elimination is off
    assert worst <= 1e-8, worst
    assert np.allclose(load.at(np.zeros(fe.n_dof)), load.linear, rtol=0, atol=1e-14)


def test_dead_loads_add_and_scale_like_vectors_and_refuse_another_model():
    fe = model_of(_with_rbe2(), rotations="large")
    a = fe.nodal_dead_load({(8, 3): 2.0})
    b = fe.nodal_dead_load({(2, 4): 1.0})
    assert np.array_equal((a + 0.5 * b).f_all, a.f_all + 0.5 * b.f_all)
    assert np.array_equal((a - b).f_all, -(b - a).f_all)
    other = model_of(_with_rbe2(), rotations="large")
    with pytest.raises(InputError, match="different FE models"):
        a + other.nodal_dead_load({(8, 3): 1.0})
    with pytest.raises(InputError, match="expected"):
        DeadLoad(fe, np.zeros(3))


#: the beam of the rod test: length 1, EI about the chord 1, GJ 0.5, EI in-plane 50
ROD_E, ROD_NU, ROD_N = 1.0e7, 0.3, 20
ROD_I1, ROD_I2, ROD_J = 1.0e-7, 5.0e-6, 1.3e-7
ROD_P, ROD_ARM = 3.0, 0.05


def _rod_deck(path):
    lines = ["SOL 400", "CEND", "SPC = 1", "NLPARM = 7", "SUBCASE 1", "  LOAD = 10",
             "BEGIN BULK"]
    lines += [f"GRID,{i + 1},,{i / ROD_N},0.0,0.0" for i in range(ROD_N + 1)]
    lines += [f"CBAR,{i + 1},1,{i + 1},{i + 2},0.0,0.0,1.0" for i in range(ROD_N)]
    lines += [f"PBAR,1,1,1.-2,{ROD_I1},{ROD_I2},{ROD_J}", f"MAT1,1,{ROD_E},,{ROD_NU}",
              f"GRID,100,,1.0,{ROD_ARM},0.0", f"RBE2,101,{ROD_N + 1},123456,100",
              f"FORCE,10,100,,{ROD_P},0.0,0.0,-1.0", "SPC1,1,123456,1", "NLPARM,7,10",
              "ENDDATA"]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_offset_tip_force_bends_and_twists_a_beam_as_the_kirchhoff_rod(tmp_path, capsys):
    """``torchrom static`` (SOL 400) on a cantilever of 20 co-rotational CBARs (EI 1 about the
    chord, GJ 0.5, EI 50 in plane, L 1) under a dead tip force of 3 on a rigid arm of 0.05 along
    the chord: the tip bends ~50° and twists 7.1° where the linear twist is 17.2°. Against the
    Kirchhoff rod (200 segments): tip position within 1e-3 of L (measured 1.5e-4) and the
    twist (asin of the chord's vertical component) within 0.5 % (measured 0.002 %). With the
    arm's moment applied to the rotation vector as the linear elimination does (the bug of
    issue 45), the twist came out 9.48°."""
    deck = _rod_deck(tmp_path / "rod.bdf")
    out = tmp_path / "rod.json"
    assert main(["static", str(deck), "--json", str(out), "--quiet"]) == 0
    capsys.readouterr()
    tip = np.array(json.loads(out.read_text())["subcases"][0]["steps"][-1]["displacements"]
                   [str(ROD_N + 1)])
    G = ROD_E / (2 * (1 + ROD_NU))
    R_rod, r_rod = cantilever_tip(1.0, (G * ROD_J, ROD_E * ROD_I1, ROD_E * ROD_I2),
                                  [0.0, 0.0, -ROD_P], [0.0, ROD_ARM, 0.0], n=200)
    R = _rotation_of(tip[3:])
    assert np.abs(tip[:3] - (r_rod - [1.0, 0.0, 0.0])).max() <= 1e-3
    twist, twist_rod = np.arcsin(-R[2, 1]), np.arcsin(-R_rod[2, 1])
    assert twist == pytest.approx(twist_rod, rel=5e-3)
    assert np.degrees(twist_rod) == pytest.approx(7.12, abs=0.01)  # the rod's own solution
