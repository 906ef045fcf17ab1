"""The ROM about a deformed state (torchrom.trim.reduced), ``torchrom flutter ROM AERO --aoa`` and
``torchrom static --aoa ... --modes N``.

Independent references:
- the typical section's static aeroelasticity (module docstring of test_trim_equilibrium): a
  rigid wing pitching on a spring, θ = q S C_Lα e α / (k − q S C_Lα e), here through the aero
  file's modal incidence load and k = 0 GAF on a one-mode ROM, and with a cubic spring
  k θ + k₃ θ³ = q S C_Lα e (α + θ) solved by Brent's method on the scalar equation;
- the FE route's steady operator (torchrom.trim.operators, the GAFs of unit spline-grid
  displacements): its incidence load projected on the modes is the aero file's;
- finite differences of the ROM's force for the tangent;
- the undeformed flutter speed of torchrom.aero.flutter_speed (another code path) for a ROM
  without nonlinear terms, whose tangent is K1 at every angle; p-k against the state space.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.optimize
import torch

from torchrom.aero.build import build_from_deck
from torchrom.aero.flutter import AeroTable, ModalStructure
from torchrom.aero.flutter_speed import flutter_speed_at_density, flutter_speed_pk_at_density
from torchrom.aero.nastran_flutter import load_deck
from torchrom.cli import main
from torchrom.fe import read_bdf
from torchrom.rom import NonlinearROM
from torchrom.trim.operators import steady_operator
from torchrom.trim.reduced import (
    SteadyModalAero,
    deformed_flutter,
    envelope_ratio,
    rom_equilibria,
    root_finder,
    tangent_structure,
)

from .test_trim_equilibrium import (
    CHORD,
    K_SPRING,
    RHO,
    SEMISPAN,
    _horseshoe_lift_and_centre,
    _rigid_wing_deck,
)

#: the typical section: plunge spring, mass and pitch inertia about the spring axis, the mass
#: centre 0.1 chord behind it (SI)
K_PLUNGE, MASS, I_PITCH, X_CG = 1000.0, 10.0, 1.0, 0.1


def _section_deck(path, plunge: bool):
    """The rigid wing of test_trim_equilibrium with a CONM2 on its spring grid; with
    ``plunge`` also free in T3 on a spring (a two-mode typical section that flutters)."""
    _rigid_wing_deck(path)
    text = path.read_text()
    mass = f"CONM2,40,1,,{MASS},{X_CG},0.0,0.0\n,0.01,0.0,{I_PITCH},0.0,0.0,0.01"
    extra = [mass] + ([f"CELAS2,31,{K_PLUNGE},1,3"] if plunge else [])
    if plunge:
        text = text.replace("SPC1,1,12346,1", "SPC1,1,1246,1")
    path.write_text(text.replace("ENDDATA", "\n".join(extra) + "\nENDDATA"))
    return path


@pytest.fixture(scope="module")
def pitch_section(tmp_path_factory):
    path = _section_deck(tmp_path_factory.mktemp("pitch") / "pitch.bdf", plunge=False)
    fe = read_bdf(path)
    aero = build_from_deck(path, fe, 0.0, 1, n_lags=2, k_list=[0.05, 0.1, 0.2, 0.5])
    return path, fe, aero


def _pitch_of_mode(fe) -> float:
    """The pitch (R5 of the spring grid) of the mass-normalised mode: θ = φ q (the pitch
    inertia about the spring axis is I + m x_cg², φ = ±1/√ of it)."""
    phi = fe.expand(fe.modes(1).shapes[:, 0])[fe.mesh.grid_row()[1], 4]
    assert abs(phi) == pytest.approx(1 / math.sqrt(I_PITCH + MASS * X_CG**2), rel=1e-9)
    return float(phi)


def test_modal_incidence_load_is_the_fe_operators(pitch_section):
    """The aero file's Q_iα against φᵀ Tₛᵀ Q_sα of the FE route's steady operator (the GAFs of
    unit spline-grid displacements): the same lattice reached two ways, to 1e-9."""
    path, fe, aero = pitch_section
    op = steady_operator(fe, load_deck(path, require_flutter=False))
    phi = fe.modes(1).shapes[:, 0]
    assert aero.incidence[0] == pytest.approx(phi @ (op.T_s.T @ op.Q_sa), rel=1e-9)
    assert aero.incidence[0] != 0


def test_rom_equilibrium_is_the_typical_sections_twist(pitch_section):
    """A one-mode ROM (θ = φ q, φ = 1/√I) at three speeds below the divergence: θ against the
    closed form with the horseshoe lattice's C_Lα and x_ac (rel 1e-7: the lattice's two
    solutions agree to ~1e-11, the Newton stops at 1e-10 of the load)."""
    _, fe, aero = pitch_section
    phi = _pitch_of_mode(fe)
    rom = NonlinearROM([[1.0]], [[K_SPRING * phi**2]])
    steady = SteadyModalAero.from_aero(aero, 1)
    cla, x_ac = _horseshoe_lift_and_centre()
    S, e = CHORD * SEMISPAN, 0.4 - x_ac
    q_div = K_SPRING / (S * cla * e)
    V = [math.sqrt(2 * f * q_div / RHO) for f in (0.2, 0.5, 0.9)]
    alpha = 2.0
    eq = rom_equilibria(rom, steady, [alpha], V, RHO)
    assert eq.converged.all()
    for i, v in enumerate(V):
        q = 0.5 * RHO * v**2
        want = q * S * cla * e * math.radians(alpha) / (K_SPRING - q * S * cla * e)
        assert phi * eq.q[0, i, 0] == pytest.approx(want, rel=1e-7)


def test_rom_equilibrium_with_a_cubic_spring_is_the_scalar_root(pitch_section):
    """k θ + k₃ θ³ = q S C_Lα e (α + θ) past the linear divergence speed (the hardening spring
    holds the wing), continued in speed at two angles at once: θ against Brent's root of the
    scalar equation (rel 1e-8)."""
    _, fe, aero = pitch_section
    phi = _pitch_of_mode(fe)
    k3 = 50.0 * K_SPRING  # N m per rad³
    K3 = np.zeros((1, 1, 1, 1))
    K3[0, 0, 0, 0] = k3 * phi**4
    rom = NonlinearROM([[1.0]], [[K_SPRING * phi**2]], K3=K3)
    steady = SteadyModalAero.from_aero(aero, 1)
    cla, x_ac = _horseshoe_lift_and_centre()
    S, e = CHORD * SEMISPAN, 0.4 - x_ac
    q_div = K_SPRING / (S * cla * e)
    V = np.sqrt(2 * np.array([0.5, 1.0, 1.3]) * q_div / RHO)
    eq = rom_equilibria(rom, steady, [1.0, 3.0], V, RHO)
    assert eq.converged.all()
    for a, alpha in enumerate((1.0, 3.0)):
        for i, v in enumerate(V):
            q = 0.5 * RHO * v**2
            c = q * S * cla * e

            def residual(t, c=c, alpha=alpha):
                return K_SPRING * t + k3 * t**3 - c * (math.radians(alpha) + t)
            want = scipy.optimize.brentq(residual, 0.0, 2.0, xtol=1e-15)
            assert phi * eq.q[a, i, 0] == pytest.approx(want, rel=1e-8)


def test_tangent_structure_is_the_finite_difference_of_the_force():
    """K_T(q0) against central differences of the stiffness force (h = 1e-6: error ~h² of
    O(1) cubic terms), D_T(q0) the damping matrix at q0 and α, γ carried."""
    from .rom_fixtures import random_gram_model

    rom, _, _ = random_gram_model(3, seed=4)
    q0 = np.array([0.3, -0.2, 0.1])
    st = tangent_structure(rom, q0, alpha=0.1, gamma=0.01)
    h = 1e-6
    fd = np.column_stack([
        (rom.stiffness_force(torch.as_tensor(q0 + h * e)) -
         rom.stiffness_force(torch.as_tensor(q0 - h * e))).numpy() / (2 * h)
        for e in np.eye(3)])
    np.testing.assert_allclose(st.K, fd, rtol=1e-7, atol=1e-7 * np.abs(fd).max())
    np.testing.assert_allclose(st.D1, rom.damping_matrix(torch.as_tensor(q0)).numpy())
    assert (st.alpha, st.gamma) == (0.1, 0.01)


@pytest.fixture(scope="module")
def flutter_section(tmp_path_factory):
    path = _section_deck(tmp_path_factory.mktemp("flutter") / "section.bdf", plunge=True)
    fe = read_bdf(path)
    aero = build_from_deck(path, fe, 0.0, 2, n_lags=8,
                           k_list=[0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.8, 1.2])
    modes = fe.modes(2)
    w = 2 * np.pi * modes.frequencies_hz
    return aero, NonlinearROM(np.eye(2), np.diag(w**2))


def test_linear_rom_flutters_at_the_undeformed_speed_at_any_angle(flutter_section):
    """Without nonlinear terms the tangent is K1 at every equilibrium: the onset at 0° and 6°
    is torchrom.aero.flutter_speed's undeformed speed and frequency by the same method, p-k on
    the table and the state space on the RFA (within 0.3 %: linear interpolation between
    speeds 1 % apart)."""
    aero, rom = flutter_section
    table = AeroTable.from_gaf(aero.gaf)
    st = ModalStructure(rom.M.numpy(), rom.K1.numpy())
    refs = {"p-k": flutter_speed_pk_at_density(st, table, RHO, 0.0)[0],
            "state-space": flutter_speed_at_density(st, aero.rfa, table, RHO, mach=0.0)}
    assert refs["p-k"].velocity is not None
    V = np.linspace(0.5, 1.3, 81) * refs["p-k"].velocity  # the divergence: 1.47 times it
    eq = rom_equilibria(rom, SteadyModalAero.from_aero(aero, 2), [0.0, 6.0], V, RHO)
    for method, ref in refs.items():
        res = deformed_flutter(rom, eq, root_finder(method, rom, aero))
        for found in res.boundaries:
            onsets = [b for b in found if b.kind == "onset"]
            assert onsets, method
            assert onsets[0].velocity == pytest.approx(ref.velocity, rel=3e-3), method
            assert onsets[0].frequency_hz == pytest.approx(ref.frequency_hz, rel=3e-3), method


def test_envelope_ratio_reads_the_condensed_roms_amplitudes():
    rom = NonlinearROM(np.eye(3), np.eye(3), metadata={"identification": {
        "modal_amplitudes": [0.1, 0.01, 0.5], "nonlinear_modes": 2}})
    r = envelope_ratio(rom, np.array([[0.05, 0.02, 9.0], [0.1, 0.0, 0.0]]))
    np.testing.assert_allclose(r, [2.0, 1.0])
    assert np.isnan(envelope_ratio(NonlinearROM(np.eye(1), np.eye(1)), np.zeros(1)))


def test_flutter_aoa_command_reports_onsets_in_json(flutter_section, tmp_path):
    """The CLI on files written by the library: the onset of the p-k sweep in the JSON with
    the tip output and its units; a bad combination is one line, nothing written."""
    aero, rom = flutter_section
    rom = rom.replace(outputs={"tip": [0.5, -0.25]})
    rom.save(tmp_path / "rom.npz")
    aero.save(tmp_path / "aero.npz")
    out = tmp_path / "f.json"
    args = ["flutter", str(tmp_path / "rom.npz"), str(tmp_path / "aero.npz"), "--aoa", "0", "4",
            "--density", str(RHO), "--alpha", "0", "--gamma", "0", "--method", "pk",
            "--velocities", *map(str, np.linspace(2, 14, 49)), "--json", str(out)]
    assert main(args) == 0
    res = json.loads(out.read_text())
    onsets = [b for b in res["boundaries"] if b["kind"] == "onset"]
    assert {b["aoa_deg"] for b in onsets} == {0.0, 4.0}
    assert res["units"]["speed"] == "m/s" and res["tip"]["output"] == "tip"
    eq = [e for e in res["equilibria"] if e["aoa_deg"] == 4.0 and e["converged"]]
    assert eq[-1]["tip_deflection"] != 0.0 and "p-k" in eq[-1]


@pytest.mark.parametrize("extra, message", [
    (["--velocities", "5", "6"], "--velocities: only with --aoa"),
    (["--aoa", "5"], "--density: --aoa needs one air density"),
    (["--aoa", "5", "--density", "1.2", "--velocities", "9", "6"],
     "--velocities: expected ascending speeds"),
    (["--aoa", "5", "--density", "1.2", "--tip-output", "nose"], "--tip-output: no output 'nose'"),
    (["--aoa", "5", "--density", "1.2", "--at", "0"], "--at: not with --aoa"),
])
def test_flutter_aoa_bad_input_is_one_line(flutter_section, tmp_path, extra, message):
    """The real CLI in a subprocess: one line naming the option, exit 2, no JSON written."""
    import subprocess
    import sys

    aero, rom = flutter_section
    rom.replace(outputs={"tip": [0.5, -0.25]}).save(tmp_path / "rom.npz")
    aero.save(tmp_path / "aero.npz")
    out = tmp_path / "f.json"
    r = subprocess.run([sys.executable, "-m", "torchrom", "flutter", str(tmp_path / "rom.npz"),
                        str(tmp_path / "aero.npz"), *extra, "--json", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert message in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not out.exists()


def test_aero_file_without_incidence_is_refused(flutter_section, tmp_path):
    """An aero file written before the incidence load: --aoa names the file and the remedy."""
    from dataclasses import replace

    from torchrom.errors import InputError

    aero, rom = flutter_section
    with pytest.raises(InputError, match="old.npz: no steady incidence load"):
        SteadyModalAero.from_aero(replace(aero, incidence=None), 2, "old.npz")


def _hardening_section(aero, rom):
    """The typical section's ROM with a cubic hardening of both modes (an LCO past flutter)."""
    K3 = np.zeros((2, 2, 2, 2))
    K3[0, 0, 0, 0], K3[1, 1, 1, 1] = 500.0, 500.0
    return rom.replace(K3=K3, outputs={"q1": [1.0, 0.0], "q2": [0.0, 1.0]})


