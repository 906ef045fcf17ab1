"""``torchrom export`` through the real command line (issue 47), on the Goland chain of
tests/shape_fixtures.py: each file read back by meshio and pyNastran holds torchrom's own
displacements (the ROM's Φ on the grids times the sweep's stored orbit, or the flutter mode's
modal vector) to 1e-10 relative (OP2: their float32 roundings, exactly); the LCO's exported
motion at point A has the row's amplitude; the flutter mode's frequency and speed are those of
``torchrom flutter``; a deck's modes equal its FE modes at point A. Bad input (an unknown row, a
sweep without orbits, an existing output) is refused in one line, exit status 2, in a subprocess.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from torchrom.rom import NonlinearROM
from torchrom.rom.shapes import normalised_mode, orbit_states
from torchrom.study.cases import orbits_of

from .shape_fixtures import cli, goland_chain

RTOL = 1e-10


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    return goland_chain(tmp_path_factory.mktemp("export"))


def _vtu(path):
    import meshio

    return meshio.read(path).point_data


def test_lco_row_read_back_equals_phi_times_the_orbit(chain):
    """24 instants of row 0's period: VTU and XDMF equal Φ q(t_k) with q from orbits.parquet
    (1e-10 relative; measured 0), the OP2's transient table their float32 roundings."""
    import meshio
    from pyNastran.op2.op2 import read_op2

    d = chain
    assert cli(d, "export", "run/rom.npz", "--sweep", "lco", "--row", "0", "--out", "l.vtu",
               "--out", "l.xdmf", "--out", "l.op2", "--json", "l.json") == 0
    rom = NonlinearROM.load(d / "run/rom.npz")
    table = pd.read_parquet(d / "lco/results.parquet")
    X, omega = orbits_of(pd.read_parquet(d / "lco/orbits.parquet"), [table["case_id"][0]], rom.n)
    t, q = orbit_states(X[0], omega[0], 24)
    u = rom.shapes.motion(q)
    scale = np.abs(u[..., :3]).max()
    pd_ = _vtu(d / "l.vtu")
    for k in range(24):
        assert np.abs(pd_[f"displacement_t{k:02d}"] - u[k, :, :3]).max() <= RTOL * scale
    with meshio.xdmf.TimeSeriesReader(d / "l.xdmf") as r:
        r.read_points_cells()
        for k in range(r.num_steps):
            tk, data, _ = r.read_data(k)
            assert tk == pytest.approx(t[k], rel=1e-15)
            assert np.abs(data["displacement"] - u[k, :, :3]).max() <= RTOL * scale
    op2 = read_op2(str(d / "l.op2"), debug=None, log=None, mode="msc")
    np.testing.assert_array_equal(op2.displacements[1].data, u.astype(np.float32))
    rec = json.loads((d / "l.json").read_text())
    assert rec["kind"] == "period" and rec["period_s"] == pytest.approx(2 * np.pi / omega[0])


def test_lco_motion_at_point_a_has_the_rows_amplitude(chain):
    """Half the peak-to-peak T3 motion of grid 1102 (point A) over 400 exported instants equals
    the row's amplitude, which the sweep measured on its own orbit of the A_Tz output (the
    ROM's output row, not the grid shapes): within 1e-4 relative (the 400-instant sampling
    misses a peak by ≤ 1 - cos(π/400) = 3e-5; the certificate's amplitude is its finished
    orbit's, within its dt_error of the harmonic balance's; measured 5.3e-6)."""
    d = chain
    assert cli(d, "export", "run/rom.npz", "--sweep", "lco", "--row", "0", "--frames", "400",
               "--out", "fine.vtu") == 0
    pd_ = _vtu(d / "fine.vtu")
    rom = NonlinearROM.load(d / "run/rom.npz")
    a = int(np.flatnonzero(rom.shapes.grid_ids == 1102)[0])
    z = np.array([pd_[f"displacement_t{k:02d}"][a, 2] for k in range(400)])
    row = pd.read_parquet(d / "lco/results.parquet").iloc[0]
    print("point A half peak-to-peak:", 0.5 * np.ptp(z), "row amplitude:", row["amplitude"])
    assert 0.5 * np.ptp(z) == pytest.approx(float(row["amplitude"]), rel=1e-4)


