"""The heavy Goland wing: calibration, stiffness vs REFERENCE Sec. 6, modes vs Table 2, point A,
pressure loads, nonlinear statics and the ``torchrom goland`` command. ``fe`` is the calibrated
variant (the first pass, where the calibration checks belong); the updated variant, the default
since issue 15, has its own tests at the end (the stiffness is the same bit for bit)."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
import torch

from torchrom.cli import main
from torchrom.fe import TABLE2_HZ, calibrate_density, goland, goland_stiffness, read_bdf
from torchrom.fe.goland import (
    CALIBRATED_DENSITY,
    DEFAULT_STORE_X,
    GOLAND_ROTATIONS_NOTE,
    POINT_A_GRID,
)


@pytest.fixture(scope="module")
def fe():
    return goland(variant="calibrated")


@pytest.fixture(scope="module")
def modes(fe):
    return fe.modes(9)


def test_calibration_reproduces_cached_density_and_mode_1(fe, modes):
    cached = CALIBRATED_DENSITY[("bending", "cquad4-membrane", False, DEFAULT_STORE_X)]
    assert calibrate_density() == pytest.approx(cached, rel=1e-9)  # 10-digit rounding
    assert fe.mesh.rods.rho[0] == cached
    assert modes.frequencies_hz[0] == pytest.approx(TABLE2_HZ[0], rel=1e-3)
    assert modes.kinds[0] == "bending" and modes.kinds[1] == "torsion"


def test_builder_keeps_small_rotations(fe):
    """The paper's model: plate bending small-rotation (linear), said in the notes; its
    nonlinear forces are unchanged by the co-rotational layer of decks."""
    assert fe.rotations == "small" and GOLAND_ROTATIONS_NOTE in fe.notes
    assert not fe._corot


def test_box_stiffness_matches_reference(fe):
    """REFERENCE Sec. 6: EI ≈ 2.4e7 lbf ft² (5 %), GJ ≈ 2.4e6 lbf ft² (10 %), flexural axis at
    2 ft from the leading edge (33 % of the 6 ft chord)."""
    s = goland_stiffness(fe)
    assert s["EI"] == pytest.approx(2.4e7, rel=0.05)
    assert s["GJ"] == pytest.approx(2.4e6, rel=0.10)
    assert s["elastic_axis_x"] == pytest.approx(2.0, abs=0.02)


def test_lead_lag_mode(modes):
    """Table 2's mode 5 (11.258 Hz) is the in-plane lead–lag mode. Our box predicts it at
    11.24 Hz (−0.2 %) but as mode 4: our second torsion mode (12.23 Hz, paper's mode 5 slot)
    lies above it, as the torsion modes are 9–31 % high (no calibration knob but the density and
    the store position is allowed, REFERENCE Sec. 6)."""
    inplane = [f for f, k in zip(modes.frequencies_hz[:5], modes.kinds[:5]) if k == "in-plane"]
    assert len(inplane) == 1
    assert inplane[0] == pytest.approx(TABLE2_HZ[4], rel=0.05)
    assert modes.kinds[3] == "in-plane" and modes.kinds[4] == "torsion"


def test_web_variants_stiffness():
    """Membrane-only CQUAD4 webs (default) and CSHEAR panels give the same box stiffness within
    2 %; webs with plate bending more than double GJ (the ribs' out-of-plane bending restrains
    the section's warping), which is why they are not the default. Measured 2.22 times (2.92
    before the CQUAD4's residual bending flexibility softened the thick one-element ribs)."""
    ref = goland_stiffness(goland(store_x=DEFAULT_STORE_X, density=10.0, variant="calibrated"))
    shear = goland_stiffness(goland(density=10.0, webs="cshear", variant="calibrated"))
    plate = goland_stiffness(goland(density=10.0, webs="cquad4", variant="calibrated"))
    assert shear["EI"] == pytest.approx(ref["EI"], rel=0.02)
    assert shear["GJ"] == pytest.approx(ref["GJ"], rel=0.02)
    assert plate["GJ"] > 2.0 * ref["GJ"]


def _box_depth(fe, u, station, chord):
    from torchrom.fe.goland import grid_id

    row = fe.mesh.grid_row()
    U = fe.expand(u)
    top, bot = row[grid_id(1, station, chord)], row[grid_id(2, station, chord)]
    return float(np.linalg.norm(fe.grid_xyz[top] + U[top, :3] - fe.grid_xyz[bot] - U[bot, :3]))


def test_large_bending_stiffens_with_membrane_webs_and_crushes_cshear_boxes(fe):
    """Uniform pressure p₅ giving a 5 ft (25 % span) tip deflection at point A linearly. A
    cantilever stiffens: with membrane CQUAD4 webs (default) the FE converges at p₅ with
    A_Tz = 4.75 ft and keeps the box depth. CSHEAR webs carry no normal stress, so the skins'
    bending stresses crush the section (root bay −15 % depth at 0.8 p₅): the response softens
    (A_Tz 4.22 ft > 4 ft linear at 0.8 p₅) and the static solution is lost before p₅."""
    a = fe.dof_index(*fe.output_points["A_Tz"])
    F = fe.pressure_load(1.0)
    p5 = 5.0 / fe.linear_static(F)[a]
    res = fe.static_solve(p5 * F, n_steps=2)
    assert res.converged and 4.6 < res.u[a] < 4.9
    assert _box_depth(fe, res.u, 1, 1) == pytest.approx(0.33334, rel=0.01)
    cs = goland(density=10.0, webs="cshear", variant="calibrated")
    Fc = cs.pressure_load(1.0)
    p5c = 5.0 / cs.linear_static(Fc)[a]
    soft = cs.static_solve(0.8 * p5c * Fc, n_steps=4)
    assert soft.converged and soft.u[a] > 1.04 * 4.0
    assert _box_depth(cs, soft.u, 1, 1) < 0.9 * 0.33334
    assert not cs.static_solve(p5c * Fc, n_steps=4).converged


def test_point_a_and_outputs(fe):
    assert fe.output_points == {"A_Tx": (POINT_A_GRID, 1), "A_Ty": (POINT_A_GRID, 2),
                                "A_Tz": (POINT_A_GRID, 3)}
    np.testing.assert_allclose(fe.grid_xyz[fe.mesh.grid_row()[POINT_A_GRID]],
                               [2.0, 20.0, 0.16667])
    assert fe.units == {"length": "ft", "mass": "slug", "time": "s", "force": "lbf"}
    k = fe.dof_index(*fe.output_points["A_Tz"])
    u = np.zeros(fe.n_dof)
    u[k] = 1.0
    assert fe.expand(u)[fe.mesh.grid_row()[POINT_A_GRID], 2] == 1.0


def _resultant(fe, F, comp):
    return sum(F[k] for k, (_, c) in enumerate(fe.free_dofs()) if c == comp)


def test_pressure_loads(fe):
    """p acts on the upper skin only (the lifting surface, 4 ft x 20 ft), upwards; the root row
    of grids (1/20 of the consistent load: half a 2-ft bay) is clamped, so 95 % remains."""
    F = fe.pressure_load(10.0)
    assert _resultant(fe, F, 3) == pytest.approx(10.0 * 80.0 * 0.95)
    assert _resultant(fe, F, 1) == 0.0 and _resultant(fe, F, 2) == 0.0
    upper = {g for g, c in fe.free_dofs() if fe.grid_xyz[fe.mesh.grid_row()[g], 2] > 0}
    assert all(F[k] == 0 for k, (g, _) in enumerate(fe.free_dofs()) if g not in upper)
    step = fe.pressure_load(lambda x, y: np.where(x < 2.0, 10.0, -10.0))
    assert abs(_resultant(fe, step, 3)) < 1e-9
    # the vertical spar and rib webs (CQUAD4s too) are not loaded: 2 x 10 upper-skin plates
    assert len(fe.pressure_elements()) == 20 and fe.pressure_elements().max() <= 20


def test_nonlinear_static_matches_linear_at_small_load_and_converges(fe):
    F = fe.pressure_load(1.0)
    u_lin = fe.linear_static(F)
    res = fe.static_solve(F)
    assert res.converged
    np.testing.assert_allclose(res.u, u_lin, rtol=0, atol=2e-3 * np.abs(u_lin).max())
    big = fe.static_solve(fe.pressure_load(1000.0))  # tip deflection ≈ 17 % of the span
    assert big.converged
    r = fe.internal_force(big.u) - fe.pressure_load(1000.0)
    assert np.linalg.norm(r) <= 1e-8 * np.linalg.norm(fe.pressure_load(1000.0))
    a = fe.dof_index(*fe.output_points["A_Tz"])
    assert big.u[a] / 20.0 > 0.15


def test_modal_taylor_coefficients_are_exact(fe, modes):
    """Φᵀ f(Φ q) is an exact cubic in q: its third derivative along q is constant (this is what
    the identification differentiates)."""
    Phi = torch.tensor(modes.shapes[:, :2])
    q0 = torch.tensor([0.3, -0.2], dtype=torch.float64)
    d = torch.tensor([1.0, 0.5], dtype=torch.float64)

    def g(s):
        return Phi.T @ fe.internal_force_torch(Phi @ (q0 + s * d))

    d3 = torch.func.jacfwd(torch.func.jacfwd(torch.func.jacfwd(g)))
    a = d3(torch.tensor(0.0, dtype=torch.float64))
    b = d3(torch.tensor(2.0, dtype=torch.float64))
    assert torch.allclose(a, b, rtol=1e-8, atol=1e-10 * a.abs().max())


def test_membrane_skin_variant_calibrates():
    fe_m = goland(skins="membrane", variant="calibrated")
    assert fe_m.modes(1).frequencies_hz[0] == pytest.approx(TABLE2_HZ[0], rel=1e-3)
    assert all(c <= 3 for _, c in fe_m.free_dofs())  # no rotations left (AUTOSPC)


def test_cli_goland_writes_deck_and_table(tmp_path, capsys):
    out = tmp_path / "g"
    js = tmp_path / "modes.json"
    assert main(["goland", "--variant", "calibrated", "--out", str(out), "--json", str(js)]) == 0
    text = capsys.readouterr().out
    assert "paper Hz" in text and "wrote" in text
    recs = json.loads(js.read_text())
    assert len(recs) == 9 and recs[0]["paper_hz"] == TABLE2_HZ[0]
    assert abs(recs[0]["diff_pct"]) < 0.1
    fe2 = read_bdf(out / "goland.bdf")
    assert fe2.output_points["A_Tz"] == (POINT_A_GRID, 3)
    # the written deck reads back as the paper's small-rotation model, like the builder's
    assert fe2.rotations == "small" and GOLAND_ROTATIONS_NOTE in fe2.notes
    assert read_bdf(out / "goland.bdf", rotations="large").rotations == "large"
    assert main(["goland", "--out", str(out)]) == 2  # no overwrite without --force
    assert "already exists" in capsys.readouterr().err
    assert main(["modes", str(out / "goland.bdf"), "--n", "3"]) == 0
    assert "paper Hz" in capsys.readouterr().out


def test_mass_groups_leave_the_matrices_unchanged(fe):
    """mass_groups puts the trailing-edge caps and web on PROD 15 / PSHELL 24 with the leading
    edge's sections and adds massless CONM2s at the edge grids: the stiffness and mass
    matrices are unchanged (bit for bit)."""
    from torchrom.fe.bdf_read import from_pynastran
    from torchrom.fe.goland import MASS_GROUPS, GolandOptions, goland_bdf, grid_id

    rho = CALIBRATED_DENSITY[("bending", "cquad4-membrane", False, DEFAULT_STORE_X)]
    split = from_pynastran(goland_bdf(DEFAULT_STORE_X, rho, GolandOptions(mass_groups=True)),
                           source="goland", name="goland")
    assert {15, 24} <= set(split.bdf.properties) and 15 not in fe.bdf.properties
    assert split.bdf.masses[MASS_GROUPS["te_out"][0]].nid == grid_id(1, 6, 2)
    assert split.bdf.masses[MASS_GROUPS["le_in"][-1]].nid == grid_id(2, 5, 0)
    assert sum(len(v) for v in MASS_GROUPS.values()) == 40
    assert abs(split.stiffness_matrix() - fe.stiffness_matrix()).max() == 0.0
    assert abs(split.mass_matrix() - fe.mass_matrix()).max() == 0.0


@pytest.fixture(scope="module")
def updated():
    return goland(variant="updated")


def _inplane_mode(modes) -> int:
    """The mode (1-based) with the largest in-plane content share."""
    return 1 + int(np.argmax([c["in-plane"] for c in modes.fractions]))


def test_updated_variant_matches_table2_in_order(updated):
    """Issue acceptance: all nine Table 2 modes within 3 % in the paper's order, mode 1 bending,
    mode 2 the first torsion, modes 1-3 transverse, mode 5 the in-plane (lead–lag) mode
    (observed max 1.7 %). Modes 4 and 5 are mixed (0.44 bending / 0.26 torsion / 0.29 in-plane
    and 0.19 / 0.39 / 0.41): mode 5's label "in-plane" wins by 0.013 only, so what is asserted
    is the robust fact: mode 5 carries the largest in-plane share of the nine (0.41, next
    0.29), and mode 4 is out-of-plane by most of its content."""
    m = updated.modes(9)
    diff = 100 * (m.frequencies_hz - np.array(TABLE2_HZ)) / np.array(TABLE2_HZ)
    assert np.abs(diff).max() < 3.0, diff
    assert m.kinds[:2] == ["bending", "torsion"]
    assert all(k in ("bending", "torsion") for k in m.kinds[:3])
    assert _inplane_mode(m) == 5 and m.fractions[4]["in-plane"] > 0.3
    assert m.fractions[3]["bending"] + m.fractions[3]["torsion"] > 0.6


@pytest.mark.parametrize("offset", [("store_z", -0.1), ("store_z", 0.1), ("store_x", -0.1),
                                    ("store_x", 0.1)])
def test_updated_variant_inplane_mode_is_robust_to_the_store(monkeypatch, offset):
    """The store moved by 0.1 ft (height or chordwise): mode 5 still has the largest in-plane
    share (observed 0.37-0.44, next 0.26-0.33), while its label flips to torsion at +0.1 ft of
    height (observed 0.382 in-plane vs 0.397 torsion; the margin the report states is 0.013),
    hence the tests assert the share."""
    from torchrom.fe.bdf_read import from_pynastran

    G = sys.modules["torchrom.fe.goland"]  # the module (torchrom.fe.goland is the function)
    name, delta = offset
    if name == "store_z":
        monkeypatch.setitem(G.UPDATED_PARAMETERS, "store_z",
                            G.UPDATED_PARAMETERS["store_z"] + delta)
    else:
        monkeypatch.setattr(G, "UPDATED_STORE_X", G.UPDATED_STORE_X + delta)
    m = from_pynastran(G.updated_goland_bdf(10), source="goland", name="moved store",
                       units=G.GOLAND_UNITS, drilling=1e-4).modes(9)
    assert _inplane_mode(m) == 5 and m.fractions[4]["in-plane"] > 0.3
    if offset == ("store_z", 0.1):
        assert m.kinds[4] == "torsion"  # the label is fragile, the share is not


def test_updated_variant_changes_only_what_reference_allows(fe, updated):
    """REFERENCE Sec. 6: element sizes, E and nu untouched (the stiffness matrix is the calibrated
    wing's, bit for bit), the store keeps 22.498 slug and its only inertia 50.3396 slug ft²;
    the structural density is at least aluminium's, every added mass is non-negative and the
    trailing-edge mass lies within the 6 ft chord; the total wing mass is plausible (observed
    211 slug, 10.5 slug/ft, against 232 slug for the calibrated wing)."""
    from torchrom.fe.goland import STORE_MASS, UPDATED_PARAMETERS
    from torchrom.fe.update import total_mass

    assert abs(updated.stiffness_matrix() - fe.stiffness_matrix()).max() == 0.0
    store = updated.bdf.masses[9001]
    assert store.mass == STORE_MASS and list(store.I) == [0.0, 0.0, 50.3396, 0.0, 0.0, 0.0]
    assert updated.bdf.materials[1].rho >= 5.24
    assert all(c.mass >= 0 for c in updated.bdf.masses.values())
    assert all(p.nsm >= 0 for p in updated.bdf.properties.values())
    assert 0.0 <= UPDATED_PARAMETERS["te_mass_x"] <= 2.0
    wing = total_mass(updated) - STORE_MASS
    assert 150.0 < wing < 300.0
    assert wing < total_mass(fe) - STORE_MASS


def test_cli_goland_default_is_the_updated_variant(tmp_path, capsys):
    """Issue 15 acceptance: ``torchrom goland --json`` (no variant: the updated wing) has Table
    2's modes 2-9 within 3 % (all nine: measured ≤ 1.7 %) and mode 5 in-plane; the deck it
    writes has the same modes; the calibrated variant's options are refused on it."""
    js = tmp_path / "modes.json"
    assert main(["goland", "--out", str(tmp_path), "--json", str(js)]) == 0
    recs = json.loads(js.read_text())
    assert max(abs(r["diff_pct"]) for r in recs) < 3.0 and recs[4]["kind"] == "in-plane"
    assert all(r["kind"] in ("bending", "torsion") for r in recs[:4])
    assert read_bdf(tmp_path / "goland.bdf").modes(9).frequencies_hz == pytest.approx(
        [r["frequency_hz"] for r in recs], rel=1e-9)
    assert read_bdf(tmp_path / "goland.bdf").modes(9).frequencies_hz == pytest.approx(
        goland(variant="updated").modes(9).frequencies_hz, rel=1e-9)
    capsys.readouterr()
    for extra in (["--store-x", "3"], ["--mass-groups"]):
        assert main(["goland", *extra, "--out", str(tmp_path / "x")]) == 2
        assert "updated variant (the default) fixes" in capsys.readouterr().err


@pytest.mark.slow
def test_updated_variant_is_reproduced_by_the_update():
    """Re-running torchrom update (torchrom/data/goland_update.toml) at the updated store
    position gives the cached parameter values' frequencies (~1 min)."""
    from torchrom.fe.bdf_read import from_pynastran
    from torchrom.fe.goland import UPDATE_SPEC, UPDATED_STORE_X, GolandOptions, goland_bdf
    from torchrom.fe.update import update_model
    from torchrom.fe.update_config import load_update_spec

    spec = load_update_spec(UPDATE_SPEC)
    bdf = goland_bdf(UPDATED_STORE_X, spec.parameters[0].initial, GolandOptions(mass_groups=True))
    new, res = update_model(from_pynastran(bdf, source="goland", name="goland"), spec)
    np.testing.assert_allclose(new.modes(9).frequencies_hz,
                               goland(variant="updated").modes(9).frequencies_hz, rtol=1e-6)
