"""Heavy Goland wing at Mach 0.70 (9 modes, 13 lags): flutter by p-k and state space vs the paper.

Paper (Sec. III.C): flutter altitude 11,275 ft at 1.975 Hz; Table 3 growing-response
frequencies 1.851–1.962 Hz at 4,000–11,000 ft. The store's chordwise position (the FE default,
2.6888 ft, membrane-only CQUAD4 webs) was calibrated once so that the p-k flutter altitude with
the default 8 × 20-box mesh is 11,275 ft (torchrom.aero.goland.calibrate_store_x); the flutter
frequency and Table 3 are predictions. On that calibrated wing they come out 5–10 % high, as its
first torsion mode is 3.99 Hz against the paper's 3.05 Hz (see tests/test_fe_goland.py); on the
updated wing (the default since issue 15: masses updated to Table 2, the store position fitted
again) they are within 0.5 % and 1.2 %. Default tests use the default (updated) wing, as
``torchrom aero goland`` does, on a coarse 4 × 10 mesh (+4.9 % in altitude against the default
mesh); the default (full-resolution) mesh runs too, one test per variant, its GAFs built once
per module for the updated wing.
"""

import json

import pytest

from torchrom.aero.build import PAPER_FLUTTER_ALTITUDE_FT, PAPER_FLUTTER_FREQUENCY_HZ, PAPER_TABLE3
from torchrom.aero.files import load_aero
from torchrom.cli import main


def _check(res, altitude_tol_ft, table3_rel):
    # p-k (tabulated DLM GAFs) and state space (13-lag minimum-state RFA) agree within 1 % in
    # altitude, as in the paper (observed 0.04 % coarse, 0.21 % default mesh)
    assert res.ss_altitude == pytest.approx(res.pk_altitude, rel=0.01)
    assert res.ss_frequency_hz == pytest.approx(res.pk_frequency_hz, rel=0.01)
    assert res.pk_altitude == pytest.approx(PAPER_FLUTTER_ALTITUDE_FT, abs=altitude_tol_ft)
    # predictions (observed: calibrated wing +5.2 % on the default mesh; updated wing +0.5 % on
    # the coarse one)
    assert res.pk_frequency_hz == pytest.approx(PAPER_FLUTTER_FREQUENCY_HZ, rel=0.08)
    for alt, (f_ss, f_pk, paper) in res.table3.items():
        assert paper == PAPER_TABLE3[alt]
        assert f_ss == pytest.approx(paper, rel=table3_rel)
        assert f_pk == pytest.approx(f_ss, rel=0.01)


@pytest.fixture(scope="module")
def modes():
    """The default (updated) wing's modes, those of ``torchrom aero goland``."""
    from torchrom.aero.build import modal_data
    from torchrom.fe import goland

    return modal_data(goland(), 9)


@pytest.fixture(scope="module")
def coarse_aero(tmp_path_factory):
    """``torchrom aero goland`` with a coarse mesh: aero.npz and its --json record."""
    d = tmp_path_factory.mktemp("goland")
    rc = main(
        [
            "aero",
            "goland",
            "--mach",
            "0.7",
            "--out",
            str(d / "aero.npz"),
            "--boxes",
            "4",
            "10",
            "--json",
            str(d / "aero.json"),
        ]
    )
    assert rc == 0
    return d


def test_aero_file_of_the_goland_wing(coarse_aero):
    rec = json.loads((coarse_aero / "aero.json").read_text())
    assert rec["n_modes"] == 9 and rec["n_lags"] == 13 and rec["semichord"] == 3.0
    assert rec["frequencies_hz"][0] == pytest.approx(1.690, rel=0.03)  # updated: 1.664 Hz
    assert rec["fit_error"]["rms_relative"] < 0.03  # observed 0.017
    data = load_aero(coarse_aero / "aero.npz")
    assert data.rfa.n_states == 13 and data.gaf.Q.shape == (21, 9, 9)