def test_flutter_mode_is_the_flutter_commands_point(chain):
    """The exported flutter mode's speed and frequency are ``torchrom flutter``'s p-k matched
    point (the same crossing, converged again at its speed: 1e-9 relative); the files hold
    Φ v (v from --json) normalised to a largest translation of 1 at phase 0: the VTU's real and
    imaginary parts to 1e-10, the OP2's complex eigenvector its complex64 rounding."""
    from pyNastran.op2.op2 import read_op2

    d = chain
    assert cli(d, "flutter", "run/rom.npz", "run/aero.npz", "--method", "pk", "--json",
               "flutter.json") == 0
    assert cli(d, "export", "run/rom.npz", "run/aero.npz", "--flutter", "--out", "f.vtu",
               "--out", "f.op2", "--json", "f.json") == 0
    pk = json.loads((d / "flutter.json").read_text())["flutter"][0]
    rec = json.loads((d / "f.json").read_text())
    assert rec["velocity"] == pytest.approx(pk["velocity"], rel=1e-9)
    assert rec["frequency_hz"] == pytest.approx(pk["frequency_hz"], rel=1e-6)
    assert abs(rec["damping_g"]) < 1e-6 and rec["residual"] < 1e-12
    rom = NonlinearROM.load(d / "run/rom.npz")
    v = np.zeros(rom.n, complex)
    v[:6] = np.array(rec["modal_vector_real"]) + 1j * np.array(rec["modal_vector_imag"])
    u = rom.shapes.motion(normalised_mode(v, rom.shapes))
    pd_ = _vtu(d / "f.vtu")
    assert np.abs(pd_["displacement_real"] - u.real[:, :3]).max() <= RTOL
    assert np.abs(pd_["displacement_imag"] - u.imag[:, :3]).max() <= RTOL
    assert np.abs(pd_["displacement_phase000"] - u.real[:, :3]).max() <= RTOL
    op2 = read_op2(str(d / "f.op2"), debug=None, log=None, mode="msc")
    np.testing.assert_array_equal(op2.eigenvectors[1].data[0], u.astype(np.complex64))
    assert op2.displacements[2].data.shape == (12, rom.shapes.n_grid, 6)


def test_deck_modes_are_the_fe_modes(chain):
    """The deck form's mode 2 at point A's T3 is the FE mode's free DOF there (dof_index, not
    the constraint expansion): 1e-10 relative."""
    from torchrom.fe import read_bdf

    d = chain
    assert cli(d, "export", "run/goland.bdf", "--n", "3", "--out", "modes.vtu") == 0
    fe = read_bdf(d / "run/goland.bdf")
    modes = fe.modes(3)
    a = int(np.flatnonzero(fe.grid_ids == 1102)[0])
    for j in range(3):
        ours = _vtu(d / "modes.vtu")[f"displacement_mode{j + 1}"][a, 2]
        ref = modes.shapes[fe.dof_index(1102, 3), j]
        assert ours == pytest.approx(ref, rel=RTOL)


def _refused(folder, *argv, word):
    run = subprocess.run([sys.executable, "-m", "torchrom", "export", *map(str, argv)],
                         cwd=folder, capture_output=True, text=True, timeout=300)
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2 and len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    assert word in lines[0], lines[0]


def test_bad_rows_and_folders_are_refused_in_one_line(chain, tmp_path):
    d = chain
    _refused(d, "run/rom.npz", "--sweep", "lco", "--row", "7", "--out", tmp_path / "x.vtu",
             word="--row 7: lco/results.parquet has rows 0..0")
    _refused(d, "run/rom.npz", "--sweep", "lco", "--row", "nosuchcase", "--out",
             tmp_path / "x.vtu", word="not a row number (0..0) nor a case_id")
    bare = d / "bare"
    bare.mkdir(exist_ok=True)
    (bare / "results.parquet").write_bytes((d / "lco/results.parquet").read_bytes())
    _refused(d, "run/rom.npz", "--sweep", "bare", "--row", "0", "--out", tmp_path / "x.vtu",
             word="keeps no orbit or history of case")
    _refused(d, "run/rom.npz", "--sweep", "run", "--row", "0", "--out", tmp_path / "x.vtu",
             word="run: no results.parquet")
    (tmp_path / "x.op2").write_text("mine")
    _refused(d, "run/rom.npz", "--out", tmp_path / "x.op2", word="--force")
    assert (tmp_path / "x.op2").read_text() == "mine"


