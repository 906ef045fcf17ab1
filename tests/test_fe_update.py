"""FE model updating (torchrom.fe.update, torchrom update): recovery of known parameters,
sensitivities against finite differences, MAC tracking through a mode swap, deck round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.fe_decks import model_of, tip_mass_beam
from torchrom.cli import main
from torchrom.fe import read_bdf, write_bdf
from torchrom.fe.update import ModelUpdater, get_value, total_mass, update_model
from torchrom.fe.update_config import (
    FrequencyTarget,
    UpdateOptions,
    UpdateParameter,
    UpdateSpec,
)

TRUE = dict(nsm=(1.0, 0.5), tip_mass=4.0, tip_x=0.05)
PERTURBED = dict(nsm=(1.3, 0.4), tip_mass=3.5, tip_x=0.08)
MASS_PARAMETERS = (
    UpdateParameter("nsm_in", "PBAR", (1,), "nsm", 0.0, 5.0),
    UpdateParameter("nsm_out", "PBAR", (2,), "nsm", 0.0, 5.0),
    UpdateParameter("tip_mass", "CONM2", (100,), "mass", 0.5, 10.0),
    UpdateParameter("tip_x", "CONM2", (100,), "x1", -0.5, 0.5),
)


def _targets(fe, n=8):
    return tuple(FrequencyTarget(float(f), name=f"mode {k + 1}")
                 for k, f in enumerate(fe.modes(n).frequencies_hz))


def test_update_recovers_perturbed_parameters():
    """Frequencies of the true beam as targets, a perturbed start (up to 60 % off): the four
    mass parameters come back within 0.1 % (the fit reaches machine precision: the targets
    are exact)."""
    targets = _targets(model_of(tip_mass_beam(**TRUE)))
    fe = model_of(tip_mass_beam(**PERTURBED))
    new, res = update_model(fe, UpdateSpec(targets, MASS_PARAMETERS,
                                           UpdateOptions(tolerance=1e-12)))
    final = {k: v["final"] for k, v in res.parameters.items()}
    want = {"nsm_in": 1.0, "nsm_out": 0.5, "tip_mass": 4.0, "tip_x": 0.05}
    for k, v in want.items():
        assert final[k] == pytest.approx(v, rel=1e-3), k
    assert res.summary()["max_abs_diff_pct"] < 1e-4
    assert res.history[0]["max_abs_diff_pct"] > 1.0
    assert res.history[-1]["cost"] < res.history[0]["cost"]
    assert [t["mode"] for t in res.targets] == list(range(1, 9))
    # MAC of each final mode against its initial (perturbed-model) shape, recomputed by hand:
    # (φ0ᵀ M φ)² / ((φ0ᵀ M φ0)(φᵀ M φ)) with the final mass matrix
    phi0 = model_of(tip_mass_beam(**PERTURBED)).modes(8).shapes
    phi, M = new.modes(8).shapes, new.mass_matrix()
    mac = [(a @ M @ b) ** 2 / ((a @ M @ a) * (b @ M @ b)) for a, b in zip(phi0.T, phi.T)]
    np.testing.assert_allclose([t["mac"] for t in res.targets], mac, rtol=1e-8)
    assert min(mac) > 0.85  # mode 4 (torsion) 0.88: the tip offset 0.08 -> 0.05 m recouples it
    # the returned model is built from the updated deck
    assert new.modes(8).frequencies_hz == pytest.approx([t["target_hz"] for t in res.targets],
                                                        rel=1e-6)
    # rigid-body mass: beam 2 m × (ρA = 2.7 + NSM) + tip mass
    assert res.total_mass_initial == pytest.approx(2.7 * 2 + 1.3 + 0.4 + 3.5, rel=1e-6)
    assert res.total_mass_final == pytest.approx(1.0 * (2.7 + 1.0) + 1.0 * (2.7 + 0.5) + 4.0,
                                                 rel=1e-6)


def test_initial_frequencies_are_the_decks_own():
    """With 'initial' values in the targets file the update starts from them, but the report's
    "initial Hz" are the frequencies of the deck as given (its own parameter values), computed
    from the deck: here those of the perturbed beam, not of the start at the true values."""
    import dataclasses

    targets = _targets(model_of(tip_mass_beam(**TRUE)), 4)
    start = {"nsm_in": 1.0, "nsm_out": 0.5, "tip_mass": 4.0, "tip_x": 0.05}
    params = tuple(dataclasses.replace(p, initial=start[p.name]) for p in MASS_PARAMETERS)
    fe = model_of(tip_mass_beam(**PERTURBED))
    _, res = update_model(fe, UpdateSpec(targets, params, UpdateOptions(tolerance=1e-10)))
    deck = model_of(tip_mass_beam(**PERTURBED)).modes(4).frequencies_hz
    np.testing.assert_allclose([t["initial_hz"] for t in res.targets], deck, rtol=1e-9)
    assert [p["initial"] for p in res.parameters.values()] == list(start.values())


@pytest.mark.parametrize("which", ["nsm_out", "tip_x", "i1"])
def test_sensitivities_match_finite_differences(which):
    """Analytic df/dp (φᵀ(dK − λ dM)φ) against central differences of the eigenvalue solution
    (step 1e-5 relative: truncation ~1e-10, rounding ~1e-9 of f; tolerance 1e-5 relative to
    the largest sensitivity)."""
    params = MASS_PARAMETERS + (UpdateParameter("i1", "PBAR", (1, 2), "i1", 1e-7, 1e-4),)
    p = next(q for q in params if q.name == which)
    fe = model_of(tip_mass_beam(**PERTURBED))
    up = ModelUpdater(fe, UpdateSpec(_targets(fe, 6), (p,)))
    v0 = np.array([get_value(fe.bdf, p)])
    S = up.frequency_sensitivities(v0)[:, 0]
    h = 1e-5 * max(abs(v0[0]), 1e-6)
    fp = up.evaluate(v0 + h)
    fm = up.evaluate(v0 - h)
    fd = (fp["freq"][fp["pairs"]] - fm["freq"][fm["pairs"]]) / (2 * h)
    assert np.abs(S).max() > 0
    np.testing.assert_allclose(S, fd, rtol=0, atol=1e-5 * np.abs(S).max())


def test_mac_tracking_follows_a_mode_swap():
    """Raise the vertical bending stiffness I1 until the 1st vertical bending mode (15.5 Hz, mode
    1) passes the 1st chordwise mode (30.9 Hz, mode 2): the target of mode 1 (45 Hz) must stay on
    the bending shape (now mode 2), the chordwise target on its shape (now mode 1). Bending
    frequency ∝ √I1 except for the small coupling through the tip-mass offset, so I1 ends
    near (45/15.46)² × 2e-6."""
    fe = model_of(tip_mass_beam())
    f0 = fe.modes(2).frequencies_hz
    targets = (FrequencyTarget(45.0, mode=1, name="bending"),
               FrequencyTarget(float(f0[1]), mode=2, name="chordwise"))
    par = (UpdateParameter("i1", "PBAR", (1, 2), "i1", 1e-7, 1e-4),)
    new, res = update_model(fe, UpdateSpec(targets, par, UpdateOptions(tolerance=1e-12)))
    bend, chord = res.targets
    assert (bend["mode"], bend["kind"]) == (2, "bending")
    assert (chord["mode"], chord["kind"]) == (1, "in-plane")
    assert bend["final_hz"] == pytest.approx(45.0, rel=1e-6)
    assert bend["mac"] > 0.99 and chord["mac"] > 0.99
    assert res.parameters["i1"]["final"] == pytest.approx((45.0 / f0[0]) ** 2 * 2e-6, rel=0.02)
    m = new.modes(2)
    assert m.kinds == ["in-plane", "bending"]


def test_pairing_by_kind_keeps_the_order():
    """pairing = "kind": the same stiffening as in the swap test, but the targets are re-paired
    in frequency order at every evaluation, so target 1 stays on the lowest mode: once the
    bending mode passes the chordwise one, raising I1 no longer moves the lowest frequency and
    the fit stops at the crossing, short of 45 Hz."""
    fe = model_of(tip_mass_beam())
    f0 = fe.modes(2).frequencies_hz
    targets = (FrequencyTarget(45.0), FrequencyTarget(float(f0[1])))
    par = (UpdateParameter("i1", "PBAR", (1, 2), "i1", 1e-7, 1e-4),)
    _, res = update_model(fe, UpdateSpec(targets, par, UpdateOptions(pairing="kind")))
    assert [t["mode"] for t in res.targets] == [1, 2]
    assert res.targets[0]["final_hz"] < f0[1] * 1.001
    assert res.targets[0]["final_diff_pct"] < -25.0


def test_pairing_by_kind_and_reference_deck():
    """Targets by kind pick the lowest matching modes (torsion = mode 4); with a reference deck
    each target is paired with its reference mode by MAC."""
    fe = model_of(tip_mass_beam())
    targets = (FrequencyTarget(100.0, kind="torsion"), FrequencyTarget(20.0, kind="in-plane"))
    up = ModelUpdater(fe, UpdateSpec(targets, MASS_PARAMETERS[:1]))
    ev = up.evaluate(up.p0)
    assert list(ev["pairs"]) == [3, 1]
    ref = model_of(tip_mass_beam())
    targets = (FrequencyTarget(100.0, mode=4), FrequencyTarget(20.0, mode=2))
    up = ModelUpdater(model_of(tip_mass_beam(**PERTURBED)),
                      UpdateSpec(targets, MASS_PARAMETERS[:1]), reference=ref)
    ev = up.evaluate(up.p0)
    assert list(ev["pairs"]) == [3, 1]


def test_updated_deck_round_trips(tmp_path):
    """The updated deck written by write_bdf and read back has the updated card values and the
    same frequencies."""
    targets = _targets(model_of(tip_mass_beam(**TRUE)), 6)
    new, res = update_model(model_of(tip_mass_beam(**PERTURBED)),
                            UpdateSpec(targets, MASS_PARAMETERS))
    path = write_bdf(new, tmp_path / "updated.bdf")
    back = read_bdf(path)
    for p in MASS_PARAMETERS:
        assert get_value(back.bdf, p) == pytest.approx(res.parameters[p.name]["final"],
                                                       rel=1e-12)
    np.testing.assert_allclose(back.modes(6).frequencies_hz, [t["final_hz"] for t in
                                                              res.targets], rtol=1e-9)
    assert total_mass(back) == pytest.approx(res.total_mass_final, rel=1e-12)


TOML = """
[optimizer]
tolerance = 1e-12

