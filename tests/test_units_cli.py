"""Units end to end through the command line (torchrom.units, issue 35 item 1): one wing
written in four unit systems flutters at one physical point, and every refusal (files of
different systems, an unknown --units, --units against the deck's cards, cards that disagree)
is one line from the real CLI in a subprocess."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from torchrom.aero.dlm import GAF
from torchrom.aero.files import AeroData, save_aero
from torchrom.aero.rfa import fit_minimum_state
from torchrom.cli import main
from torchrom.rom import NonlinearROM
from torchrom.units import SYSTEMS

from .cli_forkserver import ForkServer
from .test_aero_flutter import _altitude_case
from .test_bad_input import DECK
from .test_fe_deck_units import _bah_without_flutter_502


def _write_wing(folder, system: str, rom_units: str | None = None):
    """The H&P section of :func:`_altitude_case` (ft-slug-s, flutter near 10,000 ft at Mach
    0.5) converted exactly into ``system``: with lengths L (m per unit) and masses Mk (kg per
    unit) relative to ft and slug, M and K scale as mass x length^2 (the modal coordinates are
    dimensionless), the GAFs and the RFA's A0..A2 and D as length^3 (q Q has K's units, q =
    mass/(length s^2)), the semichord as length; k, the lag roots and E are dimensionless."""
    _, st, gaf, mach = _altitude_case()
    rfa = fit_minimum_state(gaf, n_lags=8)  # fitted once: the same RFA in every system
    ft, s = SYSTEMS["ft-slug-s"], SYSTEMS[system]
    L, Mk = ft.metre / s.metre, ft.kilogram / s.kilogram
    gaf = GAF(gaf.mach, gaf.semichord * L, gaf.k, gaf.Q * L**3, gaf.kernel)
    rfa = dataclasses.replace(rfa, A0=rfa.A0 * L**3, A1=rfa.A1 * L**3, A2=rfa.A2 * L**3,
                              D=rfa.D * L**3, semichord=rfa.semichord * L)
    NonlinearROM(st.M * Mk * L**2, st.K * Mk * L**2,
                 metadata={"unit_system": rom_units or system}).save(folder / "rom.npz")
    save_aero(AeroData(gaf, rfa, {"unit_system": system}), folder / "aero.npz")
    return mach


def _flutter(folder, system: str, *extra) -> dict:
    s = SYSTEMS[system]
    top = 20000.0 * 0.3048 / s.altitude_metre  # 20,000 ft in the system's altitude unit
    rc = main(["flutter", str(folder / "rom.npz"), str(folder / "aero.npz"), "--alpha", "0",
               "--gamma", "0", "--alt-range", "0", str(top), "--json", str(folder / "f.json"),
               *extra])
    assert rc == 0
    return json.loads((folder / "f.json").read_text())


def test_one_wing_in_four_systems_flutters_at_one_physical_point(tmp_path, capsys):
    """Matched point (p-k and state space) of the same wing in si, ft-slug-s, in-lbf-s and
    mm-t-s: the altitude in m (si, mm-t-s) is the ft one x 0.3048, the speed the ft/s one x
    the length ratio, the frequency unchanged. Tolerance 1e-5 relative: the altitude's Brent
    search stops at 1e-3 of the altitude unit (1e-7 of ~10,000) and the p-k iteration at
    1e-7; the atmosphere converts exactly. Every printed header carries the system's units."""
    out = {}
    for system in SYSTEMS:
        folder = tmp_path / system
        folder.mkdir()
        _write_wing(folder, system)
        out[system] = _flutter(folder, system)
        text = capsys.readouterr().out
        u = SYSTEMS[system].labels()
        assert f"altitude {u['altitude']}" in text and f"V {u['speed']}" in text
        assert f"q {u['dynamic_pressure']}" in text and f"units {system}" in text
        assert out[system]["units"] == u
    ref = {r["method"]: r for r in out["ft-slug-s"]["flutter"]}
    assert ref["p-k"]["altitude"] == pytest.approx(10000.0, abs=5.0)
    for system, res in out.items():
        s = SYSTEMS[system]
        for r in res["flutter"]:
            f = ref[r["method"]]
            assert r["altitude"] * s.altitude_metre == pytest.approx(f["altitude"] * 0.3048,
                                                                     rel=1e-5)
            assert r["velocity"] * s.metre == pytest.approx(f["velocity"] * 0.3048, rel=1e-5)
            assert r["frequency_hz"] == pytest.approx(f["frequency_hz"], rel=1e-5)
            assert r["density"] * s.density_si == pytest.approx(
                f["density"] * SYSTEMS["ft-slug-s"].density_si, rel=1e-5)
            assert r["dynamic_pressure"] * s.pressure_si == pytest.approx(
                f["dynamic_pressure"] * SYSTEMS["ft-slug-s"].pressure_si, rel=2e-5)


