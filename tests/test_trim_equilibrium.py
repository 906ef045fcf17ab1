"""Static aeroelastic equilibrium (torchrom.trim: operators, equilibrium, cards) and
``torchrom static --aoa/--velocity`` or a SOL 144 deck.

Independent references:
- a rigid wing on a torsion spring (the typical section's static aeroelasticity, e.g.
  Bisplinghoff, Ashley & Halfman, Sec. 8-1; Hodges & Pierce Sec. 4.1): the spring of stiffness
  k at x_ea, the lift q S C_Lα (α + θ) at the aerodynamic centre x_ac, so
  θ = q S C_Lα e α / (k − q S C_Lα e) with e = x_ea − x_ac, and the divergence
  q_D = k / (S C_Lα e). C_Lα and x_ac are those of the independent horseshoe lattice of
  tests/test_aero_dlm.py (the same boxes), so the test checks the splines, signs, coupling and
  solver, not the lattice;
- a dense direct solve of (K + q Tₛᵀ Q Tₛ) u = b for the low-rank (Woodbury) solver;
- MSC Nastran SOL 144 on the AePW-3 Pazy wing, with and without skin (Riso & Cesnik,
  J. Aircraft 2023; tests/decks/.../SOURCE.md): the tip deflection at 5°, 50 m/s;
- Nastran SOL 400 under the steady loads (the same source), for the nonlinear equilibrium.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from torchrom.aero.nastran_flutter import load_deck
from torchrom.cli import main
from torchrom.fe import read_bdf
from torchrom.fe.solvers import factor_symmetric
from torchrom.trim.equilibrium import LinearSolver, linear_sweep, nonlinear_sweep
from torchrom.trim.operators import steady_operator

from .test_aero_dlm import _horseshoe_circulation

DECKS = __import__("pathlib").Path(__file__).parent / "decks"
PAZY_SKIN = DECKS / "aepw3_pazy_skin_flutter_tipmass1" / "sol145.dat"
PAZY_NOSKIN = DECKS / "aepw3_pazy_noskin_rigidtip" / "sol144_noskin.dat"
PAZY_TIP, PAZY_SEMISPAN = 80000016, 0.55

#: the rigid wing: chord 1, semispan 4 (mirrored: aspect ratio 8), spring axis at 40 % chord
CHORD, SEMISPAN, X_EA, K_SPRING, RHO = 1.0, 4.0, 0.4, 400.0, 1.225
N_CHORD, N_SPAN = 4, 8


def _rigid_wing_deck(path, trim: str = "") -> object:
    """A rigid rectangular wing (an RBE2 from the spring grid 1 to four corner grids, SPLINE1
    on them) pitching on a CELAS2 of ``K_SPRING`` about x = ``X_EA``."""
    head = ["SOL 144" if trim else "SOL 101", "CEND", "SPC = 1"]
    if trim:
        head += ["TRIM = 7"]
    lines = head + ["BEGIN BULK",
                    f"GRID,1,,{X_EA},{SEMISPAN / 2},0.0",
                    "GRID,11,,0.0,0.0,0.0", f"GRID,12,,{CHORD},0.0,0.0",
                    f"GRID,13,,{CHORD},{SEMISPAN},0.0", f"GRID,14,,0.0,{SEMISPAN},0.0",
                    "RBE2,20,1,123456,11,12,13,14",
                    f"CELAS2,30,{K_SPRING},1,5",
                    "SPC1,1,12346,1",
                    f"AERO,,1.0,{CHORD},{RHO},1",
                    "PAERO1,100",
                    f"CAERO1,1000,100,,{N_SPAN},{N_CHORD},,,1",
                    f",0.0,0.0,0.0,{CHORD},0.0,{SEMISPAN},0.0,{CHORD}",
                    f"SPLINE1,2000,1000,1000,{1000 + N_SPAN * N_CHORD - 1},2001",
                    "SET1,2001,11,12,13,14", trim, "ENDDATA"]
    path.write_text("\n".join(x for x in lines if x) + "\n")
    return path


def _horseshoe_lift_and_centre():
    """(C_Lα, x_ac) of the deck's planform from the independent horseshoe lattice."""
    from torchrom.aero.panels import rectangular_wing

    wing = rectangular_wing(CHORD, SEMISPAN, N_CHORD, N_SPAN)
    gamma, a, b = _horseshoe_circulation(wing)
    lift = 2 * gamma * np.linalg.norm(b - a, axis=1)
    x = 0.5 * (a[:, 0] + b[:, 0])  # the bound vortex on each box's quarter chord
    return lift.sum() / wing.areas.sum(), float((lift * x).sum() / lift.sum())


