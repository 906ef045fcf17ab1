"""Bad input never gets a traceback or a silently wrong answer (issue 16).

Every case feeds one damaged input — a deck field, a configuration key, a ROM/aero file, a file
system fault or a misused API parameter — and checks: exit status 2 and a one-line message naming
the file, card/key and field (command line), or an :class:`InputError` naming the parameter
(API); and that the outputs that existed before are unchanged (nothing half-written, nothing
replaced). All inputs are tiny, so the module runs in seconds.
"""

from __future__ import annotations

import errno
import math
import os

import numpy as np
import pytest

from torchrom.cli import main
from torchrom.errors import InputError

DECK = """SOL 103
CEND
SPC = 1
METHOD = 10
BEGIN BULK
GRID    1               0.0     0.0     0.0
GRID    2               1.0     0.0     0.0
GRID    3               2.0     0.0     0.0
GRID    4               3.0     0.0     0.0
CBAR    1       1       1       2       0.0     0.0     1.0
CBAR    2       1       2       3       0.0     0.0     1.0
CBAR    3       1       3       4       0.0     0.0     1.0
PBAR    1       1       0.01    1.-5    2.-5    3.-5
MAT1    1       7.+10           0.3     2700.
CONM2   10      4               1.0
SPC1    1       123456  1
EIGRL   10                      4
ENDDATA
"""

CONFIG = """title = "bad input"
[model]
builtin = "van_der_pol_duffing"
frequencies_hz = [1.0, 2.3]
c1 = [-0.6, 0.05]
d3 = [1.0, 1.0]
k3 = [8.0, 0.0]
[initial]
q0 = 0.05
mode = 1
[integrator]
dt = 0.01
t_end = 4.0
[lco]
outputs = ["q1", "q2"]
[cases]
alpha = [0.0, 0.3]
gamma = 1.0
[run]
chunk_size = 1
"""


def _cli(capsys, argv):
    """(exit status, stderr) of ``torchrom argv`` run in-process."""
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse errors
        rc = exc.code
    return rc, capsys.readouterr().err


def _one_line_error(err: str, *words: str) -> None:
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert lines, "no message"
    assert "Traceback" not in err
    last = lines[-1]
    assert "error" in last, err
    for w in words:
        assert w in last, (w, last)


def _snapshot(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


# -- decks (torchrom modes) --
DECK_CASES = {
    # name: (replace old -> new, words the message must name)
    "negative area": (("0.01    1.-5", "-0.01   1.-5"), ("PBAR 1", "field A")),
    "negative density": (("2700.", "-2700."), ("MAT1 1", "field RHO")),
    "zero modulus": (("7.+10", "0.0  "), ("MAT1 1", "field E")),
    "poisson out of range": (("0.3 ", "0.7 "), ("MAT1 1", "field NU")),
    "nan coordinate": (("GRID    2               1.0", "GRID    2               nan"),
                       ("GRID 2", "finite")),
    "inf coordinate": (("GRID    2               1.0", "GRID    2               1.+400"),
                       ("GRID 2", "finite")),
    "huge coordinate": (("GRID    2               1.0", "GRID    2               1.+200"),
                        ("GRID 2", "X1-X3")),
    "nan inertia": (("1.-5", "nan "), ("PBAR 1", "finite")),
    "negative mass": (("CONM2   10      4               1.0",
                       "CONM2   10      4               -1.0"), ("CONM2 10", "field M")),
    "duplicate grid": (("GRID    3  ", "GRID    2  "), ("GRID 2", "duplicate")),
    "duplicate element": (("CBAR    3       1       3", "CBAR    2       1       3"),
                          ("CBAR 2", "duplicate")),
    "duplicate material": (("CONM2", "MAT1    1       7.+10           0.3     2600.\nCONM2"),
                           ("MAT1 1", "duplicate")),
    "no enddata": (("ENDDATA\n", ""), ("ENDDATA",)),
    "cut mid-way": (("PBAR    1", "\x00CUT"), ("ENDDATA",)),
    "missing property": (("CBAR    3       1", "CBAR    3       7"), ("CBAR 3", "PID")),
    "missing grid": (("CBAR    3       1       3       4", "CBAR    3       1       3       9"),
                     ("CBAR 3", "G2")),
    "missing material": (("PBAR    1       1 ", "PBAR    1       5 "), ("PBAR 1", "MID")),
    "bad spc component": (("SPC1    1       123456", "SPC1    1       123789"), ("SPC1",)),
    "bad bar offt": (("3       4       0.0     0.0     1.0",
                      "3       4       0.0     0.0     1.0     OGG"),
                     ("CBAR 3", "field OFFT", "GGG")),
    "pin flags leave a mechanism": (("3       4       0.0     0.0     1.0",
                                     "3       4       0.0     0.0     1.0\n        4       4"),
                                    ("CBAR 3", "fields PA/PB", "mechanism")),
    "no mass at all": (("MAT1    1       7.+10           0.3     2700.\n"
                        "CONM2   10      4               1.0",
                        "MAT1    1       7.+10           0.3"), ("modes", "no mass", "RHO")),
    "product of inertia too large": (("3.-5\n", "3.-5\n" + " " * 8 + "0.0     " * 8 + "\n"
                                      + " " * 24 + "2.-5\n"), ("PBAR 1", "field I12")),
}


def _deck(tmp_path, name: str) -> str:
    (old, new), _ = DECK_CASES[name]
    assert old in DECK
    text = DECK.replace(old, new)
    if new.startswith("\x00CUT"):
        text = DECK.split(old)[0]
    return text


@pytest.mark.parametrize("name", sorted(DECK_CASES))
def test_bad_deck(name, tmp_path, capsys):
    path = tmp_path / "wing.bdf"
    path.write_text(_deck(tmp_path, name))
    js = tmp_path / "modes.json"
    js.write_text("previous results\n")
    rc, err = _cli(capsys, ["modes", path, "--json", js, "--force"])
    assert rc == 2
    _one_line_error(err, "wing.bdf", *DECK_CASES[name][1])
    assert js.read_text() == "previous results\n"


def test_good_deck_reference(tmp_path, capsys):
    """The undamaged deck runs (so every failure above is the damage's)."""
    path = tmp_path / "wing.bdf"
    path.write_text(DECK)
    assert _cli(capsys, ["modes", path])[0] == 0


# -- configurations (torchrom sweep) --
CONFIG_CASES = {
    "dt above t_end": (("dt = 0.01", "dt = 10.0"), ("[integrator]", "t_end")),
    "step count": (("dt = 0.01", "dt = 1e-12"), ("[integrator]", "dt")),
    "nan q0": (("q0 = 0.05", "q0 = nan"), ("[initial] q0", "finite")),
    "q0 wrong size": (("q0 = 0.05", "q0 = [0.1, 0.2, 0.3]"), ("[initial] q0", "2 values")),
    "mode out of range": (("mode = 1", "mode = 5"), ("[initial] mode",)),
    "inf case value": (("gamma = 1.0", "gamma = inf"), ("[cases] gamma",)),
    "chunk size 0": (("chunk_size = 1", "chunk_size = 0"), ("[run] chunk_size",)),
    "unknown key": (("mode = 1", "mode = 1\nstart = 2"), ("[initial]", "start")),
    "string dt": (("dt = 0.01", 'dt = "0.01"'), ("[integrator] dt",)),
    "bad toml": (("[cases]", "[cases"), ("invalid TOML",)),
    "negative rtol": (('outputs = ["q1", "q2"]', 'outputs = ["q1", "q2"]\nrtol = -1.0'),
                      ("[lco]", "rtol")),
    "unknown output": (('outputs = ["q1", "q2"]', 'outputs = ["q1", "q9"]'), ("q9",)),
    "rom file missing": (('builtin = "van_der_pol_duffing"\nfrequencies_hz = [1.0, 2.3]\n'
                          'c1 = [-0.6, 0.05]\nd3 = [1.0, 1.0]\nk3 = [8.0, 0.0]',
                          'rom = "nowhere.npz"'), ("nowhere.npz",)),
    "rom file junk": (('builtin = "van_der_pol_duffing"\nfrequencies_hz = [1.0, 2.3]\n'
                       'c1 = [-0.6, 0.05]\nd3 = [1.0, 1.0]\nk3 = [8.0, 0.0]',
                       'rom = "junk.npz"'), ("junk.npz",)),
}


@pytest.mark.parametrize("name", sorted(CONFIG_CASES))
def test_bad_config(name, tmp_path, capsys):
    (old, new), words = CONFIG_CASES[name]
    assert old in CONFIG
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG.replace(old, new))
    (tmp_path / "junk.npz").write_text("not a zip file")
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("previous table\n")
    before = _snapshot(out)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc == 2
    _one_line_error(err, *words)
    assert _snapshot(out) == before  # no manifest, no part, nothing replaced


