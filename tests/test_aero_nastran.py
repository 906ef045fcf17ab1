"""SOL 145-style flutter of a Nastran deck: card semantics, bad decks, KE vs PK."""

import re

import numpy as np
import pytest

from torchrom.aero.nastran_flutter import format_deck_result, load_deck, run_deck
from torchrom.errors import InputError


def _field8(*fields):
    return "".join(f"{str(f):<8}" for f in fields)


@pytest.fixture(scope="module")
def pt145_text(pt145_deck):
    return pt145_deck.read_text()


def _variant(tmp_path, text, name, *replacements):
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def pt145_fe(pt145_deck):
    """pt145's structure by the built-in FE (CBAR, CMASS2, rotated CORD2R, PS = 126)."""
    from torchrom.fe import read_bdf

    return read_bdf(pt145_deck)


# NASA test problem 10-2-1 (the same 15-degree swept wing, model D of NASA TN D-1824, Mach 0.45):
# theory (modified strip analysis) k = 0.1314, ω/ω_α = 0.51, ω_α = 1488 rad/s give the flutter
# speed V = (REFC/2) ω / k = 5980 in/s and frequency 121 Hz; experiment agrees in speed. The
# wind-tunnel model was wall-mounted: a reflection plane (AERO SYMXZ = 1). The deck as given
# leaves SYMXZ blank (an isolated half wing), which Nastran also honours.
REF_SPEED_IN_S = 5980.0
REF_FREQUENCY_HZ = 121.0


def test_pt145_cards_are_read(pt145_deck):
    deck = load_deck(pt145_deck)
    assert deck.panels.n == 24 and deck.reference.chord == pytest.approx(2.0706)
    assert deck.reference.symxz == 0 and deck.aero_panels.n == 24  # AERO SYMXZ blank: no image
    assert deck.n_modes == 3  # PARAM LMODES 3 (EIGR asks for 6)
    (case,) = deck.cases
    assert case.sid == 30 and case.method == "KE" and case.nvalue == 3
    assert case.densities[0] == pytest.approx(0.967 * 1.145e-7)
    np.testing.assert_allclose(case.machs, [0.45])
    assert len(case.values) == 9 and case.values[-1] == pytest.approx(0.5)
    assert deck.mkaero == [(0.45, 0.001), (0.45, 0.1), (0.45, 0.2)]
    (spline,) = deck.splines
    assert spline.kind == "SPLINE2" and len(spline.box_index) == 24 and len(spline.grid_ids) == 11
    assert "PT145" in deck.title


def test_pt145_ke_end_to_end(pt145_deck, pt145_fe):
    res = run_deck(pt145_deck, fe=pt145_fe, log=lambda *_: None)
    # first bending, first torsion, second bending (EIGR ND 6 -> PARAM LMODES 3)
    np.testing.assert_allclose(res.frequencies_hz, [39.96, 236.4, 250.4], rtol=2e-3)
    (r,) = res.results
    sw = r.sweep
    b = 2.0706 / 2
    # KE velocities are V = ω b / k, in the deck's units (in/s)
    np.testing.assert_allclose(
        sw.velocity_by_mode, 2 * np.pi * sw.frequency_hz * b / sw.k, rtol=1e-10
    )
    (p,) = r.points
    assert p.mode == 1  # the torsion branch goes unstable
    # isolated half wing (SYMXZ blank), as MSC Nastran ran it (its f06, tests/decks/
    # pynastran_pt145: 6,004.2 in/s, 140.12 Hz): observed 6,032 in/s (+0.47 %), 139.7 Hz
    # (−0.28 %) with Nastran's parabolic DLM kernel; the reflection-plane reference is below
    assert p.velocity == pytest.approx(6004.2, rel=0.02)
    assert p.frequency_hz == pytest.approx(140.12, rel=0.02)
    text = format_deck_result(res)
    assert "FLUTTER SUMMARY" in text and "METHOD = KE" in text
    assert re.search(r"flutter speed \d+", text)
    rec = res.as_dict()
    assert rec["flutter"][0]["velocity"] == pytest.approx(p.velocity)
    assert len(rec["vg"]) == 9 * 3