def test_flutter_speed_at_a_density_equals_the_matched_point(tmp_path):
    """--density at the matched point's own density (si): the p-k flutter speed there is the
    matched point's speed (the same root crossing zero at the same V and rho; 1e-4: the
    matched point is solved on the altitude axis to 1e-3 m, 3e-6 of the speed through
    V = M a(h) and rho(h), and the speed sweep's crossing by Brent to its own tolerance)."""
    _write_wing(tmp_path, "si")
    matched = {r["method"]: r for r in _flutter(tmp_path, "si")["flutter"]}["p-k"]
    res = _flutter(tmp_path, "si", "--density", str(matched["density"]), "--method", "pk",
                   "--force")
    (r,) = res["flutter"]
    assert r["altitude"] is None and res["units"]["density"] == "kg/m^3"
    assert r["velocity"] == pytest.approx(matched["velocity"], rel=1e-4)
    assert r["frequency_hz"] == pytest.approx(matched["frequency_hz"], rel=1e-4)


def test_files_without_a_system_assume_ft_slug_s_and_say_so(tmp_path, capsys):
    """Files written before the field (no unit_system, no units) are read as ft-slug-s, as
    before, and the output says so; --units declares another."""
    _, st, gaf, _ = _altitude_case()
    NonlinearROM(st.M, st.K).save(tmp_path / "rom.npz")
    save_aero(AeroData(gaf, fit_minimum_state(gaf, n_lags=8)), tmp_path / "aero.npz")
    res = _flutter(tmp_path, "ft-slug-s", "--method", "pk")
    assert "assumed ft-slug-s" in capsys.readouterr().out
    assert res["units"]["system"] == "ft-slug-s"
    assert res["flutter"][0]["altitude"] == pytest.approx(10000.0, abs=5.0)


#: a deck of test_bad_input with an SI AERO card, and one whose cards disagree
SI_DECK = DECK.replace("ENDDATA", "AERO,,,1.0,1.225\nENDDATA")
CONFLICT_DECK = DECK.replace("ENDDATA", "AERO,,,1.0,1.225\nPARAM,WTMASS,0.00259\nENDDATA")

#: name -> (argv, the words of the one-line refusal)
REFUSALS = {
    "files of different systems": (["flutter", "si/rom.npz", "ft/aero.npz"],
                                   "files of different unit systems"),
    "rom in si, aero in ft": (["flutter", "mixed/rom.npz", "mixed/aero.npz"],
                              "mixed/rom.npz is in si but mixed/aero.npz in ft-slug-s"),
    "unknown --units": (["flutter", "si/rom.npz", "si/aero.npz", "--units", "imperial"],
                        "--units: expected one of si, ft-slug-s, in-lbf-s, mm-t-s"),
    "--units against the files": (["flutter", "si/rom.npz", "si/aero.npz", "--units",
                                   "in-lbf-s"], "--units in-lbf-s: si/rom.npz records si"),
    "--units against the deck": (["identify", "si.bdf", "--out", "OUT/rom.npz", "--linear",
                                  "2", "--dual", "0", "--units", "in-lbf-s"],
                                 "--units in-lbf-s: the deck's AERO RHOREF 1.225 says si"),
    "cards that disagree": (["identify", "conflict.bdf", "--out", "OUT/rom.npz", "--linear",
                             "2", "--dual", "0"],
                            "AERO RHOREF 1.225 says si but PARAM WTMASS 0.00259 says in-lbf-s"),
    "aero: unknown --units": (["aero", "si.bdf", "--mach", "0.5", "--out", "OUT/aero.npz",
                               "--units", "furlong"], "--units"),
    "aero: Goland planform on an si deck": (["aero", "si.bdf", "--mach", "0.5", "--out",
                                             "OUT/aero.npz", "--planform", "goland"],
                                            "--planform goland: the built-in planform is in ft"),
    "deck flutter --density": (["flutter", "si.bdf", "--density", "1.2"], "--density"),
    "deck flutter --units": (["flutter", "si.bdf", "--units", "si"], "--units"),
    "goland flutter --units si": (["flutter", "goland", "--units", "si"], "--units"),
    # bah_plane without FLUTTER 502 (tests/test_fe_deck_units.py): FLFACT 3 in in/s beside
    # RHOREF 1.225 kg/m^3
    "FLFACT velocities against the deck's RHOREF": (
        ["identify", "bah_flfact/bah_plane.bdf", "--out", "OUT/rom.npz", "--linear", "2",
         "--dual", "0"], "bah_plane.bdf: units: FLFACT 3 velocities 4774.3..5542.34 are in/s "
                         "(in-lbf-s) but AERO RHOREF 1.225 says si"),
    "aero: FLFACT velocities against the deck's RHOREF": (
        ["aero", "bah_flfact/bah_plane.bdf", "--mach", "0", "--out", "OUT/aero.npz"],
        "FLFACT 3 velocities 4774.3..5542.34 are in/s (in-lbf-s) but AERO RHOREF 1.225 says "
        "si; correct the FLFACT or declare the deck's system with --units"),
    "sweep: ROM and aero of different systems": (
        ["sweep", "mixed.toml", "--out", "OUT"],
        "mixed.toml: [model]: rom.npz is in si but aero.npz in ft-slug-s"),
    "sweep: a density of another system": (
        ["sweep", "slug_density.toml", "--out", "OUT"],
        "[cases] density: 0.0023769 (case 0) is no air density in si"),
    "sweep: unknown [model] units": (["sweep", "bad_units.toml", "--out", "OUT"],
                                     "[model] units: expected one of si, ft-slug-s"),
    # one altitude unit per run (issue 46 item 6)
    "unknown --altitude-unit": (["flutter", "si/rom.npz", "si/aero.npz", "--altitude-unit",
                                 "km"], "--altitude-unit: invalid choice: 'km'"),
    "deck flutter --altitude-unit": (["flutter", "si.bdf", "--altitude-unit", "m"],
                                     "--altitude-unit: for the matched point"),
    "sweep: altitudes in ft, altitude_unit m": (
        ["sweep", "alt_mixed.toml", "--out", "OUT"],
        "[cases] altitude_ft: altitudes in ft, but [aeroelastic] altitude_unit = 'm' names m: "
        "one altitude unit per run"),
    "sweep: unknown [aeroelastic] altitude_unit": (
        ["sweep", "alt_unknown.toml", "--out", "OUT"],
        "[aeroelastic] altitude_unit: expected one of m, ft, got 'km'"),
}