def test_lco_about_the_equilibrium_by_harmonic_balance_and_time_marching(flutter_section):
    """Past the flutter speed at 0° and 0.5° (at 3° the hardening about the deflected state
    has moved the flutter past 11 m/s): the harmonic balance orbit (its mean the 0th
    harmonic) against a time integration started at the static equilibrium plus a small
    disturbance (the second method): amplitude within 1 % and mean within 1 % of the static
    deflection (Newmark at 200 steps a period, measured over its converged window); the
    static state itself is the ROM equilibrium of torchrom.trim.reduced (1e-9); the linear
    root about it decides decay or flutter."""
    from torchrom.periodic import HarmonicBalanceMethod
    from torchrom.sim import LCOCriteria, Newmark
    from torchrom.sim.aeroelastic import aeroelastic_system_at
    from torchrom.sim.newmark import HistoryRequest
    from torchrom.sim.system import static_equilibrium

    aero, rom = flutter_section
    rom = _hardening_section(aero, rom)
    V = 11.0  # flutter at 10.04 m/s
    ae = aeroelastic_system_at(rom, aero, [V, V, 8.0], RHO, aoa_deg=[0.0, 0.5, 0.5])
    q_eq = static_equilibrium(ae.system).numpy()
    ref = rom_equilibria(rom, SteadyModalAero.from_aero(aero, 2), [0.5], [8.0, V], RHO)
    np.testing.assert_allclose(q_eq[1], ref.q[0, 1], rtol=1e-9)
    np.testing.assert_allclose(q_eq[2], ref.q[0, 0], rtol=1e-9)
    assert np.all(q_eq[0] == 0)
    hb = HarmonicBalanceMethod(stability=False).run(ae.system, outputs=["q1", "q2"],
                                                   lco=LCOCriteria(max_amplitude=10.0))
    assert list(hb.status) == ["lco", "lco", "decay"]
    assert hb.extra["mean_q1"][2] == pytest.approx(q_eq[2, 0], rel=1e-9)
    lco = LCOCriteria(max_amplitude=10.0, rtol=1e-4)
    nm = Newmark(dt=1.0 / (200 * hb.frequency_hz[1])).run(
        ae.system.select([1]), q_eq[1] + np.array([0.01, 0.0]), t_end=400.0,
        outputs=["q1", "q2"], lco=lco, history=HistoryRequest((0,), every=1))
    assert nm.status[0] == "lco"
    np.testing.assert_allclose(nm.amplitude[0], hb.amplitude[1], rtol=1e-2)
    # the time history's mean over its last ten periods against the 0th harmonic
    h = nm.histories[0]
    last = h.t >= h.t[-1] - 10.0 / hb.frequency_hz[1]
    for j, name in enumerate(("q1", "q2")):
        assert hb.extra[f"mean_{name}"][1] == pytest.approx(h.y[last, j].mean(),
                                                            abs=1e-2 * abs(q_eq[1, j]))
    # the orbit's mean is not the static state: the quadratic response of the cubic terms
    assert abs(hb.extra["mean_q1"][1] - q_eq[1, 0]) > 1e-3 * abs(q_eq[1, 0])


