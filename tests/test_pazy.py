"""The Pazy wing's geometrically nonlinear static bending sweep (experiments/pazy_static.py)
against MSC Nastran SOL 400 (Riso & Cesnik, SciTech 2022; tests/decks/aepw3_pazy_noskin_rigidtip):
a tip mass of 0 … 3.5 kg at the tip mid-chord under gravity (a dead load), the self-weight
subtracted, the tip's vertical displacement in % of the semispan. The deck, the load and the
measured point are those of the SOL 101 test (tests/test_public_decks.py); the modes against
the SOL 103 f06 are ``test_public_decks.py::test_pazy_modes_and_mass_match_nastran``.

Tolerance: 0.1 % of the semispan at every mass (the issue's target 2 %, aim 1 %). Measured over
the 15 masses (co-rotational shells and beams, RBE2 arms turned with their grid, dead loads
whose moments and arms follow the rotations, modified Newton to ‖r‖ ≤ 1e-7 ‖F‖): within
0.007 % of the semispan of SOL 400 (0.164 % with the linear elimination's loads Tᵀ f); with the
RBE2s eliminated linearly the 0.5 kg deflection was 40 % short (tests/test_fe_rigid_arms.py).
The torsion sweep (tip mass behind the trailing edge) is at the end of the module.
"""

from __future__ import annotations

import numpy as np
import pytest

from experiments.pazy_static import (
    SOL400,
    nonlinear_sweep,
    pazy_model,
    rom_envelope,
    rom_sweep,
    sweep_table,
)

#: |torchrom − SOL 400| in % of the semispan (module docstring)
TOLERANCE_PCT = 0.1


def _check(masses) -> np.ndarray:
    ref = sweep_table(SOL400)
    res = nonlinear_sweep(pazy_model(), masses, progress=lambda line: None)
    want = np.interp(masses, ref[:, 0], ref[:, 1])
    diff = res.nonlinear - want
    print("pazy SOL 400 (mass, ours, SOL 400, diff % semispan):",
          [(m, round(a, 3), round(b, 3), round(d, 3))
           for m, a, b, d in zip(masses, res.nonlinear, want, diff)], f"{res.seconds:.0f} s")
    # nonlinear stiffening: every loaded point less deflected than the linear solution
    loaded = np.asarray(masses) > 0
    assert np.all(np.abs(res.nonlinear[loaded]) < np.abs(res.linear[loaded]))
    return diff


def test_pazy_nonlinear_tip_mass_matches_sol400():
    """The sweep's first four masses, 0.25 … 1 kg (tip deflection up to a fifth of the
    semispan, where the nonlinear solution is already 1.6 % of the semispan above the linear
    one): within 0.02 % of the semispan of SOL 400 (measured +0.001, +0.001, +0.001, +0.002).
    A reduced form of the full sweep (slow), which a jump in mass cannot shorten: modified
    Newton needs the continuation's small steps."""
    diff = _check(sweep_table(SOL400)[1:5, 0])
    assert np.all(np.abs(diff) <= 0.02), diff


@pytest.mark.slow
def test_pazy_nonlinear_sweep_all_masses():
    """The whole 15-point sweep (0 … 3.5 kg by 0.25 kg) within 0.1 % of the semispan
    (measured: largest +0.007 at 3.5 kg; 55 s on 2 cores)."""
    masses = sweep_table(SOL400)[:, 0]
    diff = _check(masses)
    assert np.all(np.abs(diff) <= TOLERANCE_PCT), diff


def test_rom_envelope_is_the_leading_run_within_2_percent():
    """rom_envelope: the largest |FE| deflection of the leading masses whose ROM deflections
    are all within 2 % of the FE's, by hand: 10 % and 20 % within (1 %, 1.5 %), 30 % off by
    3 %, so 20 (a later point back within does not count); none within gives 0; all within
    gives the largest."""
    fe = np.array([-10.0, -20.0, -30.0, -40.0])
    assert rom_envelope(fe, np.array([-10.1, -19.7, -29.1, -40.0])) == 20.0
    assert rom_envelope(fe, np.array([-9.0, -20.0, -30.0, -40.0])) == 0.0
    assert rom_envelope(fe, fe * 1.015) == 40.0