#: a wind-tunnel sweep of the test wing (FOLDER, DENSITY and UNITS filled in)
TUNNEL = """title = "tunnel"
[model]
rom = "FOLDER/rom.npz"
aero = "FOLDER/aero.npz"
UNITS
[initial]
q0 = 0.01
[integrator]
dt = 0.01
t_end = 1.0
[cases]
density = DENSITY
speed = 100.0
[plot]
x = "speed"
"""


@pytest.fixture(scope="module")
def refusal_folder(tmp_path_factory):
    import os

    d = tmp_path_factory.mktemp("units")
    for name, system, rom_units in (("si", "si", None), ("ft", "ft-slug-s", None),
                                    ("mixed", "ft-slug-s", "si")):
        (d / name).mkdir()
        _write_wing(d / name, system, rom_units)
    for name, folder, density, units in (("mixed", "mixed", "1.225", ""),
                                         ("slug_density", "si", "0.0023769", ""),
                                         ("bad_units", "si", "1.225", 'units = "imperial"')):
        (d / f"{name}.toml").write_text(TUNNEL.replace("FOLDER", folder)
                                        .replace("DENSITY", density).replace("UNITS", units))
    for name, unit in (("alt_mixed", "m"), ("alt_unknown", "km")):
        (d / f"{name}.toml").write_text(
            TUNNEL.replace("FOLDER", "si").replace("UNITS", "")
            .replace("density = DENSITY", "altitude_ft = 0.0")
            .replace("[initial]", f'[aeroelastic]\naltitude_unit = "{unit}"\n[initial]'))
    (d / "si.bdf").write_text(SI_DECK)
    (d / "conflict.bdf").write_text(CONFLICT_DECK)
    (d / "bah_flfact").mkdir()
    _bah_without_flutter_502(d / "bah_flfact")
    server = ForkServer({**os.environ, "TORCHROM_CACHE": str(d / "cache")})
    yield d, server
    server.close()


@pytest.mark.parametrize("name", sorted(REFUSALS))
def test_refused_with_one_line(name, refusal_folder, tmp_path):
    folder, server = refusal_folder
    argv, words = REFUSALS[name]
    argv = [a.replace("OUT", str(tmp_path / "out")) for a in argv]
    rc, _out, err = server.run(argv, folder)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err and rc == 2, (rc, err)
    assert len(lines) == 1 and words in lines[0], err
    assert not (tmp_path / "out").exists()


def test_declared_units_decide_for_a_deck_whose_cards_disagree(refusal_folder, tmp_path):
    """--units settles cards that disagree: the ROM records the declared system."""
    folder, server = refusal_folder
    rc, out, err = server.run(["identify", "conflict.bdf", "--out", str(tmp_path / "rom.npz"),
                               "--linear", "2", "--dual", "0", "--units", "si"], folder)
    assert rc == 0, err
    assert "units: si (--units (the deck's cards disagree))" in out
    from torchrom.units import recorded_units

    assert recorded_units(NonlinearROM.load(tmp_path / "rom.npz").metadata).name == "si"
    assert np.isfinite(np.asarray(NonlinearROM.load(tmp_path / "rom.npz").K1)).all()