def test_pt145_with_reflection_plane_matches_the_reference(tmp_path, pt145_text, pt145_fe):
    path = _variant(
        tmp_path,
        pt145_text,
        "pt145_sym.bdf",
        ("AERO    0               2.0706  1.145-7", _field8("AERO", 0, "", "2.0706", "1.145-7", 1)),
    )
    (p,) = run_deck(path, fe=pt145_fe, log=lambda *_: None).results[0].points
    # observed 6,012 in/s (+0.5 %), 123.8 Hz (+2.3 %), k = 0.1341 (reference 0.1314, +2.1 %)
    # with Nastran's parabolic DLM kernel (quartic: 6,041 in/s, 121.6 Hz, k 0.1310). The
    # reference is modified strip theory, not a lifting surface: 3 % on frequency and k.
    assert p.velocity == pytest.approx(REF_SPEED_IN_S, rel=0.02)
    assert p.frequency_hz == pytest.approx(REF_FREQUENCY_HZ, rel=0.03)
    assert p.k == pytest.approx(0.1314, rel=0.03)


def test_symxz_override_and_unit_labels(tmp_path, pt145_text, pt145_deck, capsys):
    """--symxz 1 on the deck as given is the deck with AERO SYMXZ = 1 (the same image wing);
    the output names the symmetry's source and labels velocities in the deck's length unit
    (DTI,UNITS when present, else --length-unit, else the unit system its cards tell: pt145's
    AERO RHOREF 1.145e-7 is in-lbf-s)."""
    from torchrom.cli import main

    deck = load_deck(pt145_deck)
    assert "from the deck's AERO card (field blank)" in deck.symmetry
    assert deck.velocity_unit == "in/s" and deck.units == "in-lbf-s"
    over = load_deck(pt145_deck, symxz=1, length_unit="in")
    assert over.reference.symxz == 1 and over.aero_panels.n == 48
    assert "from the command line (the deck's AERO SYMXZ is 0)" in over.symmetry
    assert over.velocity_unit == "in/s"
    with pytest.raises(InputError, match="--symxz: expected -1, 0 or 1"):
        load_deck(pt145_deck, symxz=2)
    dti = _variant(tmp_path, pt145_text, "pt145_dti.bdf",
                   ("PARAM   COUPMASS1", "PARAM   COUPMASS1\n" + _field8("DTI", "UNITS", 1, "LBF",
                                                                          "LBF", "IN", "S")))
    assert load_deck(dti, length_unit="ft").velocity_unit == "in/s"  # the deck's card wins
    # the CLI line the README quotes (reflection plane: NASA test problem 10-2-1, 5,980 in/s,
    # 121 Hz; values as in test_pt145_with_reflection_plane_matches_the_reference)
    assert main(["flutter", str(pt145_deck), "--symxz", "1",
                 "--length-unit", "in"]) == 0
    out = capsys.readouterr().out
    m = re.search(r"flutter speed ([\d.]+) in/s, frequency ([\d.]+) Hz", out)
    assert m and float(m[1]) == pytest.approx(REF_SPEED_IN_S, rel=0.02)
    assert float(m[2]) == pytest.approx(REF_FREQUENCY_HZ, rel=0.03)
    assert "symmetry: SYMXZ = 1: symmetric image" in out and "units: velocity in/s" in out


def test_flfact_velocities_against_the_density_are_noted(tmp_path):
    """bah_plane without FLUTTER 502 (FLFACT 3: 4774.3..5542.34, in/s, beside RHOREF 1.225
    kg/m^3): the deck's flutter runs in its own numbers, as Nastran's does, labels no system
    and says why in one note naming both cards; the deck as published (FLUTTER 502 at
    30..450 m/s too) is labelled in m/s."""
    from pathlib import Path

    from .test_fe_deck_units import DECKS, _bah_without_flutter_502

    doctored = load_deck(_bah_without_flutter_502(tmp_path))
    assert doctored.units is None and doctored.velocity_unit == "length/s"
    (note,) = [n for n in doctored.notes if "FLFACT" in n]
    assert note == ("bah_plane.bdf: units: FLFACT 3 velocities 4774.3..5542.34 are in/s "
                    "(in-lbf-s) but AERO RHOREF 1.225 says si: the results are in the deck's "
                    "own units, labelled without a unit system")
    published = load_deck(Path(DECKS) / "pynastran_bah_plane" / "bah_plane.bdf")
    assert published.units == "si" and published.velocity_unit == "m/s"
    assert not [n for n in published.notes if "FLFACT" in n]