def test_chunk_size_option_zero_is_refused(tmp_path, capsys):
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out", "--chunk-size", "0"])
    assert rc == 2 and "--chunk-size" in err
    assert not (tmp_path / "out").exists()


# -- ROM and aero files (torchrom flutter ROM AERO) --
@pytest.mark.parametrize("damage", ["truncated", "missing"])
def test_bad_aero_file(damage, tmp_path, capsys):
    from torchrom.rom.analytic import van_der_pol_duffing

    rom = tmp_path / "rom.npz"
    van_der_pol_duffing([1.0, 2.0]).save(rom)
    aero = tmp_path / "aero.npz"
    if damage == "truncated":
        aero.write_bytes(b"PK\x03\x04 truncated zip")
    js = tmp_path / "flutter.json"
    js.write_text("old\n")
    rc, err = _cli(capsys, ["flutter", rom, aero, "--json", js, "--force"])
    assert rc == 2
    _one_line_error(err, "aero.npz")
    assert js.read_text() == "old\n"


# -- file system faults --
def test_json_not_replaced_without_force(tmp_path, capsys):
    path = tmp_path / "wing.bdf"
    path.write_text(DECK)
    js = tmp_path / "modes.json"
    js.write_text("mine\n")
    rc, err = _cli(capsys, ["modes", path, "--json", js])
    assert rc == 2
    _one_line_error(err, "modes.json", "--force")
    assert js.read_text() == "mine\n"


def test_out_is_a_file(tmp_path, capsys):
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    out.write_text("a file\n")
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc == 2
    _one_line_error(err, "out")
    assert out.read_text() == "a file\n"


def test_parts_is_a_file(tmp_path, capsys):
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    out.mkdir()
    (out / "parts").write_text("not a folder\n")
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc == 2
    _one_line_error(err, "parts")
    assert (out / "parts").read_text() == "not a folder\n"
    assert not (out / "results.csv").exists()


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes anywhere")
def test_unwritable_out_folder(tmp_path, capsys):
    path = tmp_path / "wing.bdf"
    path.write_text(DECK)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        rc, err = _cli(capsys, ["goland", "--out", locked / "sub"])
    finally:
        locked.chmod(0o700)
    assert rc == 2
    _one_line_error(err, "locked", "not writable")
    assert not (locked / "sub").exists()