def test_in_lbf_s_deck_chain_matches_the_deck(tmp_path):
    """pt145 (in-lbf-s: AERO RHOREF 1.145e-7 lbf s^2/in^4) through identify -> aero ->
    flutter --density (its FLFACT density ratio 0.967 x RHOREF, Mach 0.45): the ROM's p-k
    flutter speed within 2 % of the deck's own KE answer (``torchrom flutter pt145.bdf``,
    6032.1 in/s, 139.73 Hz, measured) and of the f06's KE crossing (POINT 2 between k =
    0.1429, g = +0.0109 at 6112.9 in/s, and k = 0.1667, g = -0.0172 at 5831.8 in/s: 6004 in/s
    by linear interpolation in g). Measured: 6055.8 in/s, 138.99 Hz (+0.39 % and -0.53 %
    against the deck, +0.9 % against the f06); printed in in/s and lbf/in^2."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    deck = Path(__file__).parent / "decks" / "pynastran_pt145" / "pt145.bdf"
    shutil.copy(deck, tmp_path / "pt145.bdf")

    def torchrom(*argv):
        run = subprocess.run([sys.executable, "-m", "torchrom", *argv], cwd=tmp_path,
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
        return run.stdout

    assert "units: in-lbf-s (AERO RHOREF 1.145e-07)" in torchrom(
        "identify", "pt145.bdf", "--linear", "3", "--dual", "0", "--out", "rom.npz")
    torchrom("aero", "pt145.bdf", "--mach", "0.45", "--modes", "3", "--kernel", "parabolic",
             "--out", "aero.npz")
    out = torchrom("flutter", "rom.npz", "aero.npz", "--density", str(0.967 * 1.145e-7),
                   "--method", "pk", "--alpha", "0", "--gamma", "0", "--json", "f.json")
    assert "V in/s" in out and "q lbf/in^2" in out and "density lbf s^2/in^4" in out
    (pk,) = json.loads((tmp_path / "f.json").read_text())["flutter"]
    assert pk["velocity"] == pytest.approx(6032.1, rel=0.02)
    assert pk["frequency_hz"] == pytest.approx(139.73, rel=0.02)
    g1, v1, g2, v2 = 0.010861521, 6112.9079, -0.017230888, 5831.7574
    assert pk["velocity"] == pytest.approx(v1 - g1 * (v1 - v2) / (g1 - g2), rel=0.02)


def test_the_same_matched_point_in_m_and_in_ft(tmp_path, capsys):
    """One altitude unit per run (issue 46 item 6): the SI wing's matched point with its own
    altitudes (m) and with --altitude-unit ft (--alt-range given in ft) is one physical
    point: altitude_ft x 0.3048 = altitude_m, and the same speed, density and frequency.
    Tolerance 1e-5 relative, as above (the Brent search stops at 1e-3 of the altitude unit;
    the conversion is exact). The table header, the JSON's units and every record name the
    run's altitude unit, and --at is read in it."""
    _write_wing(tmp_path, "si")
    runs = {}
    for unit, top in (("m", 20000.0 * 0.3048), ("ft", 20000.0)):
        rc = main(["flutter", str(tmp_path / "rom.npz"), str(tmp_path / "aero.npz"), "--alpha",
                   "0", "--gamma", "0", "--alt-range", "0", str(top), "--altitude-unit", unit,
                   "--at", str(top / 2), "--json", str(tmp_path / f"{unit}.json")])
        assert rc == 0
        text = capsys.readouterr().out
        assert f"altitude {unit}" in text and f"altitudes 0..{top:g} {unit}" in text
        runs[unit] = json.loads((tmp_path / f"{unit}.json").read_text())
        assert runs[unit]["units"]["altitude"] == unit
        assert runs[unit]["units"]["speed"] == "m/s"
        assert {r["altitude_unit"] for r in runs[unit]["flutter"]} == {unit}
    by_method = {u: {r["method"]: r for r in res["flutter"]} for u, res in runs.items()}
    for method, m in by_method["m"].items():
        f = by_method["ft"][method]
        assert m["altitude"] == pytest.approx(f["altitude"] * 0.3048, rel=1e-5)
        for key in ("velocity", "density", "frequency_hz"):
            assert m[key] == pytest.approx(f[key], rel=1e-5)
    (gm,), (gf,) = runs["m"]["growing_response"], runs["ft"]["growing_response"]
    assert gm["altitude"] == pytest.approx(gf["altitude"] * 0.3048, rel=1e-12)
    assert gm["frequency_hz_pk"] == pytest.approx(gf["frequency_hz_pk"], rel=1e-9)