def test_goland_flutter_coarse_mesh(modes, coarse_aero):
    from torchrom.aero.goland import goland_flutter

    res = goland_flutter(modes=modes, aero=load_aero(coarse_aero / "aero.npz"))
    # updated wing, coarse mesh: observed 11,824 ft (+549 ft: the coarse mesh's +4.9 %),
    # 1.984 Hz; Table 3 +0.7 .. +1.4 %
    _check(res, altitude_tol_ft=700.0, table3_rel=0.03)


def test_flutter_command_compares_with_the_paper(coarse_aero, capsys):
    out = coarse_aero / "flutter.json"
    rc = main(
        [
            "flutter",
            "goland",
            "--aero",
            str(coarse_aero / "aero.npz"),
            "--alt-range",
            "0",
            "30000",
            "--json",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "paper" in text and "11275.0" in text and "1.851" in text
    rec = json.loads(out.read_text())
    pk, ss = rec["flutter"]
    assert ss["altitude"] == pytest.approx(pk["altitude"], rel=0.01)
    assert [g["altitude"] for g in rec["growing_response"]] == sorted(PAPER_TABLE3)
    assert rec["alpha"] == 0.2565 and rec["gamma"] == 1.338e-4


@pytest.fixture(scope="module")
def default_aero(tmp_path_factory):
    """``torchrom aero goland`` on the default 8 x 20 mesh of the default (updated) wing: the
    doublet-lattice GAFs the two full-resolution updated-wing tests below share (built once)."""
    d = tmp_path_factory.mktemp("goland_default")
    assert main(["aero", "goland", "--mach", "0.7", "--out", str(d / "aero.npz")]) == 0
    return d / "aero.npz"


def test_goland_flutter_default_mesh():
    """The calibrated variant, whose store position was calibrated on this mesh (full
    resolution; runs by default, ~10 s)."""
    from torchrom.aero.goland import DEFAULT_BOXES, goland_flutter, goland_modes

    res = goland_flutter(boxes=DEFAULT_BOXES, modes=goland_modes())
    # the calibration target, observed 11,274.7 ft; Table 3 observed +6.5 .. +9.0 %
    _check(res, altitude_tol_ft=25.0, table3_rel=0.10)


def test_flutter_command_default_wing_meets_the_paper(default_aero, tmp_path):
    """Issue 15 acceptance: ``torchrom flutter goland --json`` on the default, updated wing and
    the default 8 x 20 mesh (its GAFs from the shared fixture through ``--aero``): p-k altitude
    within 1 % of 11,275 ft (observed 11,274 ft), frequency within 2 % of 1.975 Hz (observed
    1.965 Hz)."""
    out = tmp_path / "flutter.json"
    assert main(["flutter", "goland", "--aero", str(default_aero), "--json", str(out)]) == 0
    pk = next(r for r in json.loads(out.read_text())["flutter"] if r["method"] == "p-k")
    assert pk["altitude"] == pytest.approx(PAPER_FLUTTER_ALTITUDE_FT, rel=0.01)
    assert pk["frequency_hz"] == pytest.approx(PAPER_FLUTTER_FREQUENCY_HZ, rel=0.02)


def test_updated_goland_flutter_and_table3(default_aero):
    """Updated variant (torchrom/fe/goland.py, issue 15 acceptance), default mesh: the store
    position was fitted to the altitude (observed 11,274 ft); the flutter frequency (observed
    1.965 Hz, −0.5 %) and Table 3 (observed +0.2 … +1.2 %, tolerance 2 %) are predictions of
    the mass update to Table 2."""
    from torchrom.aero.build import modal_data
    from torchrom.aero.goland import goland_flutter
    from torchrom.fe import goland

    res = goland_flutter(modes=modal_data(goland(variant="updated"), 9),
                         aero=load_aero(default_aero))
    assert res.pk_altitude == pytest.approx(PAPER_FLUTTER_ALTITUDE_FT, rel=0.01)
    assert res.pk_frequency_hz == pytest.approx(PAPER_FLUTTER_FREQUENCY_HZ, rel=0.02)
    assert res.ss_altitude == pytest.approx(res.pk_altitude, rel=0.01)
    for alt, (f_ss, _f_pk, paper) in res.table3.items():
        assert f_ss == pytest.approx(paper, rel=0.02), alt