def test_disk_full_keeps_previous_outputs(tmp_path, capsys, monkeypatch):
    """A full disk while the tables are written (ENOSPC from the parquet writer): one line,
    exit 2, the previous table untouched and no temporary file left."""
    import pandas as pd

    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.parquet").write_bytes(b"previous")

    original = pd.DataFrame.to_parquet

    def full(self, path, *a, **k):
        if "results" not in str(path):  # part files (and in-memory buffers) are written
            return original(self, path, *a, **k)
        with open(path, "wb") as f:
            f.write(b"half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out, "--force"])
    assert rc == 2
    _one_line_error(err, "results.parquet", os.strerror(errno.ENOSPC))
    assert (out / "results.parquet").read_bytes() == b"previous"
    assert not list(out.glob(".results.parquet.*"))
    assert len(list((out / "parts").glob("part-*.parquet"))) == 2  # computed chunks kept: resume


def test_figure_failure_keeps_the_tables(tmp_path, capsys, monkeypatch):
    """matplotlib failing after the table is written: a warning, exit 1, tables kept."""
    import torchrom.study.plots as plots

    def broken(*a, **k):
        raise OverflowError("cannot place 1e308")

    monkeypatch.setattr(plots, "parameter_plot", broken)
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc == 1
    assert "warning: figure not written" in err and "Traceback" not in err
    assert (out / "results.parquet").exists() and (out / "results.csv").exists()


def test_plot_out_not_replaced(tmp_path, capsys):
    table = tmp_path / "t.csv"
    table.write_text("gamma,alpha\n1e-4,0.1\n2e-4,0.2\n")
    fig = tmp_path / "fig.png"
    fig.write_bytes(b"mine")
    rc, err = _cli(capsys, ["plot", table, "--figure", "fig9", "--out", fig])
    assert rc == 2
    _one_line_error(err, "fig.png", "--force")
    assert fig.read_bytes() == b"mine"


# -- API misuse --
def _rom():
    from torchrom.rom.analytic import van_der_pol_duffing

    return van_der_pol_duffing([1.0, 2.0])


def _api_cases():
    from torchrom.sim import CaseSystem, LCOCriteria, Newmark

    rom = _rom()
    return {
        "dt string": (lambda: Newmark(dt="0.1"), "integrator.dt"),
        "dt bool": (lambda: Newmark(dt=True), "integrator.dt"),
        "dt nan": (lambda: Newmark(dt=math.nan), "integrator.dt"),
        "iterations float": (lambda: Newmark(iterations=2.5), "integrator.iterations"),
        "build None": (lambda: CaseSystem.build(None), "rom"),
        "batch 0": (lambda: CaseSystem.build(rom, 0), "batch"),
        "alpha nan": (lambda: CaseSystem.build(rom, alpha=[0.1, math.nan]), "alpha"),
        "gamma string": (lambda: CaseSystem.build(rom, gamma="big"), "gamma"),
        "t_end below dt": (lambda: Newmark(dt=1.0).run(CaseSystem.build(rom), [0.1, 0.0],
                                                       t_end=0.1), "t_end"),
        "dt tiny": (lambda: Newmark(dt=1e-12).run(CaseSystem.build(rom), [0.1, 0.0],
                                                  t_end=200.0), "dt"),
        "run without system": (lambda: Newmark().run(None, [0.1, 0.0], t_end=1.0), "system"),
        "lco cycles string": (lambda: LCOCriteria(cycles="4"), "lco.cycles"),
        "lco rtol nan": (lambda: LCOCriteria(rtol=math.nan), "lco.rtol"),
        "q0 wrong size": (lambda: Newmark().run(CaseSystem.build(rom), [0.1, 0.0, 0.3],
                                                t_end=1.0), "q0"),
        "v0 string": (lambda: Newmark().run(CaseSystem.build(rom), [0.1, 0.0], "fast",
                                            t_end=1.0), "v0"),
        "rom frequencies string": (lambda: __import__(
            "torchrom.rom.analytic", fromlist=["x"]).van_der_pol_duffing("x"), "frequencies_hz"),
    }


API_NAMES = ["dt string", "dt bool", "dt nan", "iterations float", "build None", "batch 0",
             "alpha nan", "gamma string", "t_end below dt", "dt tiny", "run without system",
             "lco cycles string", "lco rtol nan", "q0 wrong size", "v0 string",
             "rom frequencies string"]


@pytest.mark.parametrize("name", API_NAMES)
def test_api_misuse(name):
    call, parameter = _api_cases()[name]
    with pytest.raises(InputError, match=parameter.replace(".", r"\.")) as info:
        call()
    assert "\n" not in str(info.value)


def test_modes_count_validated():
    from tests.fe_decks import model_of, two_bar_truss
    from torchrom.fe.solvers import modal_analysis

    fe = model_of(two_bar_truss(1.0, 0.5, 1.0))
    for n in (0, 2.5, True):
        with pytest.raises(InputError, match="modes: n: expected a positive number"):
            modal_analysis(fe, n)


def test_nan_case_never_changes_its_neighbours():
    """A case with a non-finite load and a diverging one beside good cases: marked failed /
    diverged with NaN amplitude, and the good cases bitwise equal to a batch without them."""
    import torch

    from torchrom.sim import CaseSystem, LCOCriteria, Newmark

    rom = _rom()
    load = torch.zeros(4, 2, dtype=torch.float64)
    load[1, 0] = math.nan
    alpha = [0.1, 0.1, -5.0, 0.2]
    crit = LCOCriteria(max_amplitude=50.0)
    run = Newmark(dt=0.01).run(CaseSystem.build(rom, 4, alpha=alpha, load=load),
                               [[0.1, 0.0]] * 4, t_end=20.0, lco=crit)
    assert run.status[1] == "failed" and run.status[2] == "diverged"
    assert np.isnan(run.amplitude[[1, 2]]).all() and np.isnan(run.frequency_hz[[1, 2]]).all()
    good = Newmark(dt=0.01).run(CaseSystem.build(rom, 2, alpha=[0.1, 0.2]), [[0.1, 0.0]] * 2,
                                t_end=20.0, lco=crit)
    assert (good.status == run.status[[0, 3]]).all()
    np.testing.assert_array_equal(good.q, run.q[[0, 3]])


def test_changed_case_grid_does_not_replace_a_finished_table(tmp_path, capsys):
    """A finished sweep, then the same configuration with another case grid into the same
    folder: refused (the table of the first grid stays) unless --force."""
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    assert _cli(capsys, ["sweep", cfg, "--out", out])[0] == 0
    before = _snapshot(out)
    cfg.write_text(CONFIG.replace("alpha = [0.0, 0.3]", "alpha = [0.0, 0.3, 0.6]"))
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc == 2
    _one_line_error(err, "results.parquet", "another case grid", "--force")
    assert _snapshot(out) == before


def test_permission_denied_while_writing(tmp_path, capsys, monkeypatch):
    """The file system refusing a write (EACCES, as for a read-only folder when not root):
    exit 2, one line, the deck not half-written."""
    import torchrom.io as tio

    def denied(*a, **k):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(tmp_path / "g"))

    monkeypatch.setattr(tio.tempfile, "mkstemp", denied)
    rc, err = _cli(capsys, ["goland", "--out", tmp_path / "g"])
    assert rc == 2
    _one_line_error(err, "goland.bdf", os.strerror(errno.EACCES))
    assert not (tmp_path / "g" / "goland.bdf").exists()