@pytest.mark.slow
def test_pazy_rom_follows_the_full_fe_to_a_fifth_of_the_semispan():
    """The issue's acceptance: the ROM's tip-mass curve within 2 % of the full FE's up to a
    tip deflection of 20 % of the semispan (masses 0.25 … 1 kg). The ROM: the first two
    bending modes, stiffness by implicit condensation (loads up to 30 % of the span, 3
    levels; docs/guide/pazy.md). Measured: +0.22, +0.30, +0.31, +0.18 % of the FE's
    deflection (−5.53, −10.88, −15.98, −20.80 % of the semispan against −5.54, −10.92,
    −16.03, −20.83 %); the whole sweep's envelope is 33.1 % of the semispan (1.75 kg). The
    tangent ROM of 1 linear + 1 dual mode locked at 2.2 % (an envelope of 0)."""
    masses = sweep_table(SOL400)[1:5, 0]
    fe = pazy_model()
    full = nonlinear_sweep(fe, masses, progress=lambda line: None)
    rom = rom_sweep(fe, masses, n_linear=2, stiffness="condensed", amplitude=0.3, levels=3,
                    progress=lambda line: None)
    print("pazy ROM (mass, FE, ROM % semispan):",
          [(m, round(a, 3), round(b, 3)) for m, a, b in zip(masses, full.nonlinear,
                                                             rom.tip_pct)])
    assert rom_envelope(full.nonlinear, rom.tip_pct) >= 20.0


# -- torsion under large bending (experiments/pazy_torsion.py) ------------------------------------
#: |torchrom − SOL 400| twist (deg) and vertical deflection (% of the semispan): issue 45's
#: acceptance (0.5°, 1 %); measured at most 0.034° and 0.153 % over the 13 masses
TWIST_TOL_DEG, TORSION_DEFLECTION_TOL_PCT = 0.5, 1.0


def _check_torsion(masses):
    from experiments.pazy_torsion import comparison, sweep

    table = comparison(sweep(masses, progress=lambda line: None)["rows"])
    dt = np.array([r["twist_deg"] - r["SOL 400 twist_deg"] for r in table])
    dw = np.array([r["vertical_pct"] - r["SOL 400 vertical_pct"] for r in table])
    print("pazy torsion vs SOL 400 (mass, twist diff deg, deflection diff % semispan):",
          [(r["mass_kg"], round(a, 3), round(b, 3)) for r, a, b in zip(table, dt, dw)])
    # the nonlinear twist is well below the linear one at the larger masses (the coupling)
    assert all(r["twist_deg"] < r["linear_twist_deg"] for r in table)
    return dt, dw


def test_pazy_torsion_sweep_matches_sol400_at_small_masses():
    """The torsion sweep's first four masses (0.25 … 1 kg): twist within 0.05° of SOL 400
    (measured +0.005 … +0.018°) and deflection within 0.1 % of the semispan (measured +0.018
    … +0.066); a reduced form of the slow test below. Before the dead loads turned with the
    rotations the 1 kg twist was +0.17° off."""
    dt, dw = _check_torsion(np.array([0.25, 0.5, 0.75, 1.0]))
    assert np.all(np.abs(dt) <= 0.05), dt
    assert np.all(np.abs(dw) <= 0.1), dw


@pytest.mark.slow
def test_pazy_torsion_sweep_matches_sol400():
    """0.25 … 3.25 kg by 0.25 (SOL 400's 13 masses): twist within 0.5° and deflection within
    1 % of the semispan (module constants; measured 0.034° and 0.153 %; 52 s)."""
    from experiments.pazy_torsion import reference

    dt, dw = _check_torsion(reference("SOL 400")[0][1:, 0])
    assert np.all(np.abs(dt) <= TWIST_TOL_DEG), dt
    assert np.all(np.abs(dw) <= TORSION_DEFLECTION_TOL_PCT), dw