{targets}

[[parameter]]
name = "nsm_in"
card = "PBAR"
ids = [1]
field = "nsm"
lower = 0.0
upper = 5.0

[[parameter]]
name = "tip_mass"
card = "{card}"
ids = [100]
field = "mass"
lower = 0.5
upper = 10.0
"""


def _cli_files(tmp_path, card="CONM2"):
    true = model_of(tip_mass_beam())
    deck = write_bdf(model_of(tip_mass_beam(nsm=(1.4, 0.5), tip_mass=3.0)),
                     tmp_path / "beam.bdf")
    targets = "\n".join(f"[[target]]\nfrequency_hz = {f!r}\n"
                        for f in true.modes(5).frequencies_hz)
    spec = tmp_path / "targets.toml"
    spec.write_text(TOML.format(targets=targets, card=card))
    return deck, spec


def test_cli_update(tmp_path, capsys):
    deck, spec = _cli_files(tmp_path)
    out, js = tmp_path / "updated.bdf", tmp_path / "update.json"
    args = ["update", str(deck), "--targets", str(spec), "--out", str(out), "--json", str(js)]
    assert main(args) == 0
    data = json.loads(js.read_text())
    assert data["parameters"]["nsm_in"]["final"] == pytest.approx(1.0, rel=1e-6)
    assert data["parameters"]["tip_mass"]["final"] == pytest.approx(4.0, rel=1e-6)
    assert data["max_abs_diff_pct"] < 1e-5
    assert len(data["mac"]) == 5 and len(data["history"]) >= 2
    assert read_bdf(out).modes(5).frequencies_hz == pytest.approx(
        [t["target_hz"] for t in data["targets"]], rel=1e-7)
    capsys.readouterr()
    assert main(args) == 2  # outputs exist, no --force
    assert "--force" in capsys.readouterr().err


def test_cli_update_bad_input(tmp_path, capsys):
    deck, spec = _cli_files(tmp_path, card="CONM3")
    out = tmp_path / "updated.bdf"
    assert main(["update", str(deck), "--targets", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "[[parameter]] 2" in err and "card" in err and "CONM3" in err
    assert not out.exists()
    spec.write_text(spec.read_text().replace('"CONM3"', '"CONM2"').replace("ids = [100]",
                                                                           "ids = [101]"))
    assert main(["update", str(deck), "--targets", str(spec), "--out", str(out)]) == 2
    assert "CONM2 101 not found" in capsys.readouterr().err
    assert not out.exists()