def test_extreme_alpha_is_no_traceback(tmp_path, capsys):
    """α = 1e308 (finite, so a valid case value): the cases are decided or marked, the table is
    written, and whatever the figure makes of it is at most a warning (exit 0 or 1)."""
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG.replace("alpha = [0.0, 0.3]", "alpha = [0.0, 1e308]"))
    out = tmp_path / "out"
    rc, err = _cli(capsys, ["sweep", cfg, "--out", out])
    assert rc in (0, 1) and "Traceback" not in err
    assert (out / "results.csv").exists()


@pytest.mark.parametrize("command", ["goland", "aero", "identify", "paper"])
def test_json_of_every_command_is_not_replaced(command, tmp_path, capsys):
    """The --json file of every command is checked with the other outputs, before any work."""
    js = tmp_path / "old.json"
    js.write_text("mine\n")
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    argv = {"goland": ["goland", "--out", tmp_path / "g"],
            "aero": ["aero", deck, "--mach", "0.5", "--out", tmp_path / "aero.npz"],
            "identify": ["identify", deck, "--out", tmp_path / "rom.npz"],
            "paper": ["paper", "--out", tmp_path / "p", "--quick"]}[command]
    rc, err = _cli(capsys, [*argv, "--json", js])
    assert rc == 2
    _one_line_error(err, "old.json", "--force")
    assert js.read_text() == "mine\n"
    assert not (tmp_path / "g").exists() and not (tmp_path / "aero.npz").exists()


def test_free_free_dual_combination_on_a_rigid_body_mode(tmp_path, capsys):
    """identify on an unconstrained deck (free-free structures are identified with their
    rigid-body modes at 0 Hz) asked for a dual-mode combination that loads a rigid-body mode:
    its load K U is zero, so a clear error naming the combination and what to give. (``--report``
    on a free structure validates under inertia relief: tests/test_identify_validate.py.)"""
    deck = tmp_path / "free.bdf"
    deck.write_text(DECK.replace("SPC1    1       123456  1\n", "").replace("SPC = 1\n", ""))
    rc, err = _cli(capsys, ["identify", deck, "--linear", "2", "--dual", "1", "--combinations",
                            "1:1", "--out", tmp_path / "rom.npz"])
    assert rc == 2
    _one_line_error(err, "combination (1, 1)", "rigid-body mode", "--combinations transverse")
    assert not (tmp_path / "rom.npz").exists()


@pytest.mark.parametrize("damage", ["nan density", "no enddata"])
def test_bad_flutter_deck(damage, pt145_deck, tmp_path, capsys):
    """pt145 with a NaN in its FLFACT densities or cut before ENDDATA: exit 2, card named."""
    text = pt145_deck.read_text()
    if damage == "nan density":
        text, words = text.replace("FLFACT  1       0.967 ", "FLFACT  1       nan   "), (
            "FLFACT 1", "finite")
    else:
        text, words = text.replace("ENDDATA", ""), ("ENDDATA",)
    deck = tmp_path / "pt145.bdf"
    deck.write_text(text)
    js = tmp_path / "flutter.json"
    js.write_text("old\n")
    rc, err = _cli(capsys, ["flutter", deck, "--json", js, "--force"])
    assert rc == 2
    _one_line_error(err, "pt145.bdf", *words)
    assert js.read_text() == "old\n"


OPTION_CASES = {
    "calibrate --rtol": (["calibrate", "{cfg}", "--target", "0.1", "--rtol", "-1"], "--rtol"),
    "calibrate --target": (["calibrate", "{cfg}", "--target", "nan"], "--target"),
    "bifurcation --refine": (["bifurcation", "{cfg}", "--refine", "-1"], "--refine"),
    "bifurcation --q0": (["bifurcation", "{cfg}", "--q0", "0", "1"], "--q0"),
    "modes --n": (["modes", "{deck}", "--n", "0"], "--n"),
    "goland --density": (["goland", "--density", "nan"], "--density"),
    "aero --mach": (["aero", "{deck}", "--mach", "-0.5"], "--mach"),
    "identify --amplitude": (["identify", "{deck}", "--amplitude", "0"], "--amplitude"),
}


