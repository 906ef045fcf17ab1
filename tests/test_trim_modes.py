"""Natural frequencies about a static equilibrium (torchrom.trim.modes).

Independent reference: a pinned-pinned Euler–Bernoulli beam under an axial tension P has the
exact frequencies ω_n = (nπ/L)² √(EI/m) √(1 + P L²/(n²π² EI)) (e.g. Blevins, Formulas for
Natural Frequency and Mode Shape, Table 8-1); compression lowers them, to zero at the Euler
load. The beam is solved under the dead axial load with the co-rotational FE, and its tangent's
modes are compared as ratios ω(P)/ω(0), so that the discretisation error (the same with and
without load to first order) cancels.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from torchrom.trim.modes import tangent_modes

from .fe_decks import model_of, new_deck

E, L, RHO, A, I_Z, I_Y, N_EL = 7.0e10, 2.0, 2700.0, 1.0e-3, 2.0e-8, 8.0e-7, 24


def _beam():
    """CBARs along x, pinned at x = 0 (T1-3, R1) and on a roller at x = L (T2, T3, R1); the
    weak bending in the x–z plane (I = I_Z about y)."""
    m = new_deck()
    m.add_mat1(1, E, None, 0.3, rho=RHO)
    m.add_pbar(1, 1, A=A, i1=I_Z, i2=I_Y, j=I_Y)
    for i in range(N_EL + 1):
        m.add_grid(i + 1, [L * i / N_EL, 0.0, 0.0])
    for i in range(N_EL):
        m.add_cbar(i + 1, 1, [i + 1, i + 2], [0.0, 0.0, 1.0], None)
    m.add_spc1(1, "1234", [1])
    m.add_spc1(1, "234", [N_EL + 1])
    return model_of(m)


@pytest.mark.parametrize("ratio", [2.0, -0.5])
def test_axially_loaded_beam_frequency_follows_the_closed_form(ratio):
    """P = ratio · π² EI / L² (tension 2×, compression half the Euler load): the first
    bending frequency's ratio to the unloaded one equals √(1 + ratio) within 0.2 % (measured
    −0.054 % and +0.075 %: the discretisation of the geometric stiffness, 24 elements); the
    reference mode is tracked by MAC > 0.99 (measured 1.000)."""
    fe = _beam()
    P = ratio * math.pi**2 * E * I_Z / L**2
    base = tangent_modes(fe, np.zeros(fe.n_dof), 4)
    load = fe.nodal_dead_load({(N_EL + 1, 1): P})
    u = fe.static_solve(load, n_steps=4, raise_on_failure=True).u
    loaded = tangent_modes(fe, u, 4, base.shapes[:, :1])
    assert loaded.mac[0] > 0.99
    got = loaded.tracked_frequencies()[0] / base.frequencies_hz[0]
    assert got == pytest.approx(math.sqrt(1.0 + ratio), rel=2e-3)
    # and the unloaded value against the closed form itself (measured 2e-7; asserted 0.5 %)
    f0 = (math.pi / L) ** 2 * math.sqrt(E * I_Z / (RHO * A)) / (2 * math.pi)
    assert base.frequencies_hz[0] == pytest.approx(f0, rel=5e-3)


# -- the Pazy wing at 7° (Riso & Cesnik's deformed-modes GFEM: SOL 400 + modes) -----------------
def _pazy_torsion_at(speeds):
    """The tracked first-torsion frequency (Hz) and tip deflection (% of the semispan) about
    the nonlinear equilibria at 7° through ``speeds``, and the GFEM's torsion frequency at the
    same tip deflection."""
    from experiments.pazy_aoa_static import NOSKIN_TIPMASS, REFS, _model, _tip_pct
    from torchrom.trim.equilibrium import nonlinear_sweep

    fe, op = _model(NOSKIN_TIPMASS)
    reference = fe.modes(5).shapes
    gfem = np.loadtxt(REFS / "modal_deformed_aoa7_GFEM_sweep.txt")
    out = []
    for eq in nonlinear_sweep(fe, op, speeds, 1.225, math.radians(7.0)):
        tip = _tip_pct(fe, eq.u, True)
        modes = tangent_modes(fe, eq.u, 8, reference)
        reference = modes.shapes[:, modes.tracked]  # tracked by continuity
        f = modes.tracked_frequencies()[2]
        out.append((tip, f, float(np.interp(tip, gfem[:, 1], gfem[:, 4]))))
    return out


def test_pazy_torsion_frequency_about_a_moderate_deflection():
    """7°, 10 then 25 m/s (tip ~10 % of the semispan): the first torsion frequency of the FE
    tangent within 3 % of the GFEM's at the same tip deflection (measured at 25 m/s: see
    docs/guide/pazy-aoa.md); the reduced form of the slow test below."""
    (_, _, _), (tip, f, ref) = _pazy_torsion_at([10.0, 25.0])
    assert 5.0 < tip < 15.0
    assert f == pytest.approx(ref, rel=0.03)


@pytest.mark.slow
def test_pazy_torsion_frequency_at_a_quarter_of_the_span():
    """7°, 10 … 40 m/s (tip ~26 % of the semispan, where SOL 400's torsion is 29.5 Hz, down
    from 38.3): within the issue's 3 % at every speed."""
    for tip, f, ref in _pazy_torsion_at([10.0, 20.0, 30.0, 35.0, 40.0]):
        assert f == pytest.approx(ref, rel=0.03), tip
