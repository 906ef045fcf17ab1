"""Nastran bulk data input/output: pt145 (CBAR, CMASS2, CORD2R, PS, aero cards), loads, bad
input, and the writer round trip.

pt145 references (closed form, independent of the FE code): a uniform Euler–Bernoulli
cantilever's first two bending frequencies (β L = 1.8751, 4.6941) and the exact eigenvalues of
the lumped torsional chain formed by the CMASS2 inertias (interior 2.8e-6, tip 1.4e-6) and the
CBAR torsion springs G J / h: ω_j = (2/h) √(G J / I_p) sin((2j − 1) π / (4N)).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.fe import goland, read_bdf, write_bdf
from torchrom.fe.bdf_read import UnsupportedCardWarning

from .fe_decks import model_of, new_deck


def test_pt145_modes_match_closed_form(pt145_deck):
    fe = read_bdf(pt145_deck)
    assert fe.n_modes_requested == 6  # EIGR ND
    assert fe.n_dof == 30  # 10 free grids x (T3, R1, R2) in CORD2R 1: PS = 126, root SPC1 345
    assert fe.mesh.coupled_mass  # PARAM COUPMASS 1
    # Aerodynamic cards are kept for the aerodynamics module, not errors.
    assert 101 in fe.bdf.caeros and 100 in fe.bdf.splines and 30 in fe.bdf.flutters
    modes = fe.modes(3)
    print("pt145 first three modes (Hz):", modes.frequencies_hz, modes.kinds)
    assert modes.kinds == ["bending", "torsion", "bending"]
    E, G, A, I1, J, rho, L = 10.4e6, 3.9e6, 7.175e-2, 9.83e-6, 36.8e-6, 2.61e-4, 5.72
    mL = rho * A
    bend = [b**2 / (2 * np.pi * L**2) * np.sqrt(E * I1 / mL) for b in (1.8751040687, 4.6940911330)]
    h, N = L / 10, 10
    tors = 2 / h * np.sqrt(G * J / (2.8e-6 / h)) * np.sin(np.pi / (4 * N)) / (2 * np.pi)
    # Consistent Hermite mass, 10 elements: bending within 1e-4; the torsional chain is exact.
    assert modes.frequencies_hz[0] == pytest.approx(bend[0], rel=1e-4)
    assert modes.frequencies_hz[2] == pytest.approx(bend[1], rel=1e-4)
    assert modes.frequencies_hz[1] == pytest.approx(tors, rel=1e-10)


def test_nonlinear_analysis_with_cbar(pt145_deck):
    """Decks default to large rotations: the CBARs are co-rotational, so no linear-element
    warning, and f(u) = K u + O(|u|²) (checked at |u| = 1e-7: 1e-5 relative). With
    ``rotations="small"`` the CBARs are linear, f = K u exactly, and the model warns."""
    import warnings

    from torchrom.fe import LinearElementWarning

    fe = read_bdf(pt145_deck)
    u = np.full(fe.n_dof, 1e-7)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LinearElementWarning)
        f = fe.internal_force(u)
    np.testing.assert_allclose(f, fe.stiffness_matrix() @ u, rtol=1e-5,
                               atol=1e-5 * np.abs(fe.stiffness_matrix() @ u).max())
    small = read_bdf(pt145_deck, rotations="small")
    u = np.full(small.n_dof, 1e-3)
    with pytest.warns(LinearElementWarning, match="CBAR/CBEAM/CELAS/solid elements are linear"):
        f = small.internal_force(u)
    np.testing.assert_allclose(f, small.stiffness_matrix() @ u, rtol=1e-12)


def test_cli_modes_pt145(pt145_deck, tmp_path, capsys):
    out = tmp_path / "modes.json"
    assert main(["modes", str(pt145_deck), "--n", "3", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "bending" in text and "torsion" in text
    recs = json.loads(out.read_text())
    assert [r["mode"] for r in recs] == [1, 2, 3]
    assert set(recs[0]) >= {"mode", "frequency_hz", "kind"}


BAD_DECKS = {
    "malformed": ("GRID    1               0.0     abc     0.0\n", r"GRID 1: field #4 \(x2\)"),
    "missing_property": (
        "GRID    1               0.0     0.0     0.0\nGRID    2               1.0     0.0     0.0\n"
        "MAT1    1       1.0e7           0.3     0.1\nCROD    1       7       1       2\n",
        "CROD 1: field PID: property 7 not found",
    ),
    "missing_material": (
        "GRID    1               0.0     0.0     0.0\nGRID    2               1.0     0.0     0.0\n"
        "PROD    1       9       0.5\nCROD    1       1       1       2\n",
        "PROD 1: field MID: material 9 not found",
    ),
    "zero_length": (
        "GRID    1               1.0     0.0     0.0\nGRID    2               1.0     0.0     0.0\n"
        "MAT1    1       1.0e7           0.3     0.1\nPROD    1       1       0.5\n"
        "CROD    1       1       1       2\n",
        "CROD 1: zero length",
    ),
    "missing_node": (
        "GRID    1               0.0     0.0     0.0\nGRID    2               1.0     0.0     0.0\n"
        "MAT1    1       1.0e7           0.3     0.1\nPROD    1       1       0.5\n"
        "CROD    1       1       1       99\n",
        "CROD 1: field G2: grid 99 not found",
    ),
    "degenerate_quad": (
        "GRID    1               0.0     0.0     0.0\nGRID    2               1.0     0.0     0.0\n"
        "GRID    3               2.0     0.0     0.0\nGRID    4               0.0     1.0     0.0\n"
        "MAT1    1       1.0e7           0.3     0.1\nPSHELL  1       1       0.1\n"
        "CQUAD4  3       1       1       2       3       4\n",
        "CQUAD4 3: zero-area, degenerate or concave",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_DECKS))
def test_bad_input_gives_one_line_error(tmp_path, case, capsys):
    text, pattern = BAD_DECKS[case]
    path = tmp_path / f"{case}.bdf"
    path.write_text("BEGIN BULK\n" + text + "ENDDATA\n")
    with pytest.raises(InputError, match=pattern) as info:
        read_bdf(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{case}.bdf: ")
    assert main(["modes", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and pattern.split(":")[0].replace("\\", "") in err


def test_unsupported_cards_are_listed_with_counts(tmp_path):
    path = tmp_path / "unsup.bdf"
    path.write_text(
        "SOL 103\nCEND\nBEGIN BULK\n"
        "GRID    1               0.0     0.0     0.0\nGRID    2               1.0     0.0     0.0\n"
        "GRID    3               1.0     1.0     0.0\nMAT1    1       1.0e7           0.3     0.1\n"
        "PROD    1       1       0.5\nCROD    1       1       1       2\n"
        "CROD    2       1       2       3\nPSHELL  2       1       0.1\n"
        "CQUAD8  5       2       1       2       3       4       5       6\n        7       8\n"
        "CQUAD8  6       2       1       2       3       4       5       6\n        7       8\n"
        "FOOBAR  1       2\nENDDATA\n"
    )
    with pytest.raises(InputError, match=r"unsupported cards: CQUAD8 \(2\): quadratic shell "
                       r"not implemented; FOOBAR \(1\): not read by the FE reader\."):
        read_bdf(path)
    with pytest.warns(UnsupportedCardWarning, match="CQUAD8"):
        fe = read_bdf(path, unsupported="warn")
    assert len(fe.mesh.rods) == 2


def test_loads_and_coordinate_systems():
    """FORCE in a rotated system, PLOAD2/PLOAD4 resultants, LOAD combination; a bulk-only deck."""
    m = new_deck()
    for nid, p in enumerate([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]], start=1):
        m.add_grid(nid, p)
    m.add_mat1(1, 1e7, None, 0.3, rho=1.0)
    m.add_pshell(1, mid1=1, t=0.1, mid2=1, mid3=1)
    m.add_cquad4(1, 1, [1, 2, 3, 4])
    c, s = np.cos(0.3), np.sin(0.3)
    m.add_cord2r(7, [0, 0, 0], [0, 0, 1], [c, s, 0])
    m.add_force(10, 3, 5.0, [1.0, 0.0, 0.0], cid=7)
    m.add_pload2(11, 3.0, [1])
    m.add_pload4(12, [1], [1.0, 2.0, 3.0, 4.0])
    m.add_load(20, 2.0, [1.0, -1.0], [10, 11])
    fe = model_of(m, autospc=False)
    F10 = fe.expand(fe.load_vector(10))
    np.testing.assert_allclose(F10[2, :3], 5.0 * np.array([c, s, 0.0]), atol=1e-12)
    assert fe.expand(fe.load_vector(11))[:, 2].sum() == pytest.approx(3.0 * 2.0)  # p × area
    assert fe.expand(fe.load_vector(12))[:, 2].sum() == pytest.approx(2.5 * 2.0)  # mean p × area
    np.testing.assert_allclose(fe.load_vector(20),
                               2.0 * (fe.load_vector(10) - fe.load_vector(11)), atol=1e-12)
    with pytest.raises(InputError, match="load set 99"):
        fe.load_vector(99)


def test_writer_round_trip_gives_identical_matrices(tmp_path):
    fe0 = goland()
    p1, p2 = tmp_path / "a" / "goland.bdf", tmp_path / "b" / "goland.bdf"
    write_bdf(fe0, p1)
    fe1 = read_bdf(p1)
    write_bdf(fe1, p2)
    fe2 = read_bdf(p2)
    for fe in (fe1, fe2):
        assert fe.n_dof == fe0.n_dof
        for name in ("stiffness_matrix", "mass_matrix"):
            A, B = getattr(fe0, name)(), getattr(fe, name)()
            assert (A != B).nnz == 0  # bit-identical
        assert fe.output_points == fe0.output_points
        assert fe.units == fe0.units
    assert p1.read_text() == p2.read_text()
    with pytest.raises(InputError, match="already exists"):
        write_bdf(fe1, p1)


def _pt145_with_grdset(pt145_deck, tmp_path):
    """pt145 with CP, CD and PS moved from every GRID onto one GRDSET (fields blank on GRID)."""
    lines = []
    for line in pt145_deck.read_text().splitlines():
        if line.startswith("GRID    "):
            line = line[:16] + " " * 8 + line[24:48]  # CP (field 3) blank, CD/PS (7, 8) dropped
        elif line.startswith("BEGIN BULK"):
            line += "\nGRDSET          1                               1       126"
        lines.append(line)
    path = tmp_path / "pt145_grdset.bdf"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_grdset_defaults_apply_to_blank_grid_fields(pt145_deck, tmp_path):
    """GRDSET CP, CD and PS are the defaults of blank GRID fields (MSC QRG, GRDSET): the deck
    with them on GRDSET is the same model as pt145 (before: PS ignored, 60 free DOFs, CP lost)."""
    ref = read_bdf(pt145_deck)
    fe = read_bdf(_pt145_with_grdset(pt145_deck, tmp_path))
    assert fe.n_dof == ref.n_dof == 30
    np.testing.assert_allclose(fe.grid_xyz, ref.grid_xyz, atol=1e-12)
    for name in ("stiffness_matrix", "mass_matrix"):
        assert abs(getattr(fe, name)() - getattr(ref, name)()).max() <= 1e-12 * abs(
            getattr(ref, name)()).max()
    # an explicit PS on a GRID wins over GRDSET
    m = new_deck()
    m.add_grdset(0, 0, "345", 0)
    m.add_grid(1, [0.0, 0.0, 0.0], ps="1")
    m.add_grid(2, [1.0, 0.0, 0.0])
    m.add_mat1(1, 1.0e7, None, 0.3, rho=0.1)
    m.add_prod(1, 1, 0.5)
    m.add_crod(1, 1, [1, 2])
    fe = model_of(m, autospc=False)
    assert fe.constraints.status.get((0, 0)) == "GRID 1 PS" and (0, 2) not in fe.constraints.status
    assert fe.constraints.status.get((1, 2)) == "GRID 2 PS"


def test_scalar_springs_masses_conm1_and_rbar_give_exact_oscillators():
    """CELAS1/PELAS, CELAS2, CMASS1/PMASS, CMASS2, CONM1 (in a rotated CID) and RBAR: each
    component is a one-DOF oscillator ω² = k / m (AUTOSPC removes the rest)."""
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0])
    m.add_grid(2, [1.0, 0.0, 0.0])
    m.add_grid(3, [1.0, 2.0, 0.0])
    m.add_pelas(5, 400.0)
    m.add_celas1(1, 5, [1, 0], "1", "")          # T1 of grid 1: k = 400
    m.add_pmass(7, 4.0)
    m.add_cmass1(2, 7, [1, 0], "1", "")          # m = 4: ω² = 100
    m.add_celas2(3, 900.0, [1, 0], "2", "")      # T2 of grid 1: k = 900
    m.add_cmass2(4, 1.0, [1, 0], "2", "")        # m = 1 + 8 (RBAR carries grid 3's T2)
    c, s = np.cos(0.4), np.sin(0.4)
    m.add_cord2r(9, [0, 0, 0], [0, 0, 1], [c, s, 0])
    M6 = np.zeros((6, 6))
    M6[0, 0] = M6[1, 1] = M6[2, 2] = 3.0         # isotropic 3: invariant under the rotation
    M6[5, 5] = 2.0                               # R3 about z: also invariant
    m.add_conm1(6, 2, M6, cid=9)
    m.add_celas2(7, 75.0, [2, 0], "3", "")       # T3 of grid 2: ω² = 75 / 3 = 25
    m.add_celas2(8, 50.0, [2, 0], "6", "")       # R3 of grid 2: ω² = 50 / 2 = 25
    m.add_conm2(9, 3, 8.0)
    m.add_rbar(10, [1, 3], "123456", "", "", "123456")
    fe = model_of(m)
    assert fe.summary()["CELAS"] == 4 and fe.summary()["CONM1"] == 1
    w2 = np.sort(fe.modes(10).eigenvalues)
    # grid 1: T1 100 + RBAR (grid 3 follows grid 1's rigid motion, its T1 mass 8 too):
    # (400)/(4 + 8) in T1; T2: 900 / (1 + 8); T3 of grid 2: 25; R3 of grid 2: 25
    np.testing.assert_allclose(w2, sorted([400 / 12, 900 / 9, 25.0, 25.0]), rtol=1e-9)


def test_cli_modes_compare_with_an_f06(tmp_path, capsys):
    """`torchrom modes DECK --compare RUN.f06`: Nastran's frequencies and the differences beside
    ours (bah_plane: 2 rigid-body modes, flagged, and 6 elastic ones within 1e-3 %)."""
    from pathlib import Path

    folder = Path(__file__).parent / "decks" / "pynastran_bah_plane"
    out = tmp_path / "m.json"
    assert main(["modes", str(folder / "bah_plane.bdf"), "--compare",
                 str(folder / "bah_plane.f06"), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Nastran Hz" in text and "rigid" in text
    recs = json.loads(out.read_text())
    assert len(recs) == 8 and recs[0]["diff_pct"] is None and "diff_hz" in recs[0]
    assert recs[2]["nastran_hz"] == pytest.approx(2.45402, rel=1e-5)
    assert max(abs(r["diff_pct"]) for r in recs[2:]) < 1e-3
    assert main(["modes", str(folder / "bah_plane.bdf"), "--compare",
                 str(tmp_path / "none.f06")]) == 2
    assert "no such f06 file" in capsys.readouterr().err


def test_cbush_between_coincident_grids_in_a_rotated_system():
    """CBUSH K1..K6 along a CORD2R turned 30° about z: a point mass on the bush has the six
    oscillator frequencies ω² = K_i / m (translations) and K_i / I (rotations)."""
    m = new_deck()
    m.add_grid(1, [0.0, 0.0, 0.0], ps="123456")
    m.add_grid(2, [0.0, 0.0, 0.0])
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    m.add_cord2r(5, [0, 0, 0], [0, 0, 1], [c, s, 0])
    m.add_pbush(3, [100.0, 400.0, 900.0, 16.0, 25.0, 36.0], [], [])
    m.add_cbush(1, 3, [1, 2], None, None, cid=5)
    m.add_conm2(2, 2, 4.0, X=[0.0, 0.0, 0.0], I=[1.0, 0.0, 1.0, 0.0, 0.0, 1.0])
    fe = model_of(m)
    assert fe.summary()["CBUSH"] == 1
    np.testing.assert_allclose(np.sort(fe.modes(6).eigenvalues),
                               np.sort([25.0, 100.0, 225.0, 16.0, 25.0, 36.0]), rtol=1e-10)
    # a unit force along basic x: compliance c²/K1 + s²/K2 along x (the springs are turned)
    u = fe.expand(fe.linear_static(fe.nodal_load({(2, 1): 1.0})))
    assert u[1, 0] == pytest.approx(c * c / 100.0 + s * s / 400.0, rel=1e-12)
    # between separate grids (tests/test_fe_scalar_cards.py) the spring point may lie off the
    # GA-GB line (OCID >= 0): refused
    m.add_grid(3, [1.0, 0.0, 0.0])
    m.add_cbush(4, 3, [1, 3], None, None, cid=5, ocid=5, si=[0.0, 0.1, 0.0])
    with pytest.raises(InputError, match="CBUSH 4: field OCID: only the spring on the line"):
        model_of(m)