@pytest.mark.parametrize("name", sorted(OPTION_CASES))
def test_bad_option_value(name, tmp_path, capsys):
    """A numeric option out of range is refused by the parser (exit 2, the option named)
    before anything is read or written."""
    cfg, deck, out = tmp_path / "sweep.toml", tmp_path / "wing.bdf", tmp_path / "out"
    cfg.write_text(CONFIG)
    deck.write_text(DECK)
    argv, option = OPTION_CASES[name]
    argv = [a.format(cfg=cfg, deck=deck) for a in argv] + ["--out", out]
    rc, err = _cli(capsys, argv)
    assert rc == 2
    _one_line_error(err, f"argument {option}")
    assert not out.exists()


def test_flutter_figure_failure_keeps_the_json(pt145_deck, tmp_path, capsys, monkeypatch):
    """The V-g figure failing after the pt145 flutter solution: warning, exit 1, JSON written."""
    import torchrom.aero.plots as aero_plots

    def broken(*a, **k):
        raise ValueError("Image size of 1e308 pixels is too large")

    monkeypatch.setattr(aero_plots, "plot_vg", broken)
    js = tmp_path / "flutter.json"
    rc, err = _cli(capsys, ["flutter", pt145_deck, "--json", js, "--plot",
                            tmp_path / "vg.png"])
    assert rc == 1 and "warning: figure not written" in err and "Traceback" not in err
    assert js.exists() and not (tmp_path / "vg.png").exists()


# -- issue 26: tracebacks, silent answers with exit 0, output hygiene --
def test_negative_wtmass(tmp_path, capsys):
    deck = tmp_path / "wing.bdf"
    for value, words in (("-0.5", ("PARAM WTMASS", "positive")), ("0.0", ("PARAM WTMASS",))):
        deck.write_text(DECK.replace("BEGIN BULK\n", f"BEGIN BULK\nPARAM   WTMASS  {value}\n"))
        rc, err = _cli(capsys, ["modes", deck])
        assert rc == 2
        _one_line_error(err, "wing.bdf", *words)


@pytest.mark.parametrize("device", ["meta", "xla", "cuda:99", "nonsense"])
def test_device_types(device, tmp_path, capsys):
    import torch

    if device == "cuda:99" and torch.cuda.is_available() and torch.cuda.device_count() > 99:
        pytest.skip("a machine with 100 GPUs")
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out", "--device", device])
    assert rc == 2
    _one_line_error(err, "--device")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["fig.exe", "fig", "fig.png.txt"])
def test_plot_figure_suffix(name, tmp_path, capsys):
    table = tmp_path / "t.csv"
    table.write_text("gamma,alpha\n1e-4,0.1\n2e-4,0.2\n")
    rc, err = _cli(capsys, ["plot", table, "--figure", "fig9", "--out", tmp_path / name])
    assert rc == 2
    _one_line_error(err, "--out", ".png")
    assert not (tmp_path / name).exists()


PHYSICAL_CASES = {
    # [cases] replacement -> words
    "negative gamma": (("gamma = 1.0", "gamma = -1.0"), ("[cases] gamma", ">= 0")),
    "negative gamma in a list": (("gamma = 1.0", "gamma = [1.0, -1e-4]"),
                                 ("[cases] gamma", "case")),
    "negative damping scale": (("gamma = 1.0", "gamma = 1.0\ndamping_nl = -1.0"),
                               ("[cases] damping_nl",)),
    "negative stiffness scale": (("gamma = 1.0", "gamma = 1.0\nstiffness_nl = -2.0"),
                                 ("[cases] stiffness_nl",)),
}


@pytest.mark.parametrize("name", sorted(PHYSICAL_CASES))
def test_physical_range_of_case_parameters(name, tmp_path, capsys):
    """γ < 0 was accepted by sweep (exit 0, a "matched" α and "diverged") while flutter --gamma
    refused it: one table (checks.PHYSICAL_RANGES) now serves every entry point."""
    (old, new), words = PHYSICAL_CASES[name]
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG.replace(old, new))
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, *words)
    assert not (tmp_path / "out").exists()


def test_physical_range_in_every_entry_point(tmp_path, capsys):
    from torchrom.aero.flutter import ModalStructure, alpha_for_gammas
    from torchrom.sim import CaseSystem

    rom = _rom()
    with pytest.raises(InputError, match="CaseSystem.build: gamma"):
        CaseSystem.build(rom, gamma=[1e-3, -1e-3])
    with pytest.raises(InputError, match="damping_nl"):
        CaseSystem.build(rom, damping_nl=-1.0)
    with pytest.raises(InputError, match="modal structure: gamma"):
        ModalStructure.from_modes([1.0, 2.0], gamma=-1e-4)
    with pytest.raises(InputError, match="matched alpha: gamma"):
        alpha_for_gammas(ModalStructure.from_modes([1.0, 2.0]), None, [-1.0], 0.5, 0.0)
    # the command line options use the same table
    rc, err = _cli(capsys, ["flutter", "goland", "--gamma=-1e-4"])
    assert rc == 2 and "--gamma" in err and ">= 0" in err
    rc, err = _cli(capsys, ["flutter", "goland", "--mach", "1.2"])
    assert rc == 2 and "--mach" in err and "subsonic" in err
    # branch bounds
    cfg = tmp_path / "sweep.toml"
    cfg.write_text(CONFIG)
    rc, err = _cli(capsys, ["branch", cfg, "--out", tmp_path / "b", "--parameter", "gamma",
                            "--range", "-1", "1"])
    assert rc == 2
    _one_line_error(err, "branch bounds gamma", ">= 0")
    for bad in (["--range", "nan", "1"], ["--harmonics", "-3"], ["--max-points", "0"]):
        rc, err = _cli(capsys, ["branch", cfg, "--out", tmp_path / "b", "--parameter", "alpha",
                                *bad])
        assert rc == 2 and bad[0] in err


