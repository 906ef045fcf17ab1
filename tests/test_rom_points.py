"""Output points named by the deck's grids (torchrom.rom.points): parsing, the identified ROM's
points (``identify --output``, the default ``max_mode1``), and sweeps that name them.

The bad-input cases run the real CLI in a subprocess (one line naming the key, exit 2, no
traceback, nothing written)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import torchrom
from torchrom.errors import InputError
from torchrom.rom.points import (
    check_point_table,
    parse_named_point,
    parse_point,
    resolve_output,
)

from .test_bad_input import DECK

ENV = {**os.environ, "PYTHONPATH": str(Path(torchrom.__file__).parents[1])}


def _torchrom(*argv, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv)],
                          capture_output=True, text=True, env=ENV, timeout=600, cwd=cwd)


def _one_line(run: subprocess.CompletedProcess, *words: str) -> str:
    assert run.returncode == 2, (run.returncode, run.stderr)
    assert "Traceback" not in run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    last = lines[-1]
    for w in words:
        assert w in last, (w, last)
    return last


def test_parse_point():
    assert parse_point("G1001:T3") == (1001, 3)
    assert parse_point(" G7:R1 ") == (7, 4)
    assert parse_named_point("tip=G1002:T2") == ("tip", (1002, 2))
    assert parse_named_point("G5:T1") == ("G5:T1", (5, 1))
    assert check_point_table({"tip_le": "G1001:T3"}) == {"tip_le": "G1001:T3"}
    with pytest.raises(InputError, match="unknown component"):
        parse_point("G1001:T7")
    with pytest.raises(InputError, match="expected a grid and component"):
        parse_point("1001:T3")
    with pytest.raises(InputError, match=r"\[points\] tip"):
        check_point_table({"tip": "G1:X3"})


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """A ROM of the 3-bar cantilever of test_bad_input, identified by the real CLI with two
    extra points (about 3 s)."""
    work = tmp_path_factory.mktemp("points")
    (work / "wing.bdf").write_text(DECK)
    run = _torchrom("identify", work / "wing.bdf", "--linear", "2", "--dual", "1",
                    "--combinations", "1:1", "--output", "tip=G4:T2", "--output", "G3:T3",
                    "--out", work / "rom.npz")
    assert run.returncode == 0, run.stderr
    return work, run.stdout


def test_identify_keeps_the_points_and_the_largest_mode1_translation(identified):
    """Independent check: the rows are the FE's own mode shapes at those DOFs (up to the sign
    of each mode, and the mass normalisation both use: rtol 1e-8, the eigen-solver's
    rounding), and max_mode1 is the translation with the largest mode-1 value, found here
    by scanning the FE's mode 1 over every grid (the cantilever's free tip, grid 4)."""
    from torchrom.fe import read_bdf
    from torchrom.rom import NonlinearROM

    work, stdout = identified
    rom = NonlinearROM.load(work / "rom.npz")
    points = rom.metadata["output_points"]
    assert points == {"tip": "G4:T2", "G3:T3": "G3:T3", "max_mode1": points["max_mode1"]}
    assert "max_mode1 (G4:T" in stdout and "tip (G4:T2)" in stdout
    fe = read_bdf(work / "wing.bdf")
    shapes = np.asarray(fe.modes(2).shapes, float)
    dofs = fe.free_dofs()
    trans = [i for i, (_, c) in enumerate(dofs) if c <= 3]
    best = max(trans, key=lambda i: abs(shapes[i, 0]))
    g, c = dofs[best]
    assert points["max_mode1"] == f"G{g}:T{c}" and g == 4
    for name, (grid, comp) in (("tip", (4, 2)), ("G3:T3", (3, 3)), ("max_mode1", (g, c))):
        fe_row = shapes[fe.dof_index(grid, comp), :2]
        rom_row = rom.outputs[name][:2]
        np.testing.assert_allclose(np.abs(rom_row), np.abs(fe_row), rtol=1e-8, atol=1e-12)
    assert resolve_output(rom, "G4:T2") == "tip"
    assert resolve_output(rom, "le", {"le": "G3:T3"}) == "G3:T3"
    assert resolve_output(rom, "tip", {"tip": "G3:T3"}) == "G3:T3"  # the configuration's point
    with pytest.raises(InputError, match=r"'G2:T3'.*not an output of the ROM.*max_mode1 \(G4"):
        resolve_output(rom, "G2:T3")


SWEEP = """[model]
rom = "rom.npz"
[points]
tip_le = "G4:T2"
[integrator]
dt = 0.01
t_end = 0.05
[lco]
outputs = {outputs}
[cases]
alpha = [0.1, 0.2]
"""


def test_sweep_names_points_of_the_deck(identified, tmp_path):
    """A sweep on the identified ROM tracks a [points] name and a grid:component; the
    amplitude columns carry those names."""
    import pandas as pd

    work, _ = identified
    cfg = work / "named.toml"
    cfg.write_text(SWEEP.format(outputs='["tip_le", "G3:T3", "max_mode1"]'))
    out = tmp_path / "sweep"
    run = _torchrom("sweep", cfg, "--out", out)
    assert run.returncode == 0, run.stderr
    table = next(out.glob("*.parquet"), None) or next(out.glob("*.csv"))
    df = pd.read_parquet(table) if table.suffix == ".parquet" else pd.read_csv(table)
    assert {"amplitude_tip_le", "amplitude_G3:T3", "amplitude_max_mode1"} <= set(df.columns)


@pytest.mark.parametrize("outputs, words", [
    ('["A_Tz"]', ("[lco] outputs", "'A_Tz'", "max_mode1 (G4:", "tip (G4:T2)", "--output")),
    ('["G2:T3"]', ("[lco] outputs", "'G2:T3'", "not an output of the ROM", "--output")),
    ('["G2:T9"]', ("[lco] outputs", "unknown component", "T1, T2, T3")),
])
def test_sweep_output_the_rom_does_not_have(identified, outputs, words, tmp_path):
    work, _ = identified
    cfg = work / f"bad{abs(hash(outputs))}.toml"
    cfg.write_text(SWEEP.format(outputs=outputs))
    run = _torchrom("sweep", cfg, "--out", tmp_path / "sweep")
    line = _one_line(run, *words)
    assert "([])" not in line
    assert not (tmp_path / "sweep").exists()


@pytest.mark.parametrize("spec, words", [
    ("G99:T3", ("--output", "grid 99 not found")),
    ("G4:T7", ("--output", "unknown component", "T1, T2, T3, R1, R2, R3")),
    ("4:T3", ("--output", "expected a grid and component like 'G1001:T3'")),
    ("tip=G1:T3", ("--output tip", "grid 1 component 3", "not an independent DOF")),
])
def test_identify_bad_output(spec, words, tmp_path):
    (tmp_path / "wing.bdf").write_text(DECK)
    run = _torchrom("identify", tmp_path / "wing.bdf", "--linear", "2", "--dual", "1",
                    "--combinations", "1:1", "--output", spec, "--out", tmp_path / "rom.npz")
    _one_line(run, *words)
    assert not (tmp_path / "rom.npz").exists()


def test_bad_points_table(identified, tmp_path):
    work, _ = identified
    cfg = work / "badpoint.toml"
    cfg.write_text(SWEEP.format(outputs='["tip_le"]').replace('"G4:T2"', '"G4-T2"'))
    _one_line(_torchrom("sweep", cfg, "--out", tmp_path / "sweep"), "[points] tip_le",
              "'G1001:T3'")