SWEEP = """
title = "typical section at a root angle of attack"
method = "hb"
[model]
rom = "rom.npz"
aero = "aero.npz"
[initial]
q0 = 0.01
[lco]
outputs = ["q1", "q2"]
max_amplitude = 10.0
[cases]
combine = "product"
density = 1.225
speed = [10.5, 11.0]
aoa_deg = [0.0, 0.5]
alpha = 0.0
gamma = 0.0
"""


def test_sweep_takes_the_root_angle_as_a_case_parameter(flutter_section, tmp_path):
    """`torchrom sweep` with aoa_deg among the cases: every row certified, the angle, the
    orbit's mean and amplitude of each output in the table; the mean at 0° is the orbit's
    own (zero static state, within the quadratic response) and at 0.5° near the static
    deflection of torchrom.trim.reduced (within the orbit's amplitude). A bad angle is one
    line naming it, in a subprocess."""
    import subprocess
    import sys

    import pandas as pd

    aero, rom = flutter_section
    _hardening_section(aero, rom).save(tmp_path / "rom.npz")
    aero.save(tmp_path / "aero.npz")
    cfg = tmp_path / "aoa.toml"
    cfg.write_text(SWEEP)
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "out")]) == 0
    t = pd.read_parquet(tmp_path / "out" / "results.parquet").sort_values(["aoa_deg", "speed"])
    assert list(t["status"]) == ["lco"] * 4 and t["certified"].all()
    assert {"mean_q1", "mean_q2", "amplitude_q1", "amplitude_q2", "aoa_deg"} <= set(t.columns)
    eq = rom_equilibria(_hardening_section(aero, rom), SteadyModalAero.from_aero(aero, 2),
                        [0.5], [10.5, 11.0], RHO)
    at = t[t["aoa_deg"] == 0.5]
    np.testing.assert_allclose(at["mean_q1"], eq.q[0, :, 0], atol=at["amplitude_q1"].max())
    assert (at["mean_q1"] - eq.q[0, :, 0]).abs().max() > 0
    bad = cfg.with_name("bad.toml")
    bad.write_text(SWEEP.replace("aoa_deg = [0.0, 0.5]", "aoa_deg = [0.0, 45.0]"))
    r = subprocess.run([sys.executable, "-m", "torchrom", "sweep", str(bad), "--out",
                        str(tmp_path / "bad")], capture_output=True, text=True)
    assert r.returncode == 2 and "aoa_deg" in r.stderr and "45" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "bad").exists()