def _plate_deck(n: int = 2, width: float = 1.0, depth: float = 0.5) -> str:
    """A clamped n x n CQUAD4 plate, width (x) by depth (y)."""
    lines = ["SOL 103", "CEND", "SPC = 1", "METHOD = 10", "BEGIN BULK"]
    for j in range(n + 1):
        for i in range(n + 1):
            lines.append(f"GRID,{1 + i + (n + 1) * j},,{width * i / n},{depth * j / n},0.0")
    for j in range(n):
        for i in range(n):
            g = 1 + i + (n + 1) * j
            lines.append(f"CQUAD4,{1 + i + n * j},1,{g},{g + 1},{g + n + 2},{g + n + 1}")
    lines += ["PSHELL,1,1,0.01,1,,1", "MAT1,1,7.+10,,0.3,2700.",
              f"SPC1,1,123456,1,THRU,{n + 1}", "EIGRL,10,,,4", "ENDDATA"]
    return "\n".join(lines) + "\n"


def test_goland_planform_on_a_small_plate(tmp_path, capsys):
    """The 6 x 20 ft Goland planform splined onto a 1 x 0.5 plate (exit 0 before): refused."""
    deck = tmp_path / "plate.bdf"
    deck.write_text(_plate_deck())
    rc, err = _cli(capsys, ["aero", deck, "--mach", "0.5", "--planform", "goland", "--modes",
                            "2", "--out", tmp_path / "aero.npz"])
    assert rc == 2
    # its longest side is its span (torchrom.fe.wing_frame)
    _one_line_error(err, "span 0 .. 1 along the wing's span", "Goland", "CAERO")
    assert not (tmp_path / "aero.npz").exists()


def test_eigrl_band_is_noted(tmp_path, capsys):
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK.replace("EIGRL   10                      4",
                                 "EIGRL   10      20.0    100.0   4"))
    rc = main(["modes", str(deck)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "note: EIGRL 10: frequency band 20.0 .. 100.0 Hz not applied" in out


UPDATE_PARAMETER = """
[[parameter]]
name = "rho"
card = "MAT1"
ids = [1]
field = "rho"
lower = 1000.0
upper = 5000.0
"""


@pytest.mark.parametrize("case", ["1 MHz", "1 mHz", "same mode", "unreachable"])
def test_update_implausible_targets(case, tmp_path, capsys):
    """Targets 1 MHz away (100 % misfit, deck written, exit 0 before), two targets on one mode
    (silently re-paired before), a target the bounds cannot reach: exit 2, no deck written."""
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)  # mode 1: 9.32 Hz
    targets = {
        "1 MHz": ("[[target]]\nfrequency_hz = 1e6\nmode = 1\n", ("target 1", "factor 10")),
        "1 mHz": ("[[target]]\nfrequency_hz = 1e-3\nmode = 1\n", ("target 1", "factor 10")),
        "same mode": ("[[target]]\nfrequency_hz = 9.0\nmode = 1\n"
                      "[[target]]\nfrequency_hz = 9.5\nmode = 1\n",
                      ("targets 1 and 2", "mode 1")),
        # rho in [1000, 5000] moves mode 1 by at most 26 %: 2 Hz stays > 50 % off
        "unreachable": ("[[target]]\nfrequency_hz = 2.0\nmode = 1\n",
                        ("still", "not written")),
    }[case]
    spec = tmp_path / "targets.toml"
    spec.write_text(targets[0] + UPDATE_PARAMETER)
    rc, err = _cli(capsys, ["update", deck, "--targets", spec, "--out", tmp_path / "new.bdf"])
    assert rc == 2
    _one_line_error(err, *targets[1])
    assert not (tmp_path / "new.bdf").exists()


@pytest.mark.parametrize("where", ["absolute", "parent", "device"])
def test_include_outside_the_deck_folder(where, tmp_path, capsys, monkeypatch):
    """An INCLUDE of a file outside the deck's folder and the working directory is refused by
    policy before it is read, and nothing of its content reaches the message."""
    secret = tmp_path / "secret.txt"
    secret.write_text("root:SECRETHASH:0:0:root\n")
    decks = tmp_path / "decks"
    decks.mkdir()
    cwd = tmp_path / "work"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    target = {"absolute": str(secret), "parent": "../secret.txt", "device": "/dev/zero"}[where]
    deck = decks / "wing.bdf"
    deck.write_text(DECK.replace("BEGIN BULK\n", f"BEGIN BULK\nINCLUDE '{target}'\n"))
    rc, err = _cli(capsys, ["modes", deck])
    assert rc == 2
    _one_line_error(err, "wing.bdf", "INCLUDE", "outside")
    assert "SECRET" not in err


def test_include_beside_the_deck_is_read(tmp_path, capsys):
    (tmp_path / "mass.inc").write_text("CONM2   11      3               0.5\n")
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK.replace("BEGIN BULK\n", "BEGIN BULK\nINCLUDE 'mass.inc'\n"))
    assert _cli(capsys, ["modes", deck])[0] == 0


def test_reference_deck_outside_is_refused(tmp_path, capsys, monkeypatch):
    secret = tmp_path / "secret.bdf"
    secret.write_text("root:SECRETHASH\n")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    (work / "wing.bdf").write_text(DECK)
    (work / "targets.toml").write_text(f"[reference]\ndeck = '{secret}'\n[[target]]\n"
                                       f"frequency_hz = 9.0\nmode = 1\n{UPDATE_PARAMETER}")
    rc, err = _cli(capsys, ["update", "wing.bdf", "--targets", "targets.toml", "--out",
                            "new.bdf"])
    assert rc == 2
    _one_line_error(err, "[reference] deck", "outside")
    assert "SECRET" not in err and not (work / "new.bdf").exists()


