"""Goland 9L12D identification acceptance (issue 4): non-intrusive vs intrusive (autograd)
tensors, the damping methods, outputs and metadata, the dual-mode loads, reproducibility, the CLI
and the Nastran decks.

The identification runs once per test session (session-scoped fixtures, ~12 s on 2 cores); the
full validation against the FE (static curves to 25 % span, free decay) is the slow test at the
end, with a reduced form (two load levels per load shape) in the default run.
"""

import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from torchrom.fe import goland, write_bdf
from torchrom.identify import nastran as nx
from torchrom.identify import validate as v
from torchrom.identify.basis import DualModeOptions, dual_basis, linear_basis
from torchrom.identify.build import IdentifyOptions, as_backend, identify
from torchrom.identify.damping import optimum_decomposition, symmetric_split_damping
from torchrom.identify.intrusive import intrusive_damping, intrusive_stiffness
from torchrom.rom import NonlinearROM
from torchrom.rom import conventions as cv


def rel(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.fixture(scope="session")
def goland_fe():
    """The calibrated wing, on which the issue-4 numbers below were measured (the updated wing,
    the default since issue 15, has its own static check at the end)."""
    return goland(variant="calibrated")


@pytest.fixture(scope="session")
def goland_exact(goland_fe):
    """9L12D, stiffness by tangents, damping `exact` (the material tangents come along)."""
    return identify(goland_fe, IdentifyOptions(n_linear=9, n_dual=12, damping="exact"))


@pytest.fixture(scope="session")
def goland_decomposition(goland_exact):
    s = goland_exact.stiffness
    return optimum_decomposition(s.K1, s.K2, s.K3)


@pytest.fixture(scope="session")
def goland_intrusive(goland_fe, goland_exact):
    Phi = goland_exact.basis.Phi
    return intrusive_stiffness(goland_fe, Phi), intrusive_damping(goland_fe, Phi)


def test_stiffness_matches_intrusive(goland_exact, goland_intrusive):
    (K1, K2, K3), _ = goland_intrusive
    rom = goland_exact.rom
    comb = cv.to_combined(torch.as_tensor(K2), torch.as_tensor(K3))
    mine = rom.combined()
    # acceptance: 1e-8 relative; measured ~1e-14 (the FE is exactly cubic)
    assert rel(mine["K2"], comb["K2"]) < 1e-8
    assert rel(mine["K3"], comb["K3"]) < 1e-8
    assert rel(rom.K1, K1) < 1e-10


def test_exact_damping_matches_intrusive(goland_exact, goland_intrusive):
    _, (D1, D2, D3) = goland_intrusive
    rom = goland_exact.rom
    assert rel(rom.D1, D1) < 1e-8 and rel(rom.D2, D2) < 1e-8 and rel(rom.D3, D3) < 1e-8


def test_decomposition_acceptance(goland_exact, goland_decomposition):
    s = goland_exact.stiffness
    r = goland_decomposition.report
    # the decomposition (before the final enforcement) reproduces the identified coefficients
    assert r["decomposition_reproduction_error_K2"] < 1e-10
    assert r["decomposition_reproduction_error_K3"] < 1e-10
    # smallest extended-matrix eigenvalue at least that of the plain symmetric split
    assert r["final"]["min_eigenvalue_scaled"] >= r["symmetric_split"]["min_eigenvalue_scaled"]
    assert r["final"]["min_eigenvalue_scaled"] >= 0.0
    rom = NonlinearROM(goland_exact.rom.M, s.K1, s.K2, s.K3, goland_decomposition.D1,
                       goland_decomposition.D2, goland_decomposition.D3, symmetrize=True)
    # dissipation on 10⁴ random states with realistic amplitudes: each basis function up to
    # ~20 % of the span (10 × the identification amplitude of 1 % per function, 2σ)
    g = torch.Generator().manual_seed(0)
    a = torch.as_tensor(s.amplitudes)
    q = 10.0 * a * torch.randn(10_000, rom.n, generator=g, dtype=torch.float64)
    qd = torch.randn(10_000, rom.n, generator=g, dtype=torch.float64) * a
    P = rom.dissipated_power(q, qd)
    lin = torch.einsum("bm,mn,bn->b", qd, rom.D1, qd)
    assert float((P / lin).min()) >= -1e-12
    # the plain split's extended matrix is indefinite: the decomposition/enforcement mattered
    plain = symmetric_split_damping(s.K1, s.K2, s.K3)
    rp = NonlinearROM(rom.M, s.K1, s.K2, s.K3, plain.D1, plain.D2, plain.D3, symmetrize=True)
    assert rp.extended_damping_min_eigenvalue() < 0.0 <= rom.extended_damping_min_eigenvalue()


def test_rom_outputs_kinds_metadata(goland_fe, goland_exact):
    rom, Phi = goland_exact.rom, goland_exact.basis.Phi
    assert rom.mode_kinds == ["linear"] * 9 + ["dual"] * 12
    for name in ("A_Tx", "A_Ty", "A_Tz"):
        gid, comp = goland_fe.output_points[name]
        assert np.array_equal(rom.outputs[name], Phi[goland_fe.dof_index(gid, comp)])
    assert rom.frequencies_hz[0] == pytest.approx(1.690, rel=1e-3)
    assert np.all(np.isnan(rom.frequencies_hz[9:]))
    meta = rom.metadata
    assert meta["damping"]["method"] == "exact" and meta["basis"]["n_dual"] == 12
    assert len(meta["basis"]["pod_spectrum"]) >= 12
    s = goland_exact.summary()
    assert s["fe_tangent_evaluations"] == 1 + 2 * 21 + 2 * 210
    assert s["fe_material_tangent_evaluations"] == s["fe_tangent_evaluations"]


def test_every_dual_load_converges(goland_exact):
    """All 180 dual-mode loads (9 combinations × 20 amplitudes) are carried by the FE, their
    tip deflections spread over 0.1–15 % of the span (the FE's own, within 3 %, or below the
    target where a stiffening response, e.g. torsion, reaches the α of the linear prediction)."""
    recs = goland_exact.basis.snapshots
    assert len(recs) == 180 and all(r["status"] == "ok" for r in recs)
    for r in recs:
        t = r["target_pct_span"]
        assert 0.1 - 1e-9 <= t <= 15.0 + 1e-9 and r["tip_pct_span"] <= 1.03 * t
        assert r["tip_pct_span"] >= 0.97 * t or r["tip_linear_pct_span"] == pytest.approx(t)
    solves = sum(r["solves"] for r in recs)
    assert goland_exact.counters["static_solves"] == solves < 3 * 180


def test_dual_modes_are_reproducible(goland_fe, goland_exact):
    """Two runs give the same basis bit for bit: the linear modes again, and the dual modes of a
    reduced set of loads twice (the full run twice is in the slow test)."""
    be = as_backend(goland_fe)
    lin = linear_basis(be, 9)
    assert np.array_equal(lin.Phi, goland_exact.basis.Phi[:, :9])
    opts = DualModeOptions(combinations=((1, 1), (1, 2)), n_amplitudes=6)
    a, b = (dual_basis(be, lin, 3, opts).Phi for _ in range(2))
    assert np.array_equal(a, b)


def test_static_validation_reduced(goland_fe, goland_exact):
    """Reduced form of the slow validation: both load shapes, two levels up to 10 % span; the
    issue's 2 % on A_Tz and A_Ty (measured ≤ 0.6 %)."""
    be = as_backend(goland_fe)
    for shape, load in be.load_shapes().items():
        c = v.static_validation(be, goland_exact.rom, goland_exact.basis.Phi, shape, load,
                                max_tip_fraction=0.1, n_levels=2)
        assert c.tip_pct_span.max() >= 9.9
        assert c.errors["A_Tz"] < 0.02 and c.errors["A_Ty"] < 0.02, (shape, c.errors)


def test_nastran_decks_for_goland(goland_fe, goland_exact, tmp_path):
    dm = nx.DofMap.from_fe(goland_fe)
    bdf = nx.write_bulk_include(goland_fe, tmp_path / "goland_bulk.bdf")
    be = as_backend(goland_fe)
    from torchrom.identify.basis import Basis, dual_loads

    lin = Basis(goland_exact.basis.Phi[:, :9], ["linear"] * 9,
                goland_exact.basis.frequencies_hz[:9])
    loads = dual_loads(be, lin)
    deck = nx.read_deck(nx.write_load_deck(tmp_path / "dual.bdf", dm,
                                           np.array([ld.load for ld in loads]),
                                           model_include=bdf))
    assert len([k for k in deck.case_control_deck.subcases if k > 0]) == 9 * 20
    Phi = goland_exact.basis.Phi
    pts = goland_exact.plan_points[[0, 1, 60]]
    paths = nx.write_displacement_decks(tmp_path / "imposed", dm, pts @ Phi.T,
                                        model_include=bdf, material=True)
    d = nx.read_deck(paths[2])
    assert len(d.loads[901]) == goland_fe.n_dof        # one SPCD per independent DOF
    # the decks include the model, whose bulk data pyNastran reads with them
    assert len(d.nodes) == len(goland_fe.grid_ids) and d.spcadds[902][0].sets == [1, 900]


def test_cli_identify_small_basis(goland_fe, tmp_path):
    bdf = write_bdf(goland_fe, tmp_path / "goland.bdf")
    out, js = tmp_path / "rom.npz", tmp_path / "id.json"
    cmd = [sys.executable, "-m", "torchrom", "identify", str(bdf), "--linear", "3", "--dual",
           "2", "--damping", "exact", "--out", str(out), "--json", str(js)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    rom = NonlinearROM.load(out)
    assert rom.n == 5 and rom.mode_kinds[-1] == "dual"
    rec = json.loads(js.read_text())
    # the paper's combinations within 3 modes: (1,1) (1,2) (1,3) (2,2) (2,3), 20 loads each,
    # a few more solves where the response softens ("response" amplitudes)
    assert 100 <= rec["fe_static_solves"] < 200
    assert rec["fe_tangent_evaluations"] == 1 + 2 * 5 + 2 * 10 and rec["time_command_s"] > 0
    again = subprocess.run(cmd, capture_output=True, text=True)
    assert again.returncode == 2 and "--force" in again.stderr


@pytest.mark.slow
def test_full_validation_report(goland_fe, goland_exact, tmp_path):
    """Acceptance (issue 4) for 9L12D: static A_Tz, A_Ty within 2 % up to a 25 % span tip
    deflection under the uniform pressure (measured 0.22 %, 1.72 %), and under the step pressure
    (lift + nose-up torque, mid-line at the wing's mid-chord x = 3 ft) up to 15 % (measured
    0.55 %, 1.12 %); beyond, 12 dual modes are too few: 1.72 %, 3.37 % at 25 % (the POD
    truncation — 9L14D passes, next test). Free decay from a 3 ft (15 % span) tip deflection,
    γ = 1e-3 s: within 3 % envelope and 1 % frequency over ten cycles (measured 0.81 %,
    0.074 %)."""
    from torchrom.identify.report import write_report

    nums = write_report(goland_exact, as_backend(goland_fe), tmp_path / "report", gamma=1e-3,
                        decay_tip_fraction=0.15)
    assert (tmp_path / "report" / "report.md").exists()
    print(json.dumps(nums, indent=1))
    for k in ("A_Tz", "A_Ty"):
        assert nums["static_uniform_max_tip_pct_span"] >= 24.8
        assert nums[f"static_uniform_{k}_max_rel_error"] < 0.02
        assert nums[f"static_step_{k}_max_rel_error_tip_le_15pct"] < 0.02
        assert nums[f"static_step_{k}_max_rel_error"] < 0.05  # the documented 9L12D limit
    assert nums["static_step_midline_x"] == 3.0
    assert nums["decay_initial_amplitude"] > 2.5  # A_Tz, ft, about the final mean
    assert nums["decay_envelope_error"] < 0.03 and nums["decay_frequency_error"] < 0.01


@pytest.mark.slow
def test_9l14d_static_validation_to_25_percent(goland_fe):
    """With 14 dual modes both load shapes meet the issue's 2 % on A_Tz and A_Ty up to 25 % span
    (measured uniform 0.06 %, 0.97 %; step 0.80 %, 1.09 %)."""
    res = identify(goland_fe, IdentifyOptions(n_linear=9, n_dual=14, damping="exact"))
    be = as_backend(goland_fe)
    for shape, load in be.load_shapes().items():
        c = v.static_validation(be, res.rom, res.basis.Phi, shape, load)
        assert c.tip_pct_span.max() >= 24.8
        assert c.errors["A_Tz"] < 0.02 and c.errors["A_Ty"] < 0.02, (shape, c.errors)


@pytest.mark.slow
def test_goland_identification_is_reproducible(goland_fe, goland_exact, goland_decomposition):
    """A second full 9L12D run gives the same basis, tensors and decomposition bit for bit."""
    again = identify(goland_fe, IdentifyOptions(n_linear=9, n_dual=12, damping="exact"))
    assert np.array_equal(again.basis.Phi, goland_exact.basis.Phi)
    for name in ("K1", "K2", "K3"):
        assert np.array_equal(getattr(again.stiffness, name), getattr(goland_exact.stiffness,
                                                                      name))
    s = again.stiffness
    d = optimum_decomposition(s.K1, s.K2, s.K3)
    for name in ("D1", "D2", "D3"):
        assert np.array_equal(getattr(d, name), getattr(goland_decomposition, name))
    assert d.report["symmetric_split"] == goland_decomposition.report["symmetric_split"]


@pytest.fixture(scope="session")
def goland_bending_torsion(goland_fe):
    """9L12D from the bending-torsion combinations (the built-in Goland pipeline's ROM)."""
    from torchrom.identify.basis import BENDING_TORSION_COMBINATIONS

    return identify(goland_fe, IdentifyOptions(
        n_linear=9, n_dual=12, damping="exact",
        dual=DualModeOptions(combinations=BENDING_TORSION_COMBINATIONS)))


def test_bending_torsion_9l12d_static_to_25_percent_reduced(goland_fe, goland_bending_torsion):
    """Issue 4 static acceptance for the pipeline's 9L12D, reduced to two load levels per shape
    up to a 25 % span tip deflection: A_Tz and A_Ty within 2 % (measured on the full curves:
    uniform 0.11 %, 0.87 %; step 0.53 %, 0.91 %)."""
    be = as_backend(goland_fe)
    for shape, load in be.load_shapes().items():
        c = v.static_validation(be, goland_bending_torsion.rom, goland_bending_torsion.basis.Phi,
                                shape, load, n_levels=2)
        assert c.tip_pct_span.max() >= 24.8
        assert c.errors["A_Tz"] < 0.02 and c.errors["A_Ty"] < 0.02, (shape, c.errors)


@pytest.mark.slow
def test_bending_torsion_9l12d_full_validation(goland_fe, goland_bending_torsion):
    """Issue 4 acceptance for the pipeline's 9L12D on the full curves (1 % to 25 % span, both
    shapes; 2 % on A_Tz, A_Ty) and the free decay from 10 % and 15 % span, γ = 1e-3 s (3 %
    envelope, 1 % frequency over ten cycles; measured at 10 %: 0.30 %, 0.019 %)."""
    be = as_backend(goland_fe)
    rom, Phi = goland_bending_torsion.rom, goland_bending_torsion.basis.Phi
    shapes = dict(be.load_shapes())
    for shape, load in shapes.items():
        c = v.static_validation(be, rom, Phi, shape, load)
        assert c.tip_pct_span.max() >= 24.8
        assert c.errors["A_Tz"] < 0.02 and c.errors["A_Ty"] < 0.02, (shape, c.errors)
    for tip in (0.10, 0.15):
        m = v.free_decay_validation(be, rom, Phi, shapes["uniform"], tip_fraction=tip,
                                    gamma=1e-3, cycles=10).metrics
        assert m["envelope_error"] < 0.03 and m["frequency_error"] < 0.01, (tip, m)


@pytest.fixture(scope="session")
def updated_fe():
    return goland()


def test_updated_wing_dual_pairs_by_rule(updated_fe):
    """On the updated wing (the default) the rule loads the second bending mode (4) as well: a
    torsion mode (3) lies below it (issue 15, item 3)."""
    from torchrom.identify.basis import parse_combinations

    assert parse_combinations("transverse", kinds=updated_fe.modes(9).kinds) == (
        (1, 1), (1, 2), (1, 3), (1, 4), (2, 2), (2, 3), (2, 4))


def test_updated_wing_static_to_25_percent_reduced(updated_fe):
    """Issue 15 item 3: the ROM's static error on the updated wing, A_Tz and A_Ty within 2 % up
    to a 25 % span tip deflection, with the dual pairs of the rule, reduced to two load levels
    per shape (12.5 % and 25 %). 14 dual modes: measured on the full curves (1-25 %, 11-12
    levels) uniform 0.21 % / 1.13 %, step 1.93 % / 1.40 %; with the paper's 12 the step
    pressure's A_Tz reaches 2.01 % at 25 % (1.52 % at 20 %), so the 2 % bound needs 14
    (experiments/results/goland_validation_updated.md)."""
    from torchrom.identify.basis import parse_combinations

    pairs = parse_combinations("transverse", kinds=updated_fe.modes(9).kinds)
    res = identify(updated_fe, IdentifyOptions(n_linear=9, n_dual=14, damping="exact",
                                               dual=DualModeOptions(combinations=pairs)))
    be = as_backend(updated_fe)
    for shape, load in be.load_shapes().items():
        c = v.static_validation(be, res.rom, res.basis.Phi, shape, load, n_levels=2)
        assert c.tip_pct_span.max() >= 24.8
        assert c.errors["A_Tz"] < 0.02 and c.errors["A_Ty"] < 0.02, (shape, c.errors)
