"""``torchrom flutter --f06``: FLUTTER SUMMARY tables in Nastran's layout
(torchrom.aero.f06_summary).

References: the layout of MSC/Simcenter Nastran's own f06 files in tests/decks (bah_plane.f06:
PK, pt145.f06: KE, 0012_flutter2.f06: PKNL), field by field; the values read back by pyNastran's
reader (``pyNastran.f06.parse_flutter.make_flutter_response``, pyNastran 1.4) and by
:func:`torchrom.f06.read_flutter_summary` against the numbers of the run that wrote them (its
--json, or the same sweep computed here). Tolerances are the printed precision: KFREQ to 4
decimals (half a unit, 5e-5 absolute), PK/KE columns %.7E (half a unit of the 8th significant
digit: 5e-8 relative), PKNL columns %.5E (5e-6 relative); a hair above for the decimal read.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from torchrom.aero.f06_summary import (
    INVERSE_OF_ZERO,
    ROWS_PER_PAGE,
    FlutterSummary,
    SummarySubcase,
    format_flutter_summary,
)
from torchrom.cli import main
from torchrom.f06 import read_flutter_summary

DECKS = Path(__file__).parent / "decks"
#: printed precision (module docstring)
PK_RTOL = 5.0001e-8
PKNL_RTOL = 5.0001e-6
KFREQ_ATOL = 5.0001e-5


def _pynastran(path: Path, units: str) -> dict:
    """pyNastran's reading of an f06 (subcase -> FlutterResponse), no unit conversion."""
    from cpylog import SimpleLogger
    from pyNastran.f06.parse_flutter import make_flutter_response

    return make_flutter_response(str(path), f06_units=units, out_units=units,
                                 log=SimpleLogger("error"))


def _close(actual, desired, rtol: float) -> None:
    np.testing.assert_allclose(np.asarray(actual, float), np.asarray(desired, float), rtol=rtol,
                               atol=0)


def _fields(line: str) -> list[tuple[int, str]]:
    """(end column, text) of each field of a printed row."""
    return [(m.end(), m.group()) for m in re.finditer(r"\S+", line)]


@pytest.mark.parametrize("folder, f06", [
    ("pynastran_bah_plane", "bah_plane.f06"), ("pynastran_pt145", "pt145.f06"),
    ("pynastran_2_mode_flutter", "0012_flutter2.f06")])
def test_layout_is_nastrans(folder, f06, tmp_path):
    """Nastran's own first table (PK, KE, PKNL), read and written again here: every header line
    of the table is Nastran's line, and every row has Nastran's fields at Nastran's columns
    with the same text, except 1./KFREQ (recomputed from the 4-decimal KFREQ: only its
    column is compared) and an unprinted KFREQ of 0 (Nastran's 1/1e-25 = 9.9999996E+24)."""
    path = DECKS / folder / f06
    table = read_flutter_summary(path)[0]
    theirs = path.read_text(errors="replace").splitlines()
    start = next(i for i, ln in enumerate(theirs) if "FLUTTER  SUMMARY" in ln)
    conf = theirs[start + 1]
    xy, xz = conf.split()[5], conf.split()[8]
    text = format_flutter_summary(FlutterSummary("T", "S", [SummarySubcase(1, "L", [table])],
                                                 xy, xz))
    ours = text.splitlines()
    mine = next(i for i, ln in enumerate(ours) if "FLUTTER  SUMMARY" in ln)
    for k in range(6):  # FLUTTER SUMMARY, CONFIGURATION, POINT, 2 blank lines, column heading
        assert ours[mine + k].rstrip() == theirs[start + k].rstrip()
    assert ours[mine - 1].index("SUBCASE") == 109  # pyNastran looks there
    ncol = 9 if table.method == "PKNL" else 7
    rows_theirs = []
    for ln in theirs[start + 6:]:
        if len(ln.split()) != ncol or len(rows_theirs) == ROWS_PER_PAGE:
            break
        rows_theirs.append(ln)
    rows_ours = ours[mine + 6:mine + 6 + len(rows_theirs)]
    assert len(rows_theirs) >= 5
    for a, b in zip(rows_ours, rows_theirs):
        fa, fb = _fields(a), _fields(b)
        assert [e for e, _ in fa] == [e for e, _ in fb]
        assert [t for i, (_, t) in enumerate(fa) if i != 1] == \
            [t for i, (_, t) in enumerate(fb) if i != 1]
    assert f"{INVERSE_OF_ZERO:.7E}" == "9.9999996E+24"


