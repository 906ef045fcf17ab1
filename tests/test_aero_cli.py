"""``torchrom aero`` and ``torchrom flutter`` end to end (in process; FE modes stubbed)."""

import json

import pytest

from torchrom.aero.files import AeroData, save_aero
from torchrom.aero.rfa import fit_minimum_state
from torchrom.cli import main

from .test_aero_flutter import _altitude_case


def test_flutter_rom_and_aero_files(tmp_path, capsys):
    from torchrom.rom import NonlinearROM

    _, st, gaf, mach = _altitude_case()
    NonlinearROM(st.M, st.K).save(tmp_path / "rom.npz")
    save_aero(AeroData(gaf, fit_minimum_state(gaf, n_lags=8)), tmp_path / "aero.npz")
    rc = main(
        [
            "flutter",
            str(tmp_path / "rom.npz"),
            str(tmp_path / "aero.npz"),
            "--alt-range",
            "0",
            "20000",
            "--alpha",
            "0",
            "--gamma",
            "0",
            "--at",
            "4000",
            "8000",
            "--json",
            str(tmp_path / "f.json"),
            "--plot",
            str(tmp_path / "vg.png"),
            "--root-locus",
            str(tmp_path / "rl.png"),
            "--alpha-for-gamma",
            "0.001",
            "0.01",
        ]
    )
    assert rc == 0
    out = json.loads((tmp_path / "f.json").read_text())
    pk, ss = out["flutter"]
    assert pk["method"] == "p-k" and ss["method"] == "state-space"
    assert pk["altitude"] == pytest.approx(10000.0, abs=5.0)  # the case is scaled to 10,000 ft
    assert ss["altitude"] == pytest.approx(pk["altitude"], rel=0.01)
    assert [g["altitude"] for g in out["growing_response"]] == [4000.0, 8000.0]
    g = out["growing_response"][0]
    assert g["frequency_hz_pk"] == pytest.approx(g["frequency_hz_state_space"], rel=0.01)
    a1, a2 = (p["alpha"] for p in out["alpha_for_gamma"])
    assert a1 > a2  # more stiffness-proportional damping needs less mass-proportional damping
    assert out["alpha_for_gamma"][0]["altitude"] == pytest.approx(ss["altitude"])
    assert (tmp_path / "vg.png").stat().st_size > 0 and (tmp_path / "rl.png").stat().st_size > 0
    assert "state-space" in capsys.readouterr().out


def test_flutter_deck(pt145_deck, tmp_path, capsys):
    rc = main(["flutter", str(pt145_deck), "--json", str(tmp_path / "d.json")])
    assert rc == 0
    text = capsys.readouterr().out
    assert "FLUTTER SUMMARY" in text and "flutter speed" in text
    out = json.loads((tmp_path / "d.json").read_text())
    assert out["flutter"][0]["method"] == "KE" and out["flutter"][0]["velocity"] > 0


def test_aero_command_writes_aero_npz(pt145_deck, tmp_path, capsys):
    out = tmp_path / "aero.npz"
    args = [
        "aero",
        str(pt145_deck),
        "--mach",
        "0.45",
        "--out",
        str(out),
        "--modes",
        "2",
        "--lags",
        "2",
        "--k",
        "0.05",
        "0.1",
        "0.2",
        "0.4",
        "--json",
        str(tmp_path / "a.json"),
    ]
    assert main(args) == 0
    rec = json.loads((tmp_path / "a.json").read_text())
    assert rec["k"] == [0.0, 0.05, 0.1, 0.2, 0.4] and rec["n_modes"] == 2
    assert rec["semichord"] == pytest.approx(2.0706 / 2)
    assert main(args) == 2  # no overwrite without --force
    assert "already exists" in capsys.readouterr().err