@pytest.mark.parametrize("kind", ["--linear", "--nonlinear"])
def test_static_modes_about_each_equilibrium(tmp_path, kind):
    """`torchrom static --aoa --velocity --modes 1` on the pitching section: the pitch mode of
    a linear spring about any twist is √(k / (I + m x²)) / 2π (rel 1e-8; the tangent of the
    spring is constant, the rigid arms carry no load of their own)."""
    deck = _section_deck(tmp_path / "pitch.bdf", plunge=False)
    out = tmp_path / "s.json"
    assert main(["static", str(deck), "--aoa", "2", "--velocity", "3", "6", kind, "--modes",
                 "1", "--json", str(out)]) == 0
    want = math.sqrt(K_SPRING / (I_PITCH + MASS * X_CG**2)) / (2 * math.pi)
    speeds = json.loads(out.read_text())["speeds"]
    assert len(speeds) == 2
    for s in speeds:
        assert s["natural_hz"][0] == pytest.approx(want, rel=1e-8)


def test_flutter_aoa_deck_form_is_the_undeformed_flutter_of_a_linear_section(tmp_path):
    """`torchrom flutter DECK --aoa 0 0.5 --velocities ...` (the FE route: nonlinear
    equilibrium, p-k on its tangent's modes) on the pitch-plunge section of springs and rigid
    arms, whose tangent does not change with the twist: the onset at both angles is
    flutter_speed's p-k speed of its modes with the same GAF table (within 0.5 %: the speed
    grid's interpolation; the GAFs reach the modes through the spline DOFs there, directly
    here)."""
    from torchrom.aero.nastran_flutter import NASTRAN_KERNEL
    from torchrom.trim.flutter import DEFAULT_K

    deck = _section_deck(tmp_path / "section.bdf", plunge=True)
    fe = read_bdf(deck)
    # the route's GAFs: the deck has no MKAERO, so trim.flutter's k list, Nastran's kernel
    aero = build_from_deck(deck, fe, 0.0, 2, n_lags=8, k_list=DEFAULT_K, kernel=NASTRAN_KERNEL)
    w = 2 * np.pi * fe.modes(2).frequencies_hz
    ref, _ = flutter_speed_pk_at_density(ModalStructure(np.eye(2), np.diag(w**2)),
                                         AeroTable.from_gaf(aero.gaf), RHO, 0.0)
    out = tmp_path / "f.json"
    speeds = np.linspace(0.8, 1.2, 21) * ref.velocity
    assert main(["flutter", str(deck), "--aoa", "0", "0.5", "--density", str(RHO),
                 "--velocities", *map(str, speeds), "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["route"].startswith("FE nonlinear equilibrium")
    for aoa in (0.0, 0.5):
        onsets = [b for b in res["boundaries"] if b["aoa_deg"] == aoa and b["kind"] == "onset"]
        assert onsets and onsets[0]["velocity"] == pytest.approx(ref.velocity, rel=5e-3)


def test_flutter_aoa_deck_form_with_a_linear_skin(tmp_path):
    """`--linear-skin PID`: the exact condensation route on the deck's modes of the model
    without those shells (here a CQUAD4 riding the rigid wing: no strain, so the skeleton's
    tangent is the whole model's). At 0° the condensed tangent is K1 and the onset the
    undeformed p-k speed of the same GAF table (within 0.5 %: the speed grid); an unknown
    PSHELL is refused in one line."""
    from torchrom.aero.nastran_flutter import NASTRAN_KERNEL

    deck = _section_deck(tmp_path / "skin.bdf", plunge=True)
    deck.write_text(deck.read_text().replace("ENDDATA", "MAT1,51,7e10,,0.33,2700.0\n"
                                             "PSHELL,50,51,1e-4,51,,51\n"
                                             "CQUAD4,60,50,11,12,13,14\nENDDATA"))
    fe = read_bdf(deck)
    aero = build_from_deck(deck, fe, 0.0, 2, kernel=NASTRAN_KERNEL)
    w = 2 * np.pi * fe.modes(2).frequencies_hz
    ref, _ = flutter_speed_pk_at_density(ModalStructure(np.eye(2), np.diag(w**2)),
                                         AeroTable.from_gaf(aero.gaf), RHO, 0.0)
    out = tmp_path / "f.json"
    speeds = np.linspace(0.8, 1.2, 21) * ref.velocity
    assert main(["flutter", str(deck), "--aoa", "0", "--density", str(RHO), "--linear-skin",
                 "50", "--velocities", *map(str, speeds), "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["route"].startswith("FE exact condensation")
    (onset,) = [b for b in res["boundaries"] if b["kind"] == "onset"]
    assert onset["velocity"] == pytest.approx(ref.velocity, rel=5e-3)
    assert main(["flutter", str(deck), "--aoa", "0", "--density", str(RHO), "--linear-skin",
                 "77", "--velocities", "5", "6", "--json", str(tmp_path / "g.json")]) == 2
    assert not (tmp_path / "g.json").exists()


def test_rom_about_a_deformed_state_reaches_the_closed_forms_equilibria():
    """A ROM about a deformed state (identify ``about``, on test_identify_condensation's
    closed-form bending-membrane model) continued from its reference to other angles and
    speeds, up and down: q_ref + x is the closed form's equilibrium at each (fsolve; 1e-7: the
    reference's FE solves stop at 1e-10 of their load and the membrane's 1e6 stiffness
    multiplies the rest), and the CLI's tip reading adds the reference's deflection."""
    from torchrom.identify.build import IdentifyOptions, identify

    from .test_identify_condensation import (
        ABOUT_INC,
        ABOUT_Q0,
        _about_law,
        _backend,
        _closed_form_equilibrium,
    )

    law = _about_law(0.4, 0.3)                      # V_ref = √(2 · 0.4 / 1) at density 1
    res = identify(_backend(), IdentifyOptions(n_linear=2, n_dual=0, stiffness="condensed",
                                               about=law, levels=2))
    rom, Phi = res.rom, res.basis.Phi[:2]
    aero = SteadyModalAero(ABOUT_Q0, ABOUT_INC)
    angles = np.array([10.0, 17.19, 25.0])        # deg; the reference's is 0.3 rad = 17.19°
    speeds = np.array([0.5, 0.7, 0.8944, 1.0, 1.1])
    eq = rom_equilibria(rom, aero, angles, speeds, 1.0)
    assert eq.converged.all(), eq.notes
    for a, aoa in enumerate(angles):
        for i, v in enumerate(speeds):
            want = _closed_form_equilibrium(0.5 * v**2, math.radians(aoa), Phi)
            np.testing.assert_allclose(eq.q[a, i] + rom.reference.q, want, atol=1e-7)


def _about(rom, q_ref):
    """The exact expansion of a ROM whose force is K1 q + K3(q,q,q) (no K2) about q_ref: a
    cubic about any point, so the ROM about a deformed state is exactly it there."""
    from torchrom.rom.reference import ReferenceState

    K1, K3 = rom.K1.numpy(), rom.K3.numpy()
    K1r = K1 + 3 * np.einsum("mjlp,l,p->mj", K3, q_ref, q_ref)
    K2r = 3 * np.einsum("mjlp,p->mjl", K3, q_ref)
    f_ref = K1 @ q_ref + np.einsum("mjlp,j,l,p->m", K3, q_ref, q_ref, q_ref)
    # its basis functions stay the deck's modes (their frequencies, which the aero file checks)
    ref = ReferenceState(q_ref, f_ref, {"aoa_deg": 0.5, "velocity": 8.0, "density": RHO})
    return NonlinearROM(rom.M, K1r, K2r, K3, rom.D1, outputs=rom.outputs, symmetrize=True,
                        frequencies_hz=rom.frequencies_hz, reference=ref)


def test_a_rom_about_a_deformed_state_gives_the_same_lco_and_mean(flutter_section, tmp_path):
    """The hardening section and its exact expansion about its 8 m/s, 0.5° equilibrium (a ROM
    about a deformed state, kept in and read back from rom.npz): the same static states
    (q_ref + x), and by harmonic balance past flutter the same LCO amplitude and the same
    mean (the HB table adds C q_ref to the 0th harmonic), within the orbits' own 1e-8; and
    its equilibria continued from the reference equal the original ROM's (1e-9)."""
    from torchrom.periodic import HarmonicBalanceMethod
    from torchrom.sim import LCOCriteria
    from torchrom.sim.aeroelastic import aeroelastic_system_at
    from torchrom.sim.system import static_equilibrium

    aero, rom = flutter_section
    rom = _hardening_section(aero, rom)
    steady = SteadyModalAero.from_aero(aero, 2)
    q_ref = rom_equilibria(rom, steady, [0.5], [8.0], RHO).q[0, 0]
    about = _about(rom, q_ref)
    about.save(tmp_path / "about.npz")
    about = NonlinearROM.load(tmp_path / "about.npz")
    speeds = [6.0, 8.0, 9.5, 11.0]
    plain, ref = (rom_equilibria(r, steady, [0.0, 0.5, 1.0], speeds, RHO) for r in (rom, about))
    assert ref.converged.all()
    np.testing.assert_allclose(ref.q + q_ref, plain.q, atol=1e-9 * np.abs(plain.q).max())
    runs = []
    for r in (rom, about):
        ae = aeroelastic_system_at(r, aero, [11.0, 11.0], RHO, aoa_deg=[0.5, 1.0])
        x = static_equilibrium(ae.system).numpy()
        hb = HarmonicBalanceMethod(stability=False).run(ae.system, outputs=["q1", "q2"],
                                                       lco=LCOCriteria(max_amplitude=10.0))
        runs.append((x, hb))
    (x0, hb0), (x1, hb1) = runs
    np.testing.assert_allclose(x1 + q_ref, x0, atol=1e-9 * np.abs(x0).max())
    assert list(hb0.status) == list(hb1.status) == ["lco", "lco"]
    np.testing.assert_allclose(hb1.amplitude, hb0.amplitude, rtol=1e-8)
    for name in ("mean_q1", "mean_q2"):
        np.testing.assert_allclose(hb1.extra[name], hb0.extra[name],
                                   atol=1e-8 * np.abs(hb0.extra[name]).max())


def test_identify_about_a_state_through_the_cli(tmp_path):
    """`torchrom identify DECK --stiffness condensed --about-*` through the real CLI (a
    subprocess) on the pitch-plunge section of linear springs: the reference is the linear
    static aeroelastic solution (K + q∞ Q(0)) q = −q∞ α Q_α of the aero file's operators (to
    1e-8 relative: the FE solves stop at 1e-9 of their load), K1 the modal stiffness (the
    springs' tangent does not change), K2 and K3 zero to rounding (1e-8 of K1 over the
    solves' reach), and the command prints the potential fit's misfits (the line once raised
    KeyError after writing the ROM)."""
    import subprocess
    import sys

    deck = _section_deck(tmp_path / "section.bdf", plunge=True)

    def cli(*argv):
        run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv)],
                             capture_output=True, text=True, cwd=tmp_path)
        assert run.returncode == 0, run.stderr
        return run.stdout

    cli("aero", deck, "--mach", "0", "--modes", "2", "--k", "0.05", "0.1", "0.2", "0.5",
        "--out", "aero.npz")
    speed = 5.0  # m/s: q∞ a ninth of the section's divergence pressure (14.8 m/s)
    out = cli("identify", deck, "--linear", "2", "--dual", "0", "--stiffness", "condensed",
              "--levels", "1", "--about-aero", "aero.npz", "--about-aoa", "2",
              "--about-velocity", speed, "--about-density", RHO, "--out", "rom.npz")
    assert "the quartic potential's misfit" in out and "tangent misfit" in out
    rom = NonlinearROM.load(tmp_path / "rom.npz")
    from torchrom.aero.files import load_aero

    steady = SteadyModalAero.from_aero(load_aero(tmp_path / "aero.npz"), 2)
    dyn = 0.5 * RHO * speed**2
    K = rom.K1.numpy()
    want = np.linalg.solve(K + dyn * steady.Q0, -dyn * math.radians(2) * steady.incidence)
    np.testing.assert_allclose(rom.reference.q, want, rtol=1e-8, atol=1e-12)
    scale = np.abs(K).max() / np.abs(want).max()
    assert np.abs(rom.K2.numpy()).max() < 1e-8 * scale
    assert np.abs(rom.K3.numpy()).max() < 1e-8 * scale / np.abs(want).max()
