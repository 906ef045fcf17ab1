"""Starts on the ROM's static manifold (torchrom.sim.initial)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.sim import CaseSystem, LCOCriteria, Newmark
from torchrom.sim.initial import dual_indices, static_manifold
from torchrom.study.cases import case_system

from .aeroelastic_fixtures import SEMICHORD, section_model

PAPER_STEP = {"dt": 1e-3, "iterations": 2, "refresh_every": 1, "tol": 1e-3}


def _section_cases():
    model = section_model()
    cases = [{"altitude_ft": a, "gamma": 1e-4, "alpha": 0.05} for a in (6000.0, 8000.0)]
    return model, case_system(model, cases)[0]


def test_dual_coordinate_matches_the_closed_form_static_response():
    # strain energy ½ k_u (u + h²/b)²: the static dual coordinate is u = −h²/b exactly, whatever
    # the pitch and the aerodynamic stiffness (which acts on h, α only)
    model, system = _section_cases()
    assert dual_indices(model.rom) == [2]
    h = np.array([0.3, -2.0])
    q0 = np.stack([h, [0.01, -0.02], [5.0, 0.0]], axis=1)
    q, ok = static_manifold(system, q0)
    assert ok.all()
    np.testing.assert_allclose(q[:, 2], -h**2 / SEMICHORD, rtol=1e-12)
    np.testing.assert_array_equal(q[:, :2], q0[:, :2])  # the linear coordinates are kept


def test_rom_without_dual_coordinates_is_unchanged():
    from torchrom.rom.analytic import van_der_pol_duffing

    system = CaseSystem.build(van_der_pol_duffing(1.0), 2)
    q, ok = static_manifold(system, np.array([[0.5], [1.0]]))
    np.testing.assert_array_equal(q, [[0.5], [1.0]])
    assert ok.all()


def test_large_start_on_the_manifold_reaches_the_small_start_lco():
    # h = 1 (u left at 0) puts ½ k_u/b² h⁴ of strain energy into the stiff dual mode: at the
    # paper's step (1 ms, 2 Newton iterations) the iteration breaks down and the case diverges.
    # On the static manifold the same start settles on the LCO of a small start (supercritical:
    # same amplitude within the LCO tolerance, rtol 1e-3 per cycle -> 0.5 %)
    model, system = _section_cases()
    lco = LCOCriteria(max_amplitude=10.0)
    integ = Newmark(**PAPER_STEP)
    big = np.zeros((2, 3))
    big[:, 0] = 1.0
    plain = integ.run(system, big, t_end=30.0, outputs=["A_Tz"], lco=lco)
    assert (plain.status == "diverged").all()
    on, _ = static_manifold(system, big)
    res = integ.run(system, on, t_end=30.0, outputs=["A_Tz"], lco=lco)
    small = np.zeros((2, 3))
    small[:, 0] = 0.01
    ref = integ.run(system, small, t_end=60.0, outputs=["A_Tz"], lco=lco)
    assert (res.status == "lco").all() and (ref.status == "lco").all()
    np.testing.assert_allclose(res.amplitude[:, 0], ref.amplitude[:, 0], rtol=5e-3)
    assert (res.amplitude[:, 0] < 0.2).all()  # far below the start: it decayed onto the LCO


@pytest.mark.slow
def test_goland_15_percent_span_start_converges_at_the_paper_step(tmp_path):
    # acceptance: the paper's Goland ROM, a mode-1 start with the tip at 15 % of span, dt = 1 ms
    from torchrom.paper.pipeline import goland_pipeline
    from torchrom.paper.study import QUICK_PIPELINE

    model = goland_pipeline(QUICK_PIPELINE, tmp_path, log=lambda _m: None).model
    rom = model.rom
    cases = [{"altitude_ft": a, "gamma": g, "alpha": "matched"} for g in (0.0, 1e-3)
             for a in (4000.0, 10000.0)]
    system = case_system(model, cases, dtype=torch.float64)[0]
    q0 = np.zeros((len(cases), rom.n))
    q0[:, 0] = 0.15 * model.span / rom.outputs["A_Tz"][0]
    lco = LCOCriteria(max_amplitude=10.0)
    plain = Newmark(**PAPER_STEP).run(system, q0, t_end=5.0, outputs=["A_Tz"], lco=lco)
    assert (plain.status == "diverged").all()
    on, ok = static_manifold(system, q0)
    assert ok.all()
    res = Newmark(**PAPER_STEP).run(system, on, t_end=60.0, outputs=["A_Tz"], lco=lco)
    assert (res.status == "lco").all(), res.status