@pytest.mark.slow
def test_pazy_flutter_mode_and_lco_row(tmp_path):
    """The Pazy wing (AePW-3 GFEM with skin, tip mass 1; 7007 grids) through the chain of
    docs/guide/pazy-flutter.md (condensed 10-mode ROM, Mach 0.001 aero, the shipped LCO
    sweep by harmonic balance), then ``export --flutter --density 1.225`` and one LCO row:
    the flutter mode is the first crossing of the f06 within 2 % (67.30 m/s, 34.723 Hz; the
    ROM chain's own test measured +1.31 %, -0.35 %); the files read back equal Φ v and Φ q(t)
    to 1e-10 relative; the row's amplitude at its output grid is the motion's half peak-to-peak
    within 1e-4. Measured: 68.18 m/s, 34.60 Hz; amplitude 9.0673e-3 m against the row's
    9.0674e-3 (2.7e-6). 571 s on two busy cores."""
    import shutil

    import meshio

    from .test_pazy_flutter import ROM_K, TIPMASS1

    deck = TIPMASS1 / "sol145.dat"
    shutil.copy(Path(__file__).parents[1] / "configs/pazy_skin_lco.toml", tmp_path / "lco.toml")
    for argv in (("identify", deck, "--linear", "10", "--stiffness", "condensed",
                  "--nonlinear-modes", "3", "--linear-skin", "10011", "--out", "rom.npz"),
                 ("aero", deck, "--mach", "0.001", "--modes", "10", "--k", *ROM_K, "--out",
                  "aero.npz"),
                 ("sweep", "lco.toml", "--out", "hb"),
                 ("export", "rom.npz", "aero.npz", "--flutter", "--density", "1.225", "--out",
                  "f.vtu", "--out", "f.op2", "--json", "f.json"),
                 ("export", "rom.npz", "--sweep", "hb", "--row", "3", "--frames", "400",
                  "--out", "l.vtu", "--out", "l.xdmf", "--out", "l.op2")):
        assert cli(tmp_path, *argv) == 0, argv
    rec = json.loads((tmp_path / "f.json").read_text())
    print("pazy flutter mode:", rec["velocity"], rec["frequency_hz"])
    assert rec["velocity"] == pytest.approx(67.30, rel=0.02)
    assert rec["frequency_hz"] == pytest.approx(34.723, rel=0.02)
    rom = NonlinearROM.load(tmp_path / "rom.npz")
    v = np.zeros(rom.n, complex)
    v[:10] = np.array(rec["modal_vector_real"]) + 1j * np.array(rec["modal_vector_imag"])
    u = rom.shapes.motion(normalised_mode(v, rom.shapes))
    assert np.abs(_vtu(tmp_path / "f.vtu")["displacement_real"] - u.real[:, :3]).max() <= RTOL
    table = pd.read_parquet(tmp_path / "hb/results.parquet")
    X, omega = orbits_of(pd.read_parquet(tmp_path / "hb/orbits.parquet"),
                         [table["case_id"][3]], rom.n)
    t, q = orbit_states(X[0], omega[0], 400)
    ul = rom.shapes.motion(q)
    scale = np.abs(ul[..., :3]).max()
    pd_ = _vtu(tmp_path / "l.vtu")
    assert max(np.abs(pd_[f"displacement_t{k:02d}"] - ul[k, :, :3]).max()
               for k in range(400)) <= RTOL * scale
    with meshio.xdmf.TimeSeriesReader(tmp_path / "l.xdmf") as r:
        r.read_points_cells()
        _, data, _ = r.read_data(7)
        assert np.abs(data["displacement"] - ul[7, :, :3]).max() <= RTOL * scale
    point = rom.metadata["output_points"]["max_mode1"]  # "G<grid>:T<c>" of the row's output
    grid, comp = int(point[1:].split(":")[0]), int(point[-1])
    g = int(np.flatnonzero(rom.shapes.grid_ids == grid)[0])
    print("pazy LCO half peak-to-peak:", 0.5 * np.ptp(ul[:, g, comp - 1]),
          "row amplitude:", table["amplitude"][3])
    assert 0.5 * np.ptp(ul[:, g, comp - 1]) == pytest.approx(float(table["amplitude"][3]),
                                                             rel=1e-4)