def test_bad_deck_exit_code(pt145_deck, tmp_path, capsys):
    text = pt145_deck.read_text().replace("PAERO1  1", "PAERO1  2", 1)
    bad = tmp_path / "bad.bdf"
    bad.write_text(text)
    assert main(["flutter", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "CAERO1 101: PAERO1 1 not found" in err


def test_flutter_deck_unsupported_warn_and_noted_cards(pt145_deck, tmp_path, capsys):
    """Cards without effect on modes/flutter are accepted with a note; an unknown card refuses
    the deck (exit 2, its name, count and reason) unless --unsupported warn."""
    extra = (
        "MDLPRM  QR6ROT  1\nMAT4    7       204.\nUSET    U1      1       3\n"
        "DESVAR  1       AREA    7.175-2 1.-3    1.\n"
        "DRESP1  30      FREQ1   FREQ                    1\nDCONSTR 40      30      10.\n"
        "DCONADD 50      40\nDSCREEN FREQ    -0.5    10\n"
    )
    text = pt145_deck.read_text().replace("PARAM   LMODES  3", "PARAM   LMODES  3\n" + extra, 1)
    noted = tmp_path / "noted.bdf"
    noted.write_text(text)
    assert main(["flutter", str(noted), "--json", str(tmp_path / "n.json")]) == 0
    out = capsys.readouterr().out
    for card in ("MDLPRM (1)", "MAT4 (1)", "USET (1)", "DESVAR (1)", "DSCREEN (1)"):
        assert f"note: {card} accepted" in out
    ref = json.loads((tmp_path / "n.json").read_text())["flutter"][0]
    bad = tmp_path / "bad.bdf"
    damper = "CDAMP2  99      0.1     5       3"
    bad.write_text(text.replace("PARAM   LMODES  3", "PARAM   LMODES  3\n" + damper, 1))
    assert main(["flutter", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "CDAMP2 (1): viscous damper not implemented" in err and err.count("\n") == 1
    # the command line reports the ignored card once, as a note (no raw Python warning line)
    assert main(["flutter", str(bad), "--unsupported", "warn", "--json",
                 str(tmp_path / "w.json")]) == 0
    captured = capsys.readouterr()
    assert "CDAMP2" in captured.out and "Warning" not in captured.err
    got = json.loads((tmp_path / "w.json").read_text())["flutter"][0]
    assert got["velocity"] == pytest.approx(ref["velocity"], rel=1e-12)


def test_flutter_deck_compare_with_an_f06(tmp_path, capsys):
    """`torchrom flutter DECK --compare RUN.f06`: the f06's flutter point and modes beside ours."""
    from pathlib import Path

    folder = Path(__file__).parent / "decks" / "pynastran_pt145"
    out = tmp_path / "f.json"
    assert main(["flutter", str(folder / "pt145.bdf"), "--compare", str(folder / "pt145.f06"),
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "compared with" in text and "V Nastran" in text
    (rec,) = json.loads(out.read_text())["compare"]
    assert rec["nastran_velocity"] == pytest.approx(6004.2, rel=1e-4)
    assert rec["velocity"] == pytest.approx(6032.1, rel=1e-3)  # Nastran's parabolic DLM kernel


def test_flutter_rom_at_mach_0_in_a_subprocess(tmp_path):
    """A ROM with aerodynamics built at Mach 0 (incompressible: the typical section's exact
    Theodorsen GAFs, tests/test_aero_flutter.py): ``torchrom flutter rom.npz aero.npz`` gives
    the flutter speed at the altitude's density. Independent reference: the classical flutter
    determinant of Hodges & Pierce's case (μ = 20 at that density), U_F = 2.18391 b ω_α,
    ω_F = 0.64898 ω_α; p-k is exact at zero damping (1e-4: the GAF table interpolated in k),
    the state space on the 8-lag RFA within 0.5 % (its fit error). A --mach other than the aero
    file's is refused in one line."""
    import os
    import subprocess
    import sys

    import numpy as np

    from torchrom.aero.atmosphere import atmosphere
    from torchrom.aero.dlm import GAF
    from torchrom.aero.theodorsen import TypicalSection
    from torchrom.rom import NonlinearROM

    from .conftest import REPO
    from .test_aero_flutter import HP

    b, w_a, alt = 3.0, 100.0, 10000.0
    rho = float(atmosphere(alt, "ft").density)
    ts = TypicalSection(b, HP["a"], HP["x_alpha"], HP["r_alpha_sq"],
                        HP["mu"] * np.pi * rho * b**2, HP["sigma"] * w_a, w_a)
    k = np.r_[0.0, np.geomspace(0.005, 2.0, 40)]
    gaf = GAF(0.0, b, k, ts.gaf(k))
    NonlinearROM(ts.mass_matrix(), ts.stiffness_matrix()).save(tmp_path / "rom.npz")
    save_aero(AeroData(gaf, fit_minimum_state(gaf, n_lags=8)), tmp_path / "aero.npz")

    def cli(*extra):
        return subprocess.run(
            [sys.executable, "-m", "torchrom", "flutter", str(tmp_path / "rom.npz"),
             str(tmp_path / "aero.npz"), *extra], capture_output=True, text=True, cwd=REPO,
            env={**os.environ, "PYTHONPATH": str(REPO)})

    run = cli("--alpha", "0", "--gamma", "0", "--at", str(alt), "--json",
              str(tmp_path / "f.json"))
    assert run.returncode == 0, run.stderr
    pk, ss = json.loads((tmp_path / "f.json").read_text())["flutter"]
    assert pk["method"] == "p-k" and pk["mach"] == 0.0 and pk["altitude"] == alt
    assert pk["velocity"] == pytest.approx(2.18391 * b * w_a, rel=1e-4)
    assert 2 * np.pi * pk["frequency_hz"] == pytest.approx(0.64898 * w_a, rel=1e-4)
    assert pk["kind"] == "sustained" and pk["density"] == pytest.approx(rho)
    assert ss["velocity"] == pytest.approx(pk["velocity"], rel=5e-3)
    bad = cli("--mach", "0.3")
    assert bad.returncode != 0 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().splitlines()[-1].endswith(
        "--mach 0.3 differs from the aero file's Mach 0")
    assert len(bad.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("mach", [0.5, 0.0])
def test_flutter_of_a_free_rom_reports_rigid_body_roots_apart(tmp_path, mach):
    """``torchrom flutter rom.npz aero.npz`` (a subprocess) on a free ROM: the closed-form free
    aircraft of :func:`tests._aero_fakes.rigid_and_elastic` (rigid mode at 0 Hz, its root
    unstable first at ρV = 0.8; the elastic root at ρV = 8/7, 10 rad/s). Both methods, p-k
    and the state space on the RFA, give the elastic crossing as the flutter point — at Mach
    0.5 the altitude (1 ft), at Mach 0 the speed at sea-level density (1e-6) — and print
    the rigid-body root apart, as the JSON lists it."""
    import os
    import subprocess
    import sys

    import numpy as np
    from scipy.optimize import brentq

    from torchrom.aero.atmosphere import atmosphere, flight_condition
    from torchrom.rom import NonlinearROM

    from ._aero_fakes import RIGID_ELASTIC, rigid_and_elastic
    from .conftest import REPO

    structure, gaf, rfa = rigid_and_elastic(mach)
    NonlinearROM(structure.M, structure.K).save(tmp_path / "rom.npz")
    save_aero(AeroData(gaf, rfa), tmp_path / "aero.npz")
    run = subprocess.run(
        [sys.executable, "-m", "torchrom", "flutter", str(tmp_path / "rom.npz"),
         str(tmp_path / "aero.npz"), "--alpha", str(RIGID_ELASTIC["alpha"]), "--gamma",
         str(RIGID_ELASTIC["gamma"]), "--alt-range", "0", "30000", "--json",
         str(tmp_path / "f.json")] + (["--at", "0"] if mach == 0.0 else []),
        capture_output=True, text=True, cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert run.returncode == 0, run.stderr
    points = json.loads((tmp_path / "f.json").read_text())["flutter"]
    assert [p["method"] for p in points] == ["p-k", "state-space"]
    for p in points:
        assert p["frequency_hz"] == pytest.approx(10 / (2 * np.pi), rel=1e-6)
        ((rigid,),) = [p["rigid_body_crossings"]]
        assert rigid["mode"] == 1
    if mach:
        def rho_v(h):
            c = flight_condition(mach, h, "ft")
            return float(c.density * c.velocity)

        expected = brentq(lambda h: rho_v(h) - 8 / 7, 0.0, 30000.0)
        assert [p["altitude"] for p in points] == pytest.approx([expected] * 2, abs=1.0)
    else:
        rho = float(atmosphere(0.0, "ft").density)
        assert [p["velocity"] for p in points] == pytest.approx([8 / 7 / rho] * 2, rel=1e-6)
    lines = [ln for ln in run.stdout.splitlines() if "rigid-body root (mode 1)" in ln]
    assert [ln.split(":")[0].strip() for ln in lines] == ["p-k", "state-space"], run.stdout