@pytest.fixture(scope="module")
def rigid_wing(tmp_path_factory):
    path = _rigid_wing_deck(tmp_path_factory.mktemp("rigid") / "wing.bdf")
    fe = read_bdf(path)
    return fe, steady_operator(fe, load_deck(path, require_flutter=False), mach=0.0)


def test_rigid_wing_on_a_torsion_spring_twists_and_diverges_as_the_typical_section(rigid_wing):
    """θ(q) at three dynamic pressures below divergence and q_D itself against the closed form
    with the horseshoe lattice's C_Lα (4.750) and x_ac (0.2433 c) (module docstring).
    Tolerance 1e-8 relative: the same lattice solved two ways (measured ≤ 8e-12)."""
    fe, op = rigid_wing
    cla, x_ac = _horseshoe_lift_and_centre()
    S, e = CHORD * SEMISPAN, X_EA - x_ac
    assert 0.2 < x_ac < 0.3 and e > 0  # the lift ahead of the spring: it can diverge
    q_div = K_SPRING / (S * cla * e)
    alpha = math.radians(2.0)
    solver = LinearSolver(factor_symmetric(fe.stiffness_matrix()), op)
    assert solver.divergence_pressure() == pytest.approx(q_div, rel=1e-8)
    for frac in (0.2, 0.5, 0.9):
        q = frac * q_div
        V = math.sqrt(2 * q / RHO)
        (eq,) = linear_sweep(fe, op, [V], RHO, alpha)
        theta = fe.expand(eq.u)[fe.mesh.grid_row()[1], 4]
        want = q * S * cla * e * alpha / (K_SPRING - q * S * cla * e)
        assert theta == pytest.approx(want, rel=1e-8), frac
    (past,) = linear_sweep(fe, op, [math.sqrt(2 * q_div / RHO)], RHO, alpha)
    assert not past.converged and "divergence" in past.message


def test_low_rank_solution_satisfies_the_assembled_equations():
    """(K + q Tₛᵀ Q_ss Tₛ) u = b on the Pazy deck without skin (16,764 DOFs, 96 spline DOFs):
    the Woodbury solve's residual with the assembled sparse K and the operator applied
    explicitly, ‖K u + q Tₛᵀ Q_ss Tₛ u − b‖ within 10× the rounding floor of a plain solve
    K⁻¹ b of the same b on this ill-conditioned model (1.0e-8 ‖b‖; measured 1.4e-8)."""
    fe = read_bdf(PAZY_NOSKIN)
    op = steady_operator(fe, load_deck(PAZY_NOSKIN, require_flutter=False))
    K = fe.stiffness_matrix()
    solver = LinearSolver(factor_symmetric(K), op)
    b = op.incidence_load(1500.0, 0.05)
    u = solver.solve(1500.0, b)
    r = K @ u - op.stiffness_load(1500.0, u) - b
    floor = np.linalg.norm(K @ solver.factor.solve(b) - b)
    assert np.linalg.norm(r) <= 10 * floor


def _pazy_tip_pct(fe, u, large=False):
    return 100.0 * fe.expand(u, large=large)[fe.mesh.grid_row()[PAZY_TIP], 2] / PAZY_SEMISPAN


@pytest.mark.parametrize("deck, nastran", [(PAZY_SKIN, 34.0195), (PAZY_NOSKIN, 36.4274)])
def test_pazy_linear_static_aeroelastic_matches_sol144(deck, nastran):
    """5°, 50 m/s, 1.225 kg/m³, no gravity: the reference axis's tip deflection (grid
    80000016, % of the 0.55 m semispan) against MSC Nastran SOL 144 (with skin 34.02 %,
    without 36.43 %), within the issue's 1.5 % (measured 34.018, −0.005 %; 36.385, −0.12 %)."""
    fe = read_bdf(deck)
    op = steady_operator(fe, load_deck(deck, require_flutter=False), mach=0.0)
    (eq,) = linear_sweep(fe, op, [50.0], 1.225, math.radians(5.0))
    assert _pazy_tip_pct(fe, eq.u) == pytest.approx(nastran, rel=0.015)


def test_nonlinear_equilibrium_at_a_small_incidence_is_the_linear_one(rigid_wing):
    """At 0.01° the geometric nonlinearity is of the order of the rotation (1e-4): the
    nonlinear equilibrium equals the linear one to 1e-4 relative, at half the divergence q."""
    fe, op = rigid_wing
    q = 0.5 * K_SPRING / (CHORD * SEMISPAN * _horseshoe_lift_and_centre()[0]
                          * (X_EA - _horseshoe_lift_and_centre()[1]))
    V = math.sqrt(2 * q / RHO)
    alpha = math.radians(0.01)
    (lin,) = linear_sweep(fe, op, [V], RHO, alpha)
    (nl,) = nonlinear_sweep(fe, op, [0.5 * V, V], RHO, alpha)[1:]
    assert nl.converged
    theta_l = fe.expand(lin.u)[fe.mesh.grid_row()[1], 4]
    theta_n = fe.expand(nl.u, large=True)[fe.mesh.grid_row()[1], 4]
    assert theta_n == pytest.approx(theta_l, rel=1e-4)