def test_pk_and_ke_agree_on_the_flutter_point(pt145_deck, tmp_path, pt145_text, pt145_fe):
    """KE and PK are both exact at zero damping: the same flutter point up to interpolation."""
    pk_deck = _variant(
        tmp_path,
        pt145_text,
        "pt145_pk.bdf",
        (
            "FLUTTER 30      KE      1       2       3       L       3",
            _field8("FLUTTER", 30, "PK", 1, 2, 4, "S", 3)
            + "\n"
            + _field8("FLFACT", 4, "4000.", "THRU", "8000.", 41),
        ),
        (
            "+MK     .001    0.1     0.2",
            _field8("+MK", ".001", ".05", ".1", ".125", ".15", ".2", ".3", ".5"),
        ),
    )
    ke = run_deck(pt145_deck, fe=pt145_fe, log=lambda *_: None)
    pk = run_deck(pk_deck, fe=pt145_fe, log=lambda *_: None)
    (p_ke,) = ke.results[0].points
    (p_pk,) = pk.results[0].points
    # KE interpolates linearly between its 9 reduced frequencies, PK cubically between 8 MKAERO
    # values: 2 % covers both interpolation errors (observed 0.2 %)
    assert p_pk.velocity == pytest.approx(p_ke.velocity, rel=0.02)
    assert p_pk.frequency_hz == pytest.approx(p_ke.frequency_hz, rel=0.02)


def test_symmetric_aero_card_mirrors_the_boxes(tmp_path, pt145_text):
    path = _variant(
        tmp_path,
        pt145_text,
        "sym.bdf",
        ("AERO    0               2.0706  1.145-7", _field8("AERO", 0, "", "2.0706", "1.145-7", 1)),
    )
    deck = load_deck(path)
    assert deck.aero_panels.n == 48 and np.all(deck.aero_panels.normals[:, 2] > 0.999)


def test_aero_symxy_adds_the_images_about_the_xy_plane(tmp_path, pt145_text, pt145_fe):
    """AERO SYMXY = -1 (ground effect, MSC QRG AERO) with SYMXZ = 1. pt145's boxes lie in the
    aero xy plane, where they would coincide with their images: a one-line error naming a box.
    The same deck with its boxes 0.5 above that plane: the half wing, its xz image, and the xy
    images of both (z -> -z), 96 boxes; the splined motion of an xy image is minus that of its
    source box (the mirror image of the motion), of an xz image plus. The GAFs of such panels
    are checked against a hand-built mirror in tests/test_aero_panels.py."""
    from dataclasses import replace

    from torchrom.aero.panels import AeroPanels

    path = _variant(
        tmp_path,
        pt145_text,
        "symxy.bdf",
        ("AERO    0               2.0706  1.145-7", _field8("AERO", 0, "", "2.0706", "1.145-7", 1,
                                                          -1)),
    )
    with pytest.raises(InputError, match=r"symxy.bdf: AERO: SYMXY = -1: CAERO1 box 101 lies "
                       r"in the xy plane") as exc:
        load_deck(path)
    assert "\n" not in str(exc.value)
    plain = tmp_path / "plain.bdf"
    plain.write_text(pt145_text)
    deck = load_deck(plain)
    raised = replace(deck, panels=AeroPanels(deck.panels.corners + [0.0, 0.0, 0.5],
                                             deck.panels.box_ids, deck.panels.caero_ids),
                     reference=replace(deck.reference, symxz=1, symxy=-1))
    assert "SYMXY = -1" in raised.symmetry and "ground effect" in raised.symmetry
    full = raised.aero_panels
    assert full.n == 96 and full.xy_image.sum() == 48 and full.xz_image.sum() == 48
    np.testing.assert_array_equal(full.corners[48:, :, 2], -full.corners[:48, :, 2])
    modes = pt145_fe.modes(2)
    disp = np.asarray(pt145_fe.expand(modes.shapes)).reshape(2, -1, 6)
    motion = raised.box_motion(pt145_fe.grid_ids, disp)
    for a in (motion.h_load, motion.h_control, motion.slope_control):
        np.testing.assert_array_equal(a[:, 48:], -a[:, :48])
        np.testing.assert_array_equal(a[:, :48], a[:, 24 + full.source[:48]])


