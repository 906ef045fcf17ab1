"""``torchrom identify`` on every public deck in tests/decks (issue 34: no traceback on any of
them; a deck it cannot identify is refused in one line that says why and what to do).

Each deck runs through the real command line, in a child of the fork server
(:mod:`tests.cli_forkserver`: a separate process with its own exit status and output, the
imports paid once). The CI form reads each deck and identifies its linear modes (``--linear 4
--dual 0``: the reader, the modes, the rigid-body modes of a free aircraft, the ROM file); the
decks refused before any dual-mode FE solve run with the dual modes asked for, which is what
they refuse. The slow form asks every deck for dual modes (their FE solves take minutes on the
larger decks: 4 to 13 s each on the BAH and Pazy decks).

Outcomes measured with ``--linear 4 --dual 2`` (the per-deck table of the closing note):
identified, refused in one line, or still solving its dual modes after 240 s (no error).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from .cli_forkserver import ForkServer

DECKS = Path(__file__).parent / "decks"

#: deck (relative to tests/decks) -> None: identified; or (argv options of the refusal, the
#: words its one line must hold: why, and what to do)
EXPECTED: dict[str, tuple[list[str], tuple[str, ...]] | None] = {
    "aepw3_pazy_noskin_rigidtip/sol103_noskin_stiftip.dat": None,
    "aepw3_pazy_noskin_rigidtip/sol144_noskin.dat": None,
    "aepw3_pazy_noskin_rigidtip/sol144_noskin_tipmass.dat": None,
    "aepw3_pazy_skin_flutter_tipmass0/sol145.dat": None,
    "aepw3_pazy_skin_flutter_tipmass1/sol145.dat": None,
    "cofe_ten_bar_truss/modes.dat": None,
    "dakota_cylinder/modal.bdf": (["--dual", "1"], ("no transverse (bending or torsion) mode",
                                                    "--combinations", "--dual 0")),
    "ekm_bar_beam/test_case.bdf": None,
    "ekm_swept_plane/sol103_swept_plane.bdf": None,
    # a 2-DOF model
    "pynastran_2_mode_flutter/0012_flutter.bdf": (["--dual", "2"], ("the model has 2 DOFs",
                                                                    "ask for at most 2")),
    # no panels, no thin direction, round sections: the up axis the kinds need is unknown
    "pynastran_actuator_tf/actuator_tf_modeling.bdf": (["--dual", "1"], (
        "cannot tell the wing's up axis", "--up-axis", "--dual 0")),
    "pynastran_bah_gust/BAH_Plane_cont_gust_LINE5000000_10FREQs.bdf": None,
    # small-rotation bars and springs only
    "pynastran_bah_ha146c/ha146c.bdf": (["--dual", "1"], ("every element of the model is linear",
                                                          "use --dual 0")),
    "pynastran_bah_plane/bah_plane.bdf": None,
    "pynastran_bah_plane_mach0/BAH_Plane.bdf": None,
    "pynastran_beam_modes/beam_modes.dat": None,
    "pynastran_buckled/buckled.bdf": None,
    "pynastran_cbush/cbush.dat": ([], ("the model has no mass", "MAT1 RHO", "CONM2")),
    # a free aircraft: its first 4 modes are rigid-body modes
    "pynastran_fmondsp/fmondsp.dat": (["--dual", "1"], ("no transverse",
                                                        "raise --linear past the rigid-body",
                                                        "--dual 0")),
    "pynastran_goland_sol200/goland_final_test.bdf": None,
    "pynastran_ha144d/ha144da.bdf": (["--dual", "1"], ("no transverse", "--dual 0")),
    "pynastran_pt145/pt145.bdf": None,
    # PARAM G without W3 (a SOL 111 deck): no viscous damping without W3 (issue 46 item 3)
    "pynastran_random_nx/random_test.bdf": (["--dual", "0"], ("PARAM G 0.05 needs PARAM W3",
                                                             "add PARAM W3",
                                                             "--damping-ratio")),
    "pynastran_solid_shell_bar/mode_solid_shell_bar.bdf": None,
    "pynastran_solid_shell_bar_static/static_solid_shell_bar.bdf": None,
    "pynastran_solid_shell_bar_static/static_solid_shell_bar_global_radial_cd.bdf": None,
    "tacs_mdo_wingbox/wingbox.bdf": None,
}


#: decks whose modes alone take minutes here (about 3,000 shell grids): in CI they are read
#: and refused at an output point the deck does not have (the check after reading, before the
#: modes); their linear ROM is the slow test's
LARGE = {"aepw3_pazy_noskin_rigidtip/sol103_noskin_stiftip.dat",
         "aepw3_pazy_noskin_rigidtip/sol144_noskin.dat",
         "aepw3_pazy_noskin_rigidtip/sol144_noskin_tipmass.dat",
         "aepw3_pazy_skin_flutter_tipmass0/sol145.dat",
         "aepw3_pazy_skin_flutter_tipmass1/sol145.dat"}
#: a point no public deck has, and the refusal's words
MISSING_POINT = (["--dual", "0", "--output", "x=G99999999:T3"],
                 ("--output x", "grid 99999999 not found"))


def _decks_with_a_solution() -> set[str]:
    """Every deck of tests/decks with an executive control SOL card (the decks a user runs;
    the others are include files and results)."""
    found = set()
    for path in DECKS.glob("*/*"):
        if path.suffix.lower() in (".bdf", ".dat") and any(
                line.split()[:1] == ["SOL"] for line in
                path.read_text(errors="replace").upper().splitlines()[:200]):
            found.add(str(path.relative_to(DECKS)))
    return found


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    d = tmp_path_factory.mktemp("identify-decks")
    srv = ForkServer({**os.environ, "TORCHROM_CACHE": str(d / "cache")})
    yield srv
    srv.close()


def test_every_public_deck_is_listed():
    """A deck added to tests/decks gets its expected outcome here."""
    assert _decks_with_a_solution() == set(EXPECTED)


def _check(rc: int, out: str, err: str, rom: Path, expected) -> None:
    assert "Traceback" not in err and "Traceback" not in out, err
    if expected is None:
        assert rc == 0, err
        assert rom.is_file() and "wrote" in out
        return
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2, (rc, err)
    assert len(lines) == 1 and lines[0].startswith("torchrom identify: error: "), err
    for words in expected[1]:
        assert words in lines[0], (words, lines[0])
    assert not rom.exists(), "a refused identification wrote its ROM"


@pytest.mark.parametrize("deck", sorted(EXPECTED))
def test_identify_reads_every_public_deck(deck, server, tmp_path):
    """Works (the linear modes' ROM written) or refused in one line with its reason and what
    to do; never a traceback."""
    expected = MISSING_POINT if deck in LARGE else EXPECTED[deck]
    options = ["--dual", "0"] if expected is None else expected[0]
    rom = tmp_path / "rom.npz"
    rc, out, err = server.run(["identify", DECKS / deck, "--linear", "4", *options, "--out",
                               rom, "-q"], tmp_path)
    _check(rc, out, err, rom, expected)


@pytest.mark.slow
@pytest.mark.parametrize("dual", ["0", "1"])
@pytest.mark.parametrize("deck", sorted(d for d, e in EXPECTED.items() if e is None))
def test_identify_dual_modes_on_every_public_deck(deck, dual, tmp_path):
    """The fuller run: the linear ROM (the large decks' too) and one dual mode on each deck
    identified above (a plain process: the larger decks' dual-mode FE solves take minutes).
    The dual mode may be refused in one line (e.g. loads the FE cannot carry), never with a
    traceback."""
    import subprocess
    import sys

    from .conftest import REPO

    rom = tmp_path / "rom.npz"
    run = subprocess.run([sys.executable, "-m", "torchrom", "identify", str(DECKS / deck),
                          "--linear", "4", "--dual", dual, "--out", str(rom), "-q"],
                         capture_output=True, text=True, cwd=REPO, timeout=3600,
                         env={**os.environ, "PYTHONPATH": str(REPO)})
    if dual == "0":
        _check(run.returncode, run.stdout, run.stderr, rom, None)
        return
    assert "Traceback" not in run.stderr, run.stderr
    assert run.returncode == 0 or len(run.stderr.strip().splitlines()) == 1, run.stderr
