"""Files for viewers (torchrom.post.viewers) read back by the viewers' own readers — meshio for
VTU and XDMF, pyNastran's OP2 reader — hold torchrom's displacements: VTU and XDMF to 1e-10
relative (they are float64: measured bit-for-bit), OP2 equal to their float32 roundings
(pyNastran writes 32-bit OP2 only; a float32 keeps 2^-24 = 6e-8 of each value), with the grid
ids, the mesh and the frame values (frequencies, phases, times). On the heavy Goland wing's and
the Pazy wing's (AePW-3 GFEM, 7007 grids) modes, and on a complex mode and an LCO period."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchrom.post.motions import flutter_motion, lco_motion, mode_motion
from torchrom.post.viewers import write_motion
from torchrom.rom.shapes import orbit_states

PAZY = Path(__file__).parent / "decks" / "aepw3_pazy_skin_flutter_tipmass1" / "sol145.dat"
#: VTU/XDMF hold float64: the read-back must equal torchrom's to this relative size
RTOL = 1e-10


@pytest.fixture(scope="module")
def goland_modes():
    from torchrom.fe import goland
    from torchrom.fe.shapes import mesh_shapes

    fe = goland()
    modes = fe.modes(4)
    return mesh_shapes(fe, modes.shapes), modes.frequencies_hz


def _read_vtu(path, motion):
    import meshio

    m = meshio.read(path)
    np.testing.assert_array_equal(m.points, motion.shapes.xyz)
    blocks = {c.type: c.data for c in m.cells}
    np.testing.assert_array_equal(blocks["quad"], motion.shapes.quads)
    if len(motion.shapes.lines):
        np.testing.assert_array_equal(blocks["line"], motion.shapes.lines)
    return m.point_data


def _check_all(tmp_path, motion):
    """Write the three formats and read each back (module docstring)."""
    from pyNastran.op2.op2 import read_op2

    u = motion.displacements
    scale = np.abs(u).max()
    write_motion(tmp_path / "m.vtu", motion)
    pd = _read_vtu(tmp_path / "m.vtu", motion)
    for key, ui in zip(motion.keys, u):
        assert np.abs(pd[f"displacement_{key}"] - ui[:, :3]).max() <= RTOL * scale
        assert np.abs(pd[f"rotation_{key}"] - ui[:, 3:]).max() <= RTOL * scale
    if motion.complex_shape is not None:
        np.testing.assert_array_equal(pd["displacement_imag"], motion.complex_shape.imag[:, :3])

    import meshio

    write_motion(tmp_path / "m.xdmf", motion)
    with meshio.xdmf.TimeSeriesReader(tmp_path / "m.xdmf") as r:
        points, _ = r.read_points_cells()
        np.testing.assert_array_equal(points, motion.shapes.xyz)
        assert r.num_steps == len(motion.keys)
        for i in range(r.num_steps):
            t, data, _ = r.read_data(i)
            if motion.kind != "modes":
                assert t == pytest.approx(motion.values[i], rel=1e-15)
            assert np.abs(data["displacement"] - u[i, :, :3]).max() <= RTOL * scale
            assert np.abs(data["rotation"] - u[i, :, 3:]).max() <= RTOL * scale

    write_motion(tmp_path / "m.op2", motion)
    op2 = read_op2(str(tmp_path / "m.op2"), debug=None, log=None, mode="msc")
    if motion.kind == "modes":
        res = op2.eigenvectors[1]
        np.testing.assert_allclose(res.mode_cycles, motion.values.astype(np.float32),
                                   rtol=1e-7)
    else:
        res = op2.displacements[2 if motion.complex_shape is not None else 1]
        np.testing.assert_allclose(res._times, motion.values, rtol=1e-7)
    np.testing.assert_array_equal(res.node_gridtype[:, 0], motion.shapes.grid_ids)
    np.testing.assert_array_equal(res.data, u.astype(np.float32))
    assert np.abs(res.data - u).max() <= 2**-24 * scale
    if motion.complex_shape is not None:
        c = op2.eigenvectors[1]
        np.testing.assert_array_equal(c.data[0], motion.complex_shape.astype(np.complex64))
        assert c.eigis[0] == pytest.approx(motion.eigenvalue.imag, rel=1e-7)


def test_goland_modes(goland_modes, tmp_path):
    shapes, f = goland_modes
    _check_all(tmp_path, mode_motion(shapes, f, [1, 2, 4], "Goland modes"))


def test_goland_complex_mode_and_orbit(goland_modes, tmp_path):
    """A complex combination of modes 1 and 2 (a bending-torsion flutter mode's form) as 8
    phases, and a two-harmonic orbit as 12 instants of its period."""
    shapes, f = goland_modes
    v = np.array([1.0, 0.4 - 0.7j, 0.0, 0.05j])
    _check_all(tmp_path, flutter_motion(shapes, v, -0.01 + 12.3j, 8, "complex"))
    X = np.zeros((5, shapes.n))
    X[1, 0], X[2, 1], X[3, 0] = 0.8, 0.2, 0.05
    t, q = orbit_states(X, 2 * np.pi * 1.8, 12)
    (tmp_path / "lco").mkdir()
    _check_all(tmp_path / "lco", lco_motion(shapes, t, q, "orbit"))


def test_pazy_modes(tmp_path):
    """The Pazy wing's first three modes (39,564 DOF, 7007 grids, shells and bars; about 15 s)."""
    from torchrom.fe import read_bdf
    from torchrom.fe.shapes import mesh_shapes

    fe = read_bdf(PAZY)
    modes = fe.modes(3)
    shapes = mesh_shapes(fe, modes.shapes)
    assert shapes.n_grid == 7007 and shapes.length_unit == "m"
    _check_all(tmp_path, mode_motion(shapes, modes.frequencies_hz, None, "Pazy modes"))


def test_xdmf_keeps_the_faces_of_a_mesh_with_lines(goland_modes, tmp_path):
    """meshio 5.3.5 cannot mix line cells with faces in XDMF (module docstring of
    torchrom.post.viewers): the Goland wing's XDMF holds its 92 quads, the VTU its 137 rod
    lines too."""
    import meshio

    shapes, f = goland_modes
    motion = mode_motion(shapes, f, [1], "Goland mode 1")
    write_motion(tmp_path / "m.xdmf", motion)
    write_motion(tmp_path / "m.vtu", motion)
    with meshio.xdmf.TimeSeriesReader(tmp_path / "m.xdmf") as r:
        _, cells = r.read_points_cells()
    assert [(c.type, len(c.data)) for c in cells] == [("quad", 92)]
    assert sorted((c.type, len(c.data)) for c in meshio.read(tmp_path / "m.vtu").cells) == [
        ("line", 137), ("quad", 92)]


def test_unknown_format_is_refused(goland_modes, tmp_path):
    from torchrom.errors import InputError

    shapes, f = goland_modes
    with pytest.raises(InputError, match=r"m.txt: expected a file name ending in one of"):
        write_motion(tmp_path / "m.txt", mode_motion(shapes, f, [1], "x"))