BAD = [
    (
        "missing_set1_grid.bdf",
        ("SET1    100     1       THRU    11", "SET1    100     1       THRU    12"),
        r"SET1 100: grid 12 not found",
    ),
    ("caero_without_paero.bdf", ("PAERO1  1", "PAERO1  2"), r"CAERO1 101: PAERO1 1 not found"),
    (
        "flutter_missing_flfact.bdf",
        ("FLUTTER 30      KE      1       2       3", "FLUTTER 30      KE      1       2       7"),
        r"FLUTTER 30: FLFACT 7 \(reduced frequencies\) not found",
    ),
    (
        "fmethod_missing_flutter.bdf",
        ("FMETHOD = 30", "FMETHOD = 31"),
        r"FMETHOD = 31: FLUTTER 31 not found",
    ),
    (
        "spline_missing_caero.bdf",
        ("SPLINE2 100     101     101", "SPLINE2 100     102     101"),
        r"SPLINE2 100: CAERO1 102 not found",
    ),
    (
        "aero_symxy.bdf",
        ("AERO    0               2.0706  1.145-7", _field8("AERO", 0, "", "2.0706", "1.145-7", "",
                                                          2)),
        r"AERO: SYMXY: expected -1 \(ground effect\), 0 or \+1, got 2",
    ),
    (
        "method_missing_eigr.bdf",
        ("METHOD  = 10", "METHOD  = 11"),
        r"METHOD = 11: EIGR/EIGRL 11 not found",
    ),
]


@pytest.mark.parametrize("name, replacement, message", BAD, ids=[b[0] for b in BAD])
def test_bad_decks_give_one_line_errors(tmp_path, pt145_text, name, replacement, message):
    path = _variant(tmp_path, pt145_text, name, replacement)
    with pytest.raises(InputError, match=message) as exc:
        load_deck(path)
    assert "\n" not in str(exc.value) and name in str(exc.value)


def test_missing_deck_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        load_deck(tmp_path / "nope.bdf")


def test_aero_acsid_along_minus_x_basic_gives_the_same_flutter(tmp_path, pt145_text, pt145_fe):
    """AERO ACSID: CAERO1 chords and the flow run along the aero x axis (MSC QRG, CAERO1/AERO).

    pt145 turned by 180 degrees about z (its CORD2R 1, which places the grids, the CAERO1 and the
    SPLINE2, is turned), with an aero system whose x points along -x basic: in that system the
    deck is pt145 itself, so modes and flutter must be the same to round-off (before: the boxes
    were laid along +x basic, ahead of the wing, and the flutter speed was far off, silently).
    """
    from torchrom.fe import read_bdf

    path = _variant(
        tmp_path,
        pt145_text,
        "pt145_acsid.bdf",
        ("+C1     .96593  -.25882 .0", "+C1     -.96593 .25882  .0"),
        (
            "AERO    0               2.0706  1.145-7",
            _field8("AERO", 2, "", "2.0706", "1.145-7")
            + "\n"
            + _field8("CORD2R", 2, "", ".0", ".0", ".0", ".0", ".0", "1.")
            + "\n"
            + _field8("", "-1.", ".0", ".0"),
        ),
    )
    turned = read_bdf(path)
    np.testing.assert_allclose(turned.grid_xyz[:, :2], -pt145_fe.grid_xyz[:, :2], atol=1e-12)
    deck = load_deck(path)
    assert np.all(deck.panels.corners[:, 1, 0] > deck.panels.corners[:, 0, 0])  # chord along +x
    (p,) = run_deck(deck, fe=turned, log=lambda *_: None).results[0].points
    ref = _variant(tmp_path, pt145_text, "pt145_ref.bdf")
    (q,) = run_deck(ref, fe=pt145_fe, log=lambda *_: None).results[0].points
    assert p.velocity == pytest.approx(q.velocity, rel=1e-6)
    assert p.frequency_hz == pytest.approx(q.frequency_hz, rel=1e-6)


