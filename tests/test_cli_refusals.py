"""Every entry point refuses bad input the same way (issue 37): through the real command line,
in a separate process, each damaged input — a missing file, a folder, an empty, binary or
truncated file, a file of the wrong kind (a ROM .npz as a deck, a deck as a configuration or a
table), an unknown option value, a negative, zero, NaN or infinite number for every numeric
option (found from the parser itself, so a new option is covered), an output that exists without
--force, a configuration with unknown keys, wrong types or missing sections — gives exit status 2,
exactly one line on stderr and no traceback, and leaves the output location as it was.

The command lines run in children of one fork server (:mod:`tests.cli_forkserver`: the imports
are paid once), and two of them also as plain ``python -m torchrom`` processes to show that the
server changes nothing.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from .cli_forkserver import ForkServer
from .test_bad_input import CONFIG, DECK, UPDATE_PARAMETER

#: the public decks (tests/decks)
PUBLIC_DECKS = Path(__file__).parent / "decks"

#: files of every kind (relative to the fixture folder)
FILES = {"missing": "nope.bdf", "folder": "adir", "empty": "empty.bdf", "binary": "garbage.bin",
         "rom npz": "rom.npz", "aero npz": "aero.npz", "truncated deck": "trunc.bdf",
         "toml": "cfg.toml", "deck": "deck.bdf", "parquet": "table.parquet"}

#: damaged configurations: name -> (old, new) replaced in CONFIG, and the word the refusal names
CONFIGS = {
    "unknown key": (("[run]", "[run]\nbogus = 1"), "bogus"),
    "unknown section": (("[run]", "[bogus]\nx = 1\n[run]"), "bogus"),
    "wrong type": (("dt = 0.01", 'dt = "fast"'), "dt"),
    "table as a number": (("[lco]\n", "lco = 3\n[lcox]\n"), "lco"),
    "missing [model]": ((CONFIG[CONFIG.index("[model]"):CONFIG.index("[initial]")], ""),
                        "[model]"),
    "ROM is a deck": ((CONFIG[CONFIG.index("[model]"):CONFIG.index("[initial]")],
                       '[model]\nrom = "../deck.bdf"\n'), "[model] rom"),
    "ROM is an aero file": ((CONFIG[CONFIG.index("[model]"):CONFIG.index("[initial]")],
                             '[model]\nrom = "../aero.npz"\n'), "[model] rom"),
    "rigid-body support without aero": (
        (CONFIG[CONFIG.index("[model]"):CONFIG.index("[initial]")],
         '[model]\nrom = "../rom.npz"\nrigid_body_support_hz = 0.05\n'),
        "[model] rigid_body_support_hz: needs a model with aerodynamics"),
    "rigid-body support zero": (
        (CONFIG[CONFIG.index("[model]"):CONFIG.index("[initial]")],
         '[model]\nrom = "../rom.npz"\naero = "../aero.npz"\nrigid_body_support_hz = 0\n'),
        "rigid_body_support_hz: expected a positive number"),
    "missing t_end": (("t_end = 4.0\n", ""), "t_end"),
    "not toml": (("[model]", "[model"), "TOML"),
    "dt > t_end": (("dt = 0.01", "dt = 5.0"), "dt"),
    "dt 1e-12": (("dt = 0.01", "dt = 1e-12"), "dt"),
    "nan dt": (("dt = 0.01", "dt = nan"), "dt"),
    "inf t_end": (("t_end = 4.0", "t_end = inf"), "t_end"),
    "infinite q0": (("q0 = 0.05", "q0 = -inf"), "q0"),
    "zero batch": (("chunk_size = 1", "batch_size = 0"), "batch_size"),
    "no [cases], plot x": (("[cases]\nalpha = [0.0, 0.3]\ngamma = 1.0\n", ""), "[plot] x"),
    "plot y unknown": (("[run]", '[plot]\ny = "nonsense"\n[run]'), "[plot] y"),
    "history where none": (("[run]", "[history]\nwhere = {alpha = 9.0}\n[run]"),
                           "[history] where"),
    "history every > t_end": (("[run]", "[history]\nevery = 10000\n[run]"), "[history] every"),
    "certificate dt > t_end": (("[run]", "[certificate]\ndt = 9.0\n[run]"),
                               "[certificate] dt"),
    "certificate max_harmonics < 0": (("[run]", "[certificate]\nmax_harmonics = -1\n[run]"),
                                      "certificate.max_harmonics: expected an integer >= 0"),
    "certificate slow not a boolean": (("[run]", '[certificate]\nslow = "yes"\n[run]'),
                                       "certificate.slow: expected true or false"),
}

#: a continuation line of eight blank fields and the CORD2R/CORD1R cards of the damaged decks
_BLANK = " " * 8
#: damaged decks: name -> (old, new) replaced in DECK, the command, the words of the refusal
DECKS = {
    # pyNastran's own message was an unformatted 'len(CONM2 card) = {len(card):d}'
    "CONM2 too many fields": (
        ("CONM2   10      4               1.0",
         "CONM2   10      4               1.0\n" + _BLANK + "0.0     " * 8 + "\n" + _BLANK
         + "0.0     " * 6), "CONM2 10: too many fields"),
    # pyNastran's own message was 'v=[0. 0. 0.] norm(v)=0.0', no card, no ID
    "CORD2R collinear": (
        ("SPC1", "CORD2R  5               0.0     0.0     0.0     1.0     0.0     0.0\n"
         + _BLANK + "2.0     0.0     0.0\nSPC1"), "CORD2R 5: points A, B, C are collinear"),
    "CORD2S A = B": (
        ("SPC1", "CORD2S  5               1.0     0.0     0.0     1.0     0.0     0.0\n"
         + _BLANK + "2.0     1.0     0.0\nSPC1"), "CORD2S 5: points A and B coincide"),
    "CORD1R grids coincide": (("SPC1", "CORD1R  7       1       2       2\nSPC1"),
                              "CORD1R 7: grids G1, G2, G3 (1, 2, 2)"),
}

#: the file each folder-writing command writes first (an "output exists" case puts it there)
FOLDER_OUTPUT = {"sweep": "results.csv", "branch": "branch.csv", "bifurcation": "bifurcation.csv",
                 "calibrate": "calibration.csv", "paper": "report.md",
                 "goland": "goland.bdf"}

#: a valid targets file of ``torchrom update`` for DECK
UPDATE_TARGETS = UPDATE_PARAMETER + "\n[[target]]\nmode = 1\nfrequency_hz = 9.0\n"

#: a valid command line of each entry point ("OUT" is the output location of the case)
BASE = {
    "modes": ["deck.bdf", "--json", "OUT/modes.json"],
    "identify": ["deck.bdf", "--out", "OUT/rom.npz", "--linear", "2", "--dual", "0"],
    "aero": ["deck.bdf", "--mach", "0.5", "--out", "OUT/aero.npz", "--planform", "goland"],
    "flutter": ["rom.npz", "aero.npz", "--json", "OUT/flutter.json"],
    "sweep": ["cfg.toml", "--out", "OUT"],
    "plot": ["table.parquet", "--out", "OUT/fig.png", "--x", "alpha"],
    "paper": ["--out", "OUT", "--quick"],
    "goland": ["--out", "OUT"],
    "branch": ["cfg.toml", "--out", "OUT", "--parameter", "alpha", "--range", "0", "1"],
    "bifurcation": ["cfg.toml", "--out", "OUT"],
    "calibrate": ["cfg.toml", "--target", "0.1", "--out", "OUT"],
    "update": ["deck.bdf", "--targets", "targets.toml", "--out", "OUT/updated.bdf"],
    "cache": ["info", "--json", "OUT/cache.json"],
    # a command of main that this branch predates: its cases run once the command exists
    "static": ["deck.bdf", "--json", "OUT/static.json"],
    # issue 46: aerodynamic cards over a structure-only deck
    "panels": ["deck.bdf", "--out", "OUT/panels.bdf", "--units", "si"],
    # issue 47: mode shapes, the flutter mode and LCO motion for viewers
    "export": ["deck.bdf", "--out", "OUT/modes.vtu"],
}

#: values each numeric option type must refuse (the types of torchrom.commands._common)
BAD_VALUES = {
    "positive_int": ["0", "-1", "nan", "inf", "1.5", "x"],
    "nonnegative_int": ["-1", "nan", "inf", "x"],
    "positive_float": ["0", "-1", "nan", "inf", "x"],
    "nonnegative_float": ["-1", "nan", "inf", "x"],
    "finite_float": ["nan", "inf", "-inf", "x"],
    "cpu_workers": ["0", "-1", "x"],
    "thread_count": ["0", "-1", "100000"],
    "mach": ["-0.1", "1.0", "nan", "inf"],
    "gamma": ["-1", "nan", "inf"],
    "damping_ratio": ["-0.01", "1", "nan", "x", "0.02@0", "0.02@x"],
    "figure_file": ["fig.exe"],
    # plot --out: a figure or a GIF; export --out: .vtu, .xdmf or .op2 (issue 47)
    "picture_file": ["fig.exe"],
    "output_file": ["modes.txt", "modes"],
    "int": ["5", "x"],
    # flutter --g-tolerance: a damping g from 0 to 0.05 (issue 46)
    "g_tolerance": ["-1e-3", "0.06", "nan", "inf", "x"],
    # static --load GRID:COMPONENT=VALUE (issue 46)
    "point_load": ["x", "0:T3=1", "4:T9=1", "4:T3=x", "4:T3=nan", "4:T3=inf"],
}


def _parser_options():
    """(command, option, type name, nargs, choices) of every option of every command."""
    from torchrom.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sp in sub.choices.items():
        for a in sp._actions:
            if a.option_strings and a.type is not None:
                yield name, a.option_strings[0], getattr(a.type, "__name__", str(a.type)), \
                    a.nargs, a.choices
            elif a.option_strings and a.choices:
                yield name, a.option_strings[0], "choice", a.nargs, a.choices


def _with_option(command: str, option: str, values: list[str]) -> list[str]:
    argv = list(BASE[command])
    if option in argv:
        i = argv.index(option)
        argv[i + 1:i + 2] = values
        return argv
    return [*argv, option, *values]


def _commands() -> set[str]:
    return {c for c, *_ in _parser_options()}


def _cases() -> dict[str, tuple[list[str], str]]:
    """name -> (argv, a word the refusal must contain: the file, option or key at fault), for
    the commands the parser has."""
    cases = {}
    files = {k: Path(v).name for k, v in FILES.items()}
    # input files of every kind where a deck, a configuration, a table or a ROM is expected
    for command in ("modes", "identify", "aero", "update", "static", "panels", "export"):
        for kind in ("missing", "folder", "empty", "binary", "rom npz", "truncated deck",
                     "toml", "parquet"):
            cases[f"{command} deck={kind}"] = ([command, FILES[kind], *BASE[command][1:]],
                                               files[kind])
    for kind in ("missing", "folder", "empty", "binary", "rom npz", "aero npz",
                 "truncated deck", "toml"):
        cases[f"flutter input={kind}"] = (["flutter", FILES[kind]], files[kind])
    for kind in ("missing", "folder", "empty", "binary", "aero npz", "deck"):
        w = files[kind]
        cases[f"flutter rom={kind}"] = (["flutter", FILES[kind], "aero.npz"], w)
        cases[f"flutter aero={kind}"] = (["flutter", "rom.npz", FILES[kind]], w)
        cases[f"flutter goland --aero={kind}"] = (["flutter", "goland", "--aero", FILES[kind]], w)
        cases[f"modes --compare={kind}"] = (["modes", *BASE["modes"], "--compare", FILES[kind]],
                                             w)
        cases[f"update --targets={kind}"] = (
            ["update", *_with_option("update", "--targets", [FILES[kind]])], w)
        cases[f"plot --histories={kind}"] = (
            ["plot", FILES["parquet"], "--out", "OUT/fig.png", "--figure", "fig11", "--histories",
             FILES[kind]], w)
    for damage, (_, words) in DECKS.items():
        for command in ("modes", "flutter"):  # the FE reader and the aero reader
            cases[f"{command} deck: {damage}"] = ([command, f"bad/{damage}.bdf"], words)
    cases["aero deck without CAERO1"] = (["aero", "deck.bdf", "--mach", "0.5", "--out",
                                          "OUT/aero.npz"], "--planform goland")
    # the condensation takes no dual modes and no material tangents (identify --stiffness)
    cases["identify --stiffness condensed with dual modes"] = (
        ["identify", *_with_option("identify", "--dual", ["2"]), "--stiffness", "condensed"],
        "--dual 0")
    cases["identify --stiffness condensed --damping exact"] = (
        ["identify", *BASE["identify"], "--stiffness", "condensed", "--damping", "exact"],
        "stiffness 'tangent'")
    # a foil skin left out of the nonlinear terms (identify --linear-skin): condensation only,
    # and a property of the deck's shells
    condensed = [*BASE["identify"], "--stiffness", "condensed"]
    cases["identify --linear-skin with the tangent plan"] = (
        ["identify", *BASE["identify"], "--linear-skin", "1"],
        "--linear-skin: an option of --stiffness condensed")
    cases["identify --linear-skin of a missing property"] = (
        ["identify", *condensed, "--linear-skin", "99"], "--linear-skin 99: no property 99")
    cases["identify --linear-skin of a bar property"] = (
        ["identify", *condensed, "--linear-skin", "1"],
        "PBAR 1 is used by no CQUAD4 or CTRIA3")
    cases["identify --higher-amplitude with the tangent plan"] = (
        ["identify", *BASE["identify"], "--higher-amplitude", "0.1"],
        "higher_amplitude (--higher-amplitude) is an option of stiffness 'condensed'")
    cases["identify --higher-amplitude beyond half the span"] = (
        ["identify", *condensed, "--higher-amplitude", "0.9"],
        "higher_amplitude (--higher-amplitude): expected a fraction of the span in (0, 0.5]")
    # the ROM about a deformed state (identify --about-*): all four, a condensation, an aero
    # file of at most --linear modes
    about = ["--about-aero", "aero.npz", "--about-aoa", "5", "--about-velocity", "45",
             "--about-density", "1.225"]
    cases["identify --about-aero alone"] = (
        ["identify", *condensed, "--about-aero", "aero.npz"],
        "--about-*: a reference state needs --about-aoa, --about-velocity, --about-density")
    cases["identify --about-* with the tangent plan"] = (
        ["identify", *BASE["identify"], *about], "use --stiffness condensed")
    cases["identify --about-aero of a ROM file"] = (
        ["identify", *condensed, *about[2:], "--about-aero", "rom.npz"],
        "--about-aero: rom.npz is")
    # a ROM written without its shapes on the deck's grids (issue 47): identify again
    for command, argv in (("export", ["rom.npz", "--out", "OUT/basis.vtu"]),
                          ("export", ["rom.npz", "aero.npz", "--flutter", "--out", "OUT/f.op2"]),
                          ("plot", ["rom.npz", "--mode", "1", "--out", "OUT/mode.png"])):
        cases[f"{command} {' '.join(argv[:-2])}: no shapes"] = ([command, *argv],
                                                               "torchrom identify")
    cases["export --row without --sweep"] = (["export", *BASE["export"], "--row", "0"],
                                             "--row: needs --sweep")
    cases["export --flutter of a deck"] = (["export", *BASE["export"], "--flutter"],
                                           "--flutter: expected ROM.npz AERO.npz")
    cases["plot --mode to a GIF"] = (["plot", "deck.bdf", "--mode", "1", "--out", "OUT/m.gif"],
                                     "--out")
    cases["plot --scale of a table"] = (["plot", *BASE["plot"], "--scale", "2"], "--scale")
    cases["flutter ROM without its aero file"] = (["flutter", "rom.npz"],
                                                  "torchrom flutter rom.npz aero.npz")
    # decks the deck flutter cannot handle (issue 35 item 7): what is missing and what to do
    cases["flutter deck without CAERO1"] = (["flutter", "deck.bdf"], "torchrom panels")
    for deck, card in (("pynastran_bah_ha146c/ha146c.bdf", "SPLINE2 100: SET1 14: grids 1 and 2"),
                       ("pynastran_fmondsp/fmondsp.dat", "SPLINE5 29: SET1 29")):
        for command, extra in (("flutter", []), ("aero", ["--mach", "0.5", "--out",
                                                          "OUT/aero.npz"])):
            cases[f"{command} {deck.split('/')[0]}: two grids at one spline station"] = (
                [command, str(PUBLIC_DECKS / deck), *extra], card)
    for command in ("sweep", "branch", "bifurcation", "calibrate"):
        for kind in ("missing", "folder", "empty", "binary", "rom npz", "deck", "parquet"):
            cases[f"{command} config={kind}"] = ([command, FILES[kind], *BASE[command][1:]],
                                                 files[kind])
        for damage, (_, word) in CONFIGS.items():
            cases[f"{command} config: {damage}"] = (
                [command, f"bad/{damage}.toml", *BASE[command][1:]], word)
    for kind in ("missing", "folder", "empty", "binary", "rom npz", "deck", "toml"):
        cases[f"plot table={kind}"] = (["plot", FILES[kind], *BASE["plot"][1:]], files[kind])
    # every numeric option and every option with choices, from the parser
    for command, option, kind, nargs, _choices in _parser_options():
        n = nargs if isinstance(nargs, int) else 1
        values = ["bogus"] if kind == "choice" else BAD_VALUES.get(kind, [])
        for v in values:
            cases[f"{command} {option}={v}"] = (
                [command, *_with_option(command, option, [v] * n)], option)
    # outputs that exist, without --force
    for command, argv in BASE.items():
        cases[f"{command} output exists"] = ([command, *argv], "--force")
    cases["flutter --alt-range reversed"] = (
        ["flutter", *BASE["flutter"], "--alt-range", "9000", "1000"], "--alt-range")
    cases["cache clear --cache-dir=file"] = (["cache", "clear", "--cache-dir", "deck.bdf"],
                                             "--cache-dir")
    # the reduced frequencies' speed range and the flutter damping tolerance (issue 46)
    cases["aero --speeds reversed"] = (
        ["aero", *BASE["aero"], "--speeds", "500", "50"], "--speeds")
    cases["aero --speeds with the Goland planform"] = (
        ["aero", *BASE["aero"], "--speeds", "50", "500"], "--speeds: for a deck's own panels")
    cases["flutter --g-tolerance with --aoa"] = (
        ["flutter", *BASE["flutter"], "--aoa", "1", "--density", "1.2", "--g-tolerance",
         "1e-3"], "--g-tolerance: not with --aoa")
    for command, option in (("calibrate", "--gamma"), ("branch", "--range"),
                            ("bifurcation", "--q0")):
        cases[f"{command} {option} reversed"] = (
            [command, *_with_option(command, option, ["2", "1"])], option)
    commands = _commands()
    return {name: case for name, case in cases.items() if case[0][0] in commands}


CASES = _cases()


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    """The fixture folder (every file kind, damaged configurations) and the fork server."""
    import pandas as pd

    from torchrom.rom.analytic import van_der_pol_duffing

    d = tmp_path_factory.mktemp("refusals")
    (d / "deck.bdf").write_text(DECK)
    (d / "trunc.bdf").write_text(DECK.split("CONM2")[0])
    (d / "empty.bdf").write_text("")
    (d / "garbage.bin").write_bytes(bytes(range(256)) * 20)
    (d / "adir").mkdir()
    (d / "cfg.toml").write_text(CONFIG)
    (d / "targets.toml").write_text(UPDATE_TARGETS)
    van_der_pol_duffing([1.0, 2.0]).save(d / "rom.npz")
    np.savez(d / "aero.npz", rfa_kind=np.array("roger"), M=np.zeros(1))
    pd.DataFrame({"alpha": [0.0, 0.1], "amplitude": [1.0, 2.0],
                  "status": ["lco", "lco"]}).to_parquet(d / "table.parquet")
    (d / "bad").mkdir()
    for damage, ((old, new), _) in CONFIGS.items():
        assert old in CONFIG, damage
        (d / "bad" / f"{damage}.toml").write_text(CONFIG.replace(old, new, 1))
    for damage, ((old, new), _) in DECKS.items():
        assert old in DECK, damage
        (d / "bad" / f"{damage}.bdf").write_text(DECK.replace(old, new, 1))
    # the ExportNastranKM beam (tests/decks) with its root clamped
    ekm = (Path(__file__).parent / "decks" / "ekm_bar_beam" / "test_case.bdf").read_text()
    (d / "ekm_clamped.bdf").write_text(ekm.replace("GRDSET,,,,,,,1256",
                                                   "GRDSET,,,,,,,1256\nSPC1    2       123456  1"))
    env = {**os.environ, "TORCHROM_CACHE": str(d / "cache")}
    server = ForkServer(env)
    yield d, server
    server.close()


def _snapshot(folder: Path):
    if not folder.exists():
        return None
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _prepare(name: str, argv: list[str], case_dir: Path) -> list[str]:
    """argv with OUT replaced by the case's output folder; for "output exists" the outputs
    are there first (a file of the same name, or the command's table in the folder)."""
    out = case_dir / "out"
    argv = [a.replace("OUT", str(out)) for a in argv]
    if name.endswith("output exists"):
        out.mkdir(parents=True)
        for a in argv:
            if a == str(out):
                (out / FOLDER_OUTPUT[argv[0]]).write_text("mine\n")
            elif a.startswith(str(out)):
                Path(a).write_text("mine\n")
    return argv


def _check_refusal(rc: int, err: str, word: str) -> None:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err, err
    assert rc == 2, (rc, err)
    assert len(lines) == 1, err
    assert ": error: " in lines[0] and word in lines[0], (word, err)


@pytest.mark.parametrize("name", sorted(CASES))
def test_refused_with_one_line(name, fixtures, tmp_path):
    folder, server = fixtures
    argv, word = CASES[name]
    argv = _prepare(name, argv, tmp_path)
    before = _snapshot(tmp_path / "out")
    rc, _out, err = server.run(argv, folder)
    _check_refusal(rc, err, word)
    assert _snapshot(tmp_path / "out") == before, "the output location changed"


@pytest.mark.parametrize("name", ["flutter input=rom npz", "sweep config: dt > t_end"])
def test_plain_process_agrees(name, fixtures, tmp_path):
    """``python -m torchrom`` itself gives what the fork server's child gave."""
    folder, server = fixtures
    argv, word = CASES[name]
    argv = _prepare(name, argv, tmp_path)
    run = subprocess.run([sys.executable, "-m", "torchrom", *argv], cwd=folder,
                         capture_output=True, text=True, timeout=300)
    _check_refusal(run.returncode, run.stderr, word)
    assert server.run(argv, folder)[::2] == (run.returncode, run.stderr)


def test_every_entry_point_is_covered():
    """Each command of ``torchrom --help`` has cases here (a new one must get its own)."""
    commands = _commands()
    covered = {argv[0] for argv, _ in CASES.values()}
    assert commands <= set(BASE) and commands <= covered, sorted(commands - set(BASE))


def test_help_texts(fixtures):
    """A required option says so (its example is no default), and --allow-large is offered
    only by the commands that check a bound."""
    folder, server = fixtures
    rc, out, _ = server.run(["identify", "--help"], folder)
    assert rc == 0
    text = " ".join(out.split())
    assert "--out ROM.npz ROM file to write, e.g. rom.npz (required)" in text
    assert "--allow-large" in text
    for command in ("plot", "cache"):
        rc, out, _ = server.run([command, "--help"], folder)
        assert rc == 0 and "--allow-large" not in out, command


def test_condensed_stiffness_of_a_free_structure_is_refused(fixtures, tmp_path):
    """``identify --stiffness condensed`` solves the structure under applied loads: a free
    deck (the fixture deck without its SPC1) is refused in one line that says to restrain it
    or to use the tangent plan with dual modes, and no ROM is written."""
    folder, server = fixtures
    deck = tmp_path / "free.bdf"
    deck.write_text(DECK.replace("SPC1    1       123456  1\n", "").replace("SPC = 1\n", ""))
    assert "SPC1" not in deck.read_text()
    rc, out, err = server.run(["identify", deck, "--linear", "3", "--stiffness", "condensed",
                               "--out", tmp_path / "rom.npz"], folder)
    _check_refusal(rc, err, "restrain it (SPC) or use --stiffness tangent")
    assert not (tmp_path / "rom.npz").exists()


def test_dual_zero_prints_no_combinations(fixtures, tmp_path):
    """``identify --dual 0``: no dual-mode combinations are chosen or printed."""
    folder, server = fixtures
    rc, out, err = server.run(["identify", "deck.bdf", "--linear", "2", "--dual", "0", "--out",
                               tmp_path / "rom.npz", "-q"], folder)
    assert rc == 0, err
    assert "combinations" not in out and (tmp_path / "rom.npz").is_file()
    assert "(n = 2)" in out