def test_unsupported_warn_prints_no_python_warning_line(tmp_path):
    """--unsupported warn printed Python's raw warning line (file:line: UnsupportedCardWarning
    and the source line) before its note; run as a process, where Python prints warnings."""
    import subprocess
    import sys
    from pathlib import Path

    import torchrom

    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK.replace("BEGIN BULK\n", "BEGIN BULK\nCDAMP1  100     7       2       "
                                 "1\nPDAMP   7       10.0\n"))
    env = {**os.environ, "PYTHONPATH": str(Path(torchrom.__file__).parents[1])}
    run = subprocess.run([sys.executable, "-m", "torchrom", "modes", str(deck), "--unsupported",
                          "warn"], capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "Warning" not in run.stderr and "warnings.warn" not in run.stderr, run.stderr
    assert "note: ignored unsupported cards: CDAMP1" in run.stdout


def test_other_python_warnings_are_one_line(tmp_path, capsys, monkeypatch):
    import warnings

    import torchrom.commands.modes as modes_cmd

    original = modes_cmd.run

    def noisy(args):
        warnings.warn("something odd\nover two lines", RuntimeWarning, stacklevel=1)
        return original(args)

    monkeypatch.setattr(modes_cmd, "run", noisy)
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    from torchrom.cli import build_parser

    args = build_parser().parse_args(["modes", str(deck)])
    assert args._run is noisy
    rc = main(["modes", str(deck)])
    err = capsys.readouterr().err
    assert rc == 0
    assert "torchrom modes: warning: something odd over two lines" in err
    assert "RuntimeWarning" not in err


def test_stale_temporary_figure_is_removed(tmp_path):
    """A writer killed mid-write (SIGKILL: no finally) leaves .NAME.PID.*.part.png: the next
    write of NAME removes it (its process is gone); a live writer's is kept."""
    import subprocess
    import sys

    from torchrom.io import atomic_path, remove_stale_parts

    fig = tmp_path / "fig.png"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = tmp_path / f".fig.png.{int(dead.stdout)}.abc123.part.png"
    stale.write_bytes(b"half a figure")
    live = tmp_path / f".fig.png.{os.getpid()}.def456.part.png"
    live.write_bytes(b"being written")
    old = tmp_path / ".fig.png.xyz.part.png"  # no process id, older than an hour
    old.write_bytes(b"old")
    os.utime(old, (0, 0))
    with atomic_path(fig) as tmp:
        tmp.write_bytes(b"new figure")
    assert fig.read_bytes() == b"new figure"
    assert not stale.exists() and not old.exists() and live.exists()
    assert remove_stale_parts(fig) == []


def test_star_import_exports_existing_modules():
    import torchrom

    ns: dict = {}
    exec("from torchrom import *", ns)
    for name in ("periodic", "paper", "study", "NonlinearROM", "InputError"):
        assert name in ns
    assert "plots" not in torchrom.__all__


def test_damaged_cache_files_are_rebuilt(tmp_path):
    """A cached JSON damaged since it was written (flutter.json truncated: its SHA-256 differs
    from the manifest's) is refused in one line naming --force, not a traceback, and rebuilt
    under force; one that no longer parses without a recorded hash (an older manifest) is a
    miss; a damaged cache.json is replaced under --force, as its message advises."""
    import json

    from torchrom.paper.cache import MANIFEST, FileCache

    cache = FileCache(tmp_path)
    key = FileCache.key({"a": 1})
    cache.put("flutter.json", key, lambda p: p.write_text('{"ok": 1}'))
    assert FileCache(tmp_path).get_json("flutter.json", key) == {"ok": 1}
    (tmp_path / "flutter.json").write_text('{"ok": ')
    with pytest.raises(InputError, match="--force"):
        FileCache(tmp_path).get_json("flutter.json", key)
    assert FileCache(tmp_path, force=True).get_json("flutter.json", key) is None
    manifest = json.loads((tmp_path / MANIFEST).read_text())
    manifest["files"]["flutter.json"].pop("sha256")
    (tmp_path / MANIFEST).write_text(json.dumps(manifest))
    again = FileCache(tmp_path)
    assert again.get_json("flutter.json", key) is None and not again.hits
    (tmp_path / MANIFEST).write_text("{ not json")
    with pytest.raises(InputError, match="paper --force"):
        FileCache(tmp_path)
    forced = FileCache(tmp_path, force=True)
    forced.put("flutter.json", key, lambda p: p.write_text('{"ok": 2}'))
    assert FileCache(tmp_path).get_json("flutter.json", key) == {"ok": 2}


@pytest.mark.parametrize("argv, words", [
    (["--alt-range", "40000", "0"], ("--alt-range", "LO < HI")),
    (["--alt-range", "0", "1e9"], ("--alt-range", "USSA-76")),
    (["--at", "1e9"], ("--at", "USSA-76")),
])
def test_flutter_altitudes(argv, words, capsys):
    rc, err = _cli(capsys, ["flutter", "goland", *argv])
    assert rc == 2
    _one_line_error(err, *words)


def test_altitude_of_a_case_in_the_atmosphere(tmp_path, capsys):
    from torchrom.checks import physical

    assert physical("altitude_ft", 11000.0) == 11000.0
    with pytest.raises(InputError, match=r"\[cases\] altitude_ft.*USSA-76"):
        physical("altitude_ft", 1e9, "[cases]")


@pytest.mark.parametrize("old, new, words", [
    ("0.01    1.-5", "1.+300  1.-5", ("PBAR 1", "1e+100")),
    ("7.+10", "1.+300", ("MAT1 1", "1e+100")),
])
def test_absurd_field_magnitude(old, new, words, tmp_path, capsys):
    """A field of 1e300 overflowed the assembled matrices (an "infs or NaNs" traceback)."""
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK.replace(old, new))
    rc, err = _cli(capsys, ["modes", deck])
    assert rc == 2
    _one_line_error(err, "wing.bdf", *words)