def test_spline4_and_spline5_on_aelists_equal_spline1_and_spline2(tmp_path, pt145_text):
    """SPLINE5 (beam spline, boxes on an AELIST) over the same boxes, grids and CID as pt145's
    SPLINE2 moves the boxes identically; SPLINE4 (IPS) likewise against the SPLINE1 of the
    two-mode flutter deck (tests/decks)."""
    import shutil
    from pathlib import Path

    rng = np.random.default_rng(3)
    spline2 = "SPLINE2 100     101     101     124     100     .0      1.0     1       +SP\n"
    spline2 += "+SP     .0      .0"
    s5 = _variant(
        tmp_path, pt145_text, "pt145_s5.bdf",
        (spline2, _field8("SPLINE5", 100, 101, 77, "", 100, ".0", "1.0", 1) + "+SP\n"
         + _field8("+SP", ".0", ".0") + "\n" + _field8("AELIST", 77, 101, "THRU", 124)),
    )
    base = _variant(tmp_path, pt145_text, "pt145_base.bdf")
    pairs = [(load_deck(s5), load_deck(base), np.arange(1, 12))]
    src = Path(__file__).parent / "decks" / "pynastran_2_mode_flutter"
    work = tmp_path / "two_mode"
    shutil.copytree(src, work)
    inc = work / "aero_cards.inc"
    text = inc.read_text()
    assert "SPLINE1,1002,1,1,100,10000" in text
    inc.write_text(text.replace("SPLINE1,1002,1,1,100,10000",
                                "SPLINE4,1002,1,77,,10000,,IPS\nAELIST,77,1,THRU,100"))
    s4 = load_deck(work / "0012_flutter.bdf")
    s1 = load_deck(src / "0012_flutter.bdf")
    assert s4.splines[0].kind == "SPLINE4" and s1.splines[0].kind == "SPLINE1"
    pairs.append((s4, s1, np.asarray(sorted(s1.splines[0].grid_ids))))
    for new, old, grid_ids in pairs:
        disp = rng.standard_normal((2, len(grid_ids), 6))
        a, b = new.box_motion(grid_ids, disp), old.box_motion(grid_ids, disp)
        for name in ("h_load", "h_control", "slope_control"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, atol=1e-12)
        assert np.abs(a.h_load).max() > 0.1


def test_resvec_selection(tmp_path):
    """Residual vectors (RESVEC) are used as Nastran uses them: by default, when LMODES asks for
    more modes than ND (bah_plane: LMODES 10, ND 8 -> 8 eigenmodes + 2 residual vectors),
    switched off by PARAM RESVEC NO, case control RESVEC = NO or ``resvec=False`` (8 modes);
    a PARAM RESVEC that is neither YES nor NO is a one-line error naming it."""
    from pathlib import Path

    from torchrom.aero import nastran_flutter as nf
    from torchrom.fe import read_bdf

    folder = Path(__file__).parent / "decks" / "pynastran_bah_plane"
    for inc in folder.glob("*.inc"):
        (tmp_path / inc.name).write_text(inc.read_text())
    text = (folder / "bah_plane.bdf").read_text()
    fe = read_bdf(folder / "bah_plane.bdf")

    def deck(name, new_text, **kw):
        path = tmp_path / name
        path.write_text(new_text)
        return nf.load_deck(path, **kw)

    default = deck("default.bdf", text)
    assert default.resvec and default.resvec_source == "Nastran's default"
    assert (default.n_eigen, default.lmodes) == (8, 10)
    assert len(nf._modes(default, fe, [])[0]) == 10
    param_no = deck("param.bdf",
                    text.replace("PARAM,LMODES,10", "PARAM,LMODES,10\nPARAM,RESVEC,NO"))
    case_no = deck("case.bdf", text.replace("METHOD = 401", "METHOD = 401\nRESVEC = NO"))
    for d in (param_no, case_no, deck("cli.bdf", text, resvec=False)):
        assert not d.resvec and len(nf._modes(d, fe, [])[0]) == 8
    with pytest.raises(InputError, match=r"bad.bdf: PARAM RESVEC: expected YES or NO, got MAYBE"):
        deck("bad.bdf", text.replace("PARAM,LMODES,10", "PARAM,LMODES,10\nPARAM,RESVEC,MAYBE"))