def test_pazy_nonlinear_static_aeroelastic_at_30_mps():
    """Without skin, 5°, 20 then 30 m/s (continuation): the tip deflection against SOL 400
    under the steady loads (4.434, 10.466 % of the semispan), within 0.25 % of the semispan
    (measured 4.403, 10.421). The reduced form of the slow 50 m/s test."""
    fe = read_bdf(PAZY_NOSKIN)
    op = steady_operator(fe, load_deck(PAZY_NOSKIN, require_flutter=False), mach=0.0)
    sweep = nonlinear_sweep(fe, op, [20.0, 30.0], 1.225, math.radians(5.0))
    got = [_pazy_tip_pct(fe, e.u, large=True) for e in sweep]
    assert got == pytest.approx([4.434, 10.466], abs=0.25)


@pytest.mark.slow
def test_pazy_nonlinear_static_aeroelastic_at_50_mps():
    """Without skin, 5°, 20 … 50 m/s: within 1 % of the semispan of the peers' 31.6 % at 50 m/s
    (SOL 400 under the steady loads 31.59, UM/NAST 31.76, SHARPy 31.58; measured 31.48)."""
    fe = read_bdf(PAZY_NOSKIN)
    op = steady_operator(fe, load_deck(PAZY_NOSKIN, require_flutter=False), mach=0.0)
    sweep = nonlinear_sweep(fe, op, [20.0, 30.0, 40.0, 45.0, 50.0], 1.225, math.radians(5.0))
    assert _pazy_tip_pct(fe, sweep[-1].u, large=True) == pytest.approx(31.59, abs=1.0)


# -- the command ---------------------------------------------------------------------------------
def test_static_command_solves_a_sol144_trim_as_the_aoa_options(tmp_path, capsys):
    """A SOL 144 deck's TRIM (q, ANGLEA) through ``torchrom static`` gives the numbers of
    ``--aoa --velocity`` at the same q (to rounding), with the JSON's units and tip keys."""
    q = 0.5 * K_SPRING / (CHORD * SEMISPAN * 4.0 * 0.15)  # some q below divergence
    deck = _rigid_wing_deck(tmp_path / "trim.bdf",
                            trim=f"TRIM,7,0.0,{q},ANGLEA,0.03\nAESTAT,1,ANGLEA")
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(["static", str(deck), "--json", str(a), "--tip", "1"]) == 0
    V = math.sqrt(2 * q / RHO)
    assert main(["static", str(deck), "--aoa", str(math.degrees(0.03)), "--velocity", str(V),
                 "--json", str(b), "--tip", "1"]) == 0
    capsys.readouterr()
    ra, rb = (json.loads(p.read_text()) for p in (a, b))
    assert ra["analysis"] == "static aeroelastic, linear" and ra["tip"]["grid"] == 1
    (sa,), (sb,) = ra["speeds"], rb["speeds"]
    assert sa["tip_twist_deg"] == pytest.approx(sb["tip_twist_deg"], rel=1e-10)
    assert sa["dynamic_pressure"] == pytest.approx(q, rel=1e-12)
    assert ra["divergence"]["dynamic_pressure"] > q


@pytest.mark.parametrize("extra, trim, message", [
    (["--aoa", "5"], "", "--aoa: expected --velocity"),
    (["--velocity", "30"], "", "--velocity: expected --aoa"),
    ([], "TRIM,7,0.0,100.0,URDD3,1.0\nAESTAT,1,URDD3",
     "TRIM 7: label URDD3: only ANGLEA"),
    ([], "TRIM,7,0.0,100.0,ANGLEA,0.03", "ANGLEA: no AESTAT card"),
    (["--aoa", "5", "--velocity", "30", "--tip", "99"], "", "--tip: grid 99 not found"),
    (["--tip", "1"], "", "--tip: only for the static aeroelastic solution"),
    (["--density", "1.2"], "", "--density: only for the static aeroelastic solution"),
])
def test_static_aeroelastic_bad_input_is_one_line(tmp_path, extra, trim, message):
    """Through the real command in a subprocess: exit 2, one line naming the option or card."""
    deck = _rigid_wing_deck(tmp_path / "wing.bdf", trim=trim)
    out = subprocess.run([sys.executable, "-m", "torchrom", "static", str(deck), *extra],
                         capture_output=True, text=True)
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