@pytest.mark.parametrize("optimizer, words", [
    ("tolerance = 1e-300", ("tolerance", "1e-15")),
    ("max_evaluations = 1000000000", ("max_evaluations", "--allow-large")),
])
def test_update_optimizer_settings(optimizer, words, tmp_path, capsys):
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    spec = tmp_path / "targets.toml"
    spec.write_text(f"[[target]]\nfrequency_hz = 9.0\nmode = 1\n[optimizer]\n{optimizer}\n"
                    f"{UPDATE_PARAMETER}")
    rc, err = _cli(capsys, ["update", deck, "--targets", spec, "--out", tmp_path / "new.bdf"])
    assert rc == 2
    _one_line_error(err, *words)
    assert not (tmp_path / "new.bdf").exists()


def test_unread_params_are_noted(tmp_path, capsys):
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK.replace("BEGIN BULK\n", "BEGIN BULK\nPARAM   K6ROT   100.\n"))
    assert main(["modes", str(deck)]) == 0
    assert "note: PARAM K6ROT: not applied" in capsys.readouterr().out


@pytest.mark.parametrize("param, words", [("VREF    -1.", ("PARAM VREF", "positive")),
                                          ("LMODES  -3", ("PARAM LMODES", ">= 0"))])
def test_flutter_deck_params(param, words, pt145_deck, tmp_path, capsys):
    text = pt145_deck.read_text()
    key = param.split()[0]
    lines = [ln for ln in text.splitlines() if not ln.startswith(f"PARAM   {key}")]
    text = "\n".join(lines).replace("ENDDATA", f"PARAM   {param}\nENDDATA") + "\n"
    deck = tmp_path / "pt145.bdf"
    deck.write_text(text)
    rc, err = _cli(capsys, ["flutter", deck])
    assert rc == 2
    _one_line_error(err, "pt145.bdf", *words)


def test_identification_amplitude_beyond_the_span(tmp_path, capsys):
    """--amplitude 1e6 (a million spans) identified a ROM and exited 0: refused."""
    deck = tmp_path / "wing.bdf"
    deck.write_text(DECK)
    rc, err = _cli(capsys, ["identify", deck, "--linear", "2", "--dual", "1", "--combinations",
                            "1:1", "--amplitude", "1e6", "--out", tmp_path / "rom.npz"])
    assert rc == 2
    _one_line_error(err, "amplitude", "0.5")
    assert not (tmp_path / "rom.npz").exists()


def test_update_report_says_a_target_was_re_paired():
    """A target whose paired mode changed during the fit is reported as a note (report and
    JSON), not re-paired silently."""
    from torchrom.commands.update import report_lines
    from torchrom.fe.update import UpdateResult

    target = {"name": "1st bending", "target_hz": 9.0, "initial_hz": 9.3,
              "initial_diff_pct": 3.3, "final_hz": 9.0, "final_diff_pct": 0.0, "mode": 2,
              "kind": "bending", "kind_ok": True, "mac": 0.97}
    res = UpdateResult({}, [target], [], [[0.1, 0.97]], 1.0, 1.0, True, "ok", 3, 2,
                       notes=["target 1st bending: paired with mode 1 at the start, mode 2 at "
                              "the end (MAC 0.970)"])
    assert any(line.startswith("note: target 1st bending: paired with mode 1")
               for line in report_lines(res))
    assert res.as_dict()["notes"] == res.notes


@pytest.mark.parametrize("line, words", [
    ("baseline_gamma = -1e-3", ("[aeroelastic] baseline_gamma", ">= 0")),
    ("baseline_alpha = 'x'", ("[aeroelastic] baseline_alpha", "number")),
    ("altitude_range_ft = ['a', 1]", ("[aeroelastic] altitude_range_ft",)),
])
def test_aeroelastic_table_values(line, words, tmp_path, capsys):
    """The [aeroelastic] values of a built-in Goland sweep are checked when the file is read
    (before the model is built): a string range raised a TypeError before."""
    cfg = tmp_path / "goland.toml"
    cfg.write_text("method = 'hb'\n[model]\nbuiltin = 'goland'\n[lco]\noutputs = ['A_Tz']\n"
                   f"[aeroelastic]\n{line}\n[cases]\naltitude_ft = 11000.0\ngamma = 0.0\n")
    rc, err = _cli(capsys, ["sweep", cfg, "--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, "goland.toml", *words)
    assert not (tmp_path / "out").exists()


def test_step_bound_is_checked_before_any_allocation(tmp_path, capsys, monkeypatch):
    """dt = 1e-12 on a shooting sweep (issue 37): refused from the configuration, naming dt,
    the steps per period and the bound, before any allocation; and with that bound removed the
    allocator's own failure (torch's RuntimeError "can't allocate memory" of ~1e14 bytes) is
    one line too, never a traceback."""
    config = tmp_path / "c.toml"
    config.write_text("method = \"shooting\"\n" + CONFIG.replace("dt = 0.01", "dt = 1e-12"))
    rc, err = _cli(capsys, ["sweep", config, "--out", tmp_path / "out"])
    assert rc == 2
    _one_line_error(err, "[integrator] dt", "steps per LCO period", "1e+08")
    assert not (tmp_path / "out").exists()

    import torchrom.study.config as config_module

    monkeypatch.setattr(config_module, "check_orbit_steps", lambda *a, **k: None)
    rc, err = _cli(capsys, ["sweep", config, "--out", tmp_path / "out", "-q"])
    assert rc == 2
    _one_line_error(err, "out of memory", "allocation of")
    assert len(err.strip().splitlines()) == 1