def _pitch_section_flutter_deck(path):
    """tests/test_trim_reduced.py's rigid pitching wing (one mode, 3.04 Hz: a CELAS2 of 400
    N m/rad about x = 0.4 of a 1 x 4 m wing, 4 x 8 DLM boxes, ρ = 1.225) with SOL 145 cards:
    PK at Mach 0 from 0.3 to 1.4 times its divergence speed, MKAERO k 0.001 to 1. Its
    divergence: q_D = K / (S C_Lα e) with the horseshoe lattice's C_Lα and aerodynamic centre
    (e = x_ea - x_ac), V_D = √(2 q_D / ρ) = 14.81 m/s."""
    import math

    from .test_trim_equilibrium import (
        CHORD,
        K_SPRING,
        RHO,
        SEMISPAN,
        X_EA,
        _horseshoe_lift_and_centre,
    )
    from .test_trim_reduced import _section_deck

    _section_deck(path, plunge=False)
    cla, x_ac = _horseshoe_lift_and_centre()
    v_d = math.sqrt(2 * K_SPRING / (CHORD * SEMISPAN * cla * (X_EA - x_ac)) / RHO)
    cards = ["EIGRL,1,,,1", "FLUTTER,5,PK,1,2,3", "FLFACT,1,1.0", "FLFACT,2,0.0",
             f"FLFACT,3,{0.3 * v_d:.6f},THRU,{1.4 * v_d:.6f},12",
             "MKAERO1,0.0,,,,,,,,+MK", "+MK,0.001,0.01,0.05,0.1,0.2,0.5,1.0"]
    text = path.read_text().replace("SOL 101", "SOL 145").replace(
        "SPC = 1", "SPC = 1\nMETHOD = 1\nFMETHOD = 5")
    path.write_text(text.replace("ENDDATA", "\n".join(cards) + "\nENDDATA"))
    return path, v_d


def test_a_divergence_is_reported_as_divergence_never_as_flutter(tmp_path):
    """SOL 145-style PK on a wing that diverges (a rigid wing pitching about an axis aft of
    its aerodynamic centre): its one root's pair turns real and a real root crosses zero at
    the divergence speed. Reported as a divergence at V_D (closed form of the horseshoe
    lattice, 1e-4: the p-k's real roots take Q_R at the lowest MKAERO k, 0.001, not the
    steady k = 0: an O(k²) difference, 3.5e-5 measured), with no flutter row, in the text
    and the JSON; before issue 46 it read "flutter speed 14.812 m/s, frequency 0 Hz"."""
    import json
    import subprocess
    import sys

    deck, v_d = _pitch_section_flutter_deck(tmp_path / "pitch.bdf")
    res = run_deck(deck, log=lambda *_: None)
    (r,) = res.results
    assert r.points == [] and r.rigid_points == [] and r.not_loaded == []
    (div,) = r.divergence_points
    assert div.divergence and div.frequency_hz == 0.0 and div.refined
    assert div.velocity == pytest.approx(v_d, rel=1e-4)
    text = format_deck_result(res)
    assert re.search(r"divergence speed 14\.81\d m/s \(a real root crosses zero\)", text)
    assert "flutter speed" not in text
    run = subprocess.run([sys.executable, "-m", "torchrom", "flutter", deck.name, "--json",
                          "f.json"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    out = json.loads((tmp_path / "f.json").read_text())
    assert out["flutter"] == [] and out["g_tolerance"] == 1e-3
    (rec,) = out["divergence"]
    assert rec["divergence"] is True and rec["velocity"] == pytest.approx(v_d, rel=1e-4)