def test_bah_deck_flutter_round_trip(tmp_path):
    """bah_plane (FLUTTER 501, PK at Mach 0, 22 speeds, 10 modes; m/s), ``--f06`` beside
    ``--json``: both readers give back the run's own V-g records (--json "vg": speed, damping g,
    frequency, eigenvalue; mode = POINT) to the printed precision; the deck's symmetry
    (SYMXZ = 1) and Mach, density ratio and units are on the page; the root unstable from the
    first speed (the json's, by its damping and frequency) is in the tables too."""
    f06, out = tmp_path / "bah.f06", tmp_path / "bah.json"
    deck = DECKS / "pynastran_bah_plane" / "bah_plane.bdf"
    assert main(["flutter", str(deck), "--f06", str(f06), "--json", str(out)]) == 0
    rec = json.loads(out.read_text())
    text = f06.read_text()
    assert "VELOCITY IN m/s" in text and "XZ-SYMMETRY = SYMMETRIC" in text
    tables = read_flutter_summary(f06)
    assert [(t.subcase, t.point, t.method, t.mach, t.density_ratio) for t in tables] == \
        [(1, j, "PK", 0.0, 1.0) for j in range(1, 11)]
    (response,) = _pynastran(f06, "si").values()
    assert response.method == "PK" and list(response.modes) == list(range(1, 11))
    for t in tables:
        vg = [r for r in rec["vg"] if r["mode"] == t.point]
        assert len(vg) == len(t.velocity) == 22
        want = {name: [r[name] for r in vg] for name in vg[0]}
        py = response.results[t.point - 1]
        for got, name in ((t.velocity, "velocity"), (py[:, response.ivelocity], "velocity"),
                          (t.damping, "damping_g"), (py[:, response.idamping], "damping_g"),
                          (t.frequency, "frequency_hz"), (py[:, response.ifreq], "frequency_hz"),
                          (t.eigenvalue.real, "eigenvalue_real"),
                          (py[:, response.ieigr], "eigenvalue_real"),
                          (t.eigenvalue.imag, "eigenvalue_imag"),
                          (py[:, response.ieigi], "eigenvalue_imag")):
            _close(got, want[name], PK_RTOL)
        np.testing.assert_allclose(t.kfreq, want["reduced_frequency"], rtol=0, atol=KFREQ_ATOL)
    (first,) = rec["unstable_at_first_speed"]  # g = +0.074 at 2.155 Hz, measured
    hit = [t for t in tables if abs(t.damping[0] - first["damping_g"]) <= 1e-7
           and abs(t.frequency[0] - first["frequency_hz"]) <= 1e-6]
    assert len(hit) == 1 and hit[0].damping[0] > 0.05


@pytest.fixture(scope="module")
def goland_run(tmp_path_factory):
    """``torchrom aero goland`` (coarse 4 x 10 mesh) and ``torchrom flutter goland --f06``."""
    d = tmp_path_factory.mktemp("goland_f06")
    assert main(["aero", "goland", "--mach", "0.7", "--boxes", "4", "10",
                 "--out", str(d / "aero.npz")]) == 0
    assert main(["flutter", "goland", "--aero", str(d / "aero.npz"), "--f06",
                 str(d / "goland.f06"), "--json", str(d / "goland.json")]) == 0
    return d


def test_goland_matched_point_round_trip(goland_run):
    """The Goland wing's matched point at Mach 0.7 (ft/s, slug/ft³; 41 altitudes, 40,000 ft
    down to 0; 9 modes): subcase 1 holds the p-k branches, subcase 2 the state space's, in
    PKNL (density and Mach per row; RHOREF = 1: the density itself). Both readers give back the
    p-k sweep computed here from the same files and damping (the json's α, γ) to the printed
    precision (%.5E); the 41 rows cross a page (35 rows) and are merged again. Cross-checks:
    the state space's branch j has p-k branch j's frequency within 3 % at every altitude
    (measured 1.8 %: the RFA's fit; a swapped branch would be off by 65 % or more), and the
    crossing read from the table (linear between rows, as Nastran's own) is the json's p-k
    flutter speed and frequency within 0.3 % (the json's is solved between the rows)."""
    from torchrom.aero.build import modal_data
    from torchrom.aero.files import load_aero
    from torchrom.aero.flutter import AeroTable, flutter_altitude_pk, pk_damping
    from torchrom.aero.nastran_flutter import f06_flutter_points
    from torchrom.fe import goland

    d = goland_run
    rec = json.loads((d / "goland.json").read_text())
    aero = load_aero(d / "aero.npz")
    structure = modal_data(goland(), aero.n_modes).structure(rec["alpha"], rec["gamma"])
    sweep = flutter_altitude_pk(structure, AeroTable.from_gaf(aero.gaf), 0.7, (0.0, 40000.0),
                                g_tolerance=rec["g_tolerance"]).sweep
    g = pk_damping(sweep.eigenvalues, sweep.velocity, sweep.semichord, "nastran")
    tables = read_flutter_summary(d / "goland.f06")
    pk = [t for t in tables if t.subcase == 1]
    ss = [t for t in tables if t.subcase == 2]
    assert [t.point for t in pk] == [t.point for t in ss] == list(range(1, 10))
    responses = _pynastran(d / "goland.f06", "english_ft")
    assert sorted(responses) == [1, 2] and responses[1].method == "PKNL"
    py = responses[1].results
    for j, t in enumerate(pk):
        assert t.method == "PKNL" and len(t.velocity) == 41
        for got in (t.velocity, py[j, :, responses[1].ivelocity]):
            _close(got, sweep.velocity, PKNL_RTOL)
        for got in (t.density, py[j, :, responses[1].idensity]):
            _close(got, sweep.density, PKNL_RTOL)
        for got in (t.damping, py[j, :, responses[1].idamping]):
            _close(got, g[:, j], PKNL_RTOL)
        for got in (t.frequency, py[j, :, responses[1].ifreq]):
            _close(got, sweep.frequency_hz[:, j], PKNL_RTOL)
        _close(t.eigenvalue.imag, sweep.eigenvalues[:, j].imag, PKNL_RTOL)
        np.testing.assert_allclose(t.machs, 0.7)
    for a, b in zip(pk, ss):
        np.testing.assert_allclose(b.frequency, a.frequency, rtol=0.03)
    (flutter,) = [p for p in f06_flutter_points(pk) if not p.real_root]
    want = next(r for r in rec["flutter"] if r["method"] == "p-k")
    assert flutter.velocity == pytest.approx(want["velocity"], rel=3e-3)
    assert flutter.frequency_hz == pytest.approx(want["frequency_hz"], rel=3e-3)
    text = (d / "goland.f06").read_text()
    assert "VELOCITY IN ft/s" in text and "DENSITY IN slug/ft^3 (RHOREF = 1)" in text
    assert "STATE-SPACE" in text


def test_rom_at_a_density_round_trip(tmp_path):
    """A ROM at fixed densities (the H&P section of tests/test_aero_flutter.py, --density
    twice): PK tables, one per branch and density (DENSITY RATIO = the density, RHOREF = 1),
    p-k in subcase 1 and the state space in subcase 2; both readers agree with each other to
    the printed precision, and each method's first crossing read from its tables is bracketed
    by the two printed speeds where the json's flutter speed (solved between them) lies."""
    from torchrom.aero.files import AeroData, save_aero
    from torchrom.aero.nastran_flutter import f06_flutter_points
    from torchrom.aero.rfa import fit_minimum_state
    from torchrom.rom import NonlinearROM

    from .test_aero_flutter import _altitude_case

    _, st, gaf, _ = _altitude_case()
    NonlinearROM(st.M, st.K).save(tmp_path / "rom.npz")
    save_aero(AeroData(gaf, fit_minimum_state(gaf, n_lags=8)), tmp_path / "aero.npz")
    f06, out = tmp_path / "rom.f06", tmp_path / "rom.json"
    assert main(["flutter", str(tmp_path / "rom.npz"), str(tmp_path / "aero.npz"), "--alpha",
                 "0", "--gamma", "0", "--density", "0.0017", "0.002", "--f06", str(f06),
                 "--json", str(out)]) == 0
    tables = read_flutter_summary(f06)
    assert sorted({(t.subcase, t.method, t.density_ratio) for t in tables}) == [
        (1, "PK", 0.0017), (1, "PK", 0.002), (2, "PK", 0.0017), (2, "PK", 0.002)]
    responses = _pynastran(f06, "english_ft")
    for sub in (1, 2):
        mine = [t for t in tables if t.subcase == sub]
        py = responses[sub].results
        for t in mine:  # pyNastran puts a mode's tables of both densities end to end
            rows = py[t.point - 1, :, :][(0 if t.density_ratio == 0.0017 else len(t.velocity)):]
            _close(rows[:len(t.velocity), responses[sub].ivelocity], t.velocity, PK_RTOL)
            _close(rows[:len(t.velocity), responses[sub].idamping], t.damping, PK_RTOL)
    rec = json.loads(out.read_text())
    for r in rec["flutter"]:
        sub = 1 if r["method"] == "p-k" else 2
        found = [p for p in f06_flutter_points(
            [t for t in tables if t.subcase == sub and t.density_ratio == r["density"]])
            if not p.real_root]
        assert found and found[0].bracket[0] <= r["velocity"] <= found[0].bracket[1]


def test_f06_refused_with_aoa_and_when_it_exists(tmp_path):
    """Bad input, through the real command line in its own process: an existing --f06 file
    without --force, and --f06 with --aoa: one line, exit status 2, the file untouched."""
    import subprocess
    import sys

    f06 = tmp_path / "old.f06"
    f06.write_text("mine\n")
    for extra, word in ((["--f06", str(f06)], "--force"),
                        (["--f06", str(tmp_path / "new.f06"), "--aoa", "1", "--density", "1.2"],
                         "--f06: not with --aoa")):
        p = subprocess.run([sys.executable, "-m", "torchrom", "flutter", "rom.npz", "aero.npz",
                            *extra], capture_output=True, text=True, cwd=tmp_path)
        lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
        assert p.returncode == 2 and len(lines) == 1 and word in lines[0], p.stderr
        assert "Traceback" not in p.stderr
    assert f06.read_text() == "mine\n" and not (tmp_path / "new.f06").exists()
