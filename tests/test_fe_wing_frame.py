"""The wing's axes from a deck's geometry (torchrom.fe.wing_frame) and the metamorphic test:
a deck rotated rigidly — 90° about x, 90° about z, an arbitrary rotation with the grids in
basic, and the same with the grids given in a rotated CORD2R — is the same wing.

Tolerances: frequencies 1e-8 relative (the rotated grids are written in 16-character double
fields, 11 digits, so positions in basic differ by ~1e-11 relative: on the Pazy wing's
millimetre elements, 3.7 m from the rotation's origin, its stiffness matrix by 6e-9, against
5e-14 with the grids in the CORD2R; the eigen-solver's own rounding is ~1e-12); ROM
tensors 1e-7 relative to each tensor's largest entry (the dual modes come from Newton solves
converged to 1e-8 of the load: their rounding, not the rotation's, sets this); flutter 0.1 %
(the issue's bound; the aerodynamic frame rotates with the deck, so the DLM sees the same
boxes and the difference is rounding).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pyNastran.bdf.bdf import BDF

from torchrom.errors import InputError
from torchrom.fe import read_bdf
from torchrom.fe.wing_frame import WingFrameError, axis_name, parse_axis, wing_frame

from .conftest import REPO
from .fe_decks import model_of, new_deck, rotation, tip_mass_beam
from .rotated_decks import rotate_deck

DECKS = Path(__file__).parent / "decks"
WINGBOX = DECKS / "tacs_mdo_wingbox" / "wingbox.bdf"
ROTATIONS = {
    "90 deg about x": (rotation([1, 0, 0], np.pi / 2), "basic"),
    "90 deg about z": (rotation([0, 0, 1], np.pi / 2), "basic"),
    "arbitrary": (rotation([0.3, -0.5, 0.8], 1.1), "basic"),
    "CORD2R": (rotation([0.3, -0.5, 0.8], 1.1), "rotated"),
}


def test_parse_axis_names_and_vectors():
    assert np.allclose(parse_axis("y", "--up-axis"), [0, 1, 0])
    assert np.allclose(parse_axis("-Z", "--up-axis"), [0, 0, -1])
    assert np.allclose(parse_axis("0,3,4", "--up-axis"), [0, 0.6, 0.8])
    assert parse_axis(None, "--up-axis") is None
    for bad in ("w", "1,2", "0,0,0", "a,b,c", "nan,0,1"):
        with pytest.raises(InputError, match="--up-axis"):
            parse_axis(bad, "--up-axis")
    assert axis_name(np.array([0.0, -1.0, 0.0])) == "-y"


def _plate(normal_axis: int, span_axis: int, n: int = 6) -> BDF:
    """A clamped 1 x 0.2 plate strip (CQUAD4), its thickness along ``normal_axis``."""
    m = new_deck()
    chord_axis = 3 - normal_axis - span_axis
    nid = 1
    for i in range(n + 1):
        for j in range(3):
            x = np.zeros(3)
            x[span_axis], x[chord_axis] = i / n, 0.1 * j
            m.add_grid(nid, x)
            nid += 1
    eid = 1
    for i in range(n):
        for j in range(2):
            a = i * 3 + j + 1
            m.add_cquad4(eid, 1, [a, a + 3, a + 4, a + 1])
            eid += 1
    m.add_pshell(1, mid1=1, t=0.002, mid2=1, mid3=1)
    m.add_mat1(1, 7e10, None, 0.3, rho=2700.0)
    m.add_spc1(1, "123456", [1, 2, 3])
    return m


@pytest.mark.parametrize("normal_axis,span_axis", [(2, 0), (1, 2), (0, 1)])
def test_plate_up_is_its_thickness_and_span_points_away_from_the_clamp(normal_axis, span_axis):
    fe = model_of(_plate(normal_axis, span_axis))
    f = fe.wing_frame()
    assert abs(f.up[normal_axis]) == pytest.approx(1.0)
    assert f.span[span_axis] == pytest.approx(1.0)  # root at 0, tip at +1
    assert np.dot(np.cross(f.span, f.up), f.chord) == pytest.approx(1.0)
    kinds = fe.modes(3).kinds
    assert kinds[0] == "bending"


def test_user_axes_override_and_are_checked():
    fe = model_of(_plate(2, 0))
    assert np.allclose(wing_frame(fe, up="-z").up, [0, 0, -1])
    with pytest.raises(InputError, match="--span-axis"):
        wing_frame(fe, up="z", span="-z")


def test_panels_give_up_and_flow():
    """With CAERO1 panels, up is the AERO card's ACSID z and the chord its x."""
    m = _plate(2, 0)
    m.add_cord2r(7, [0, 0, 0], [0, 1, 0], [0, 0, 1])  # z along basic y, x along basic z
    m.add_aero(velocity=1.0, cref=0.2, rho_ref=1.0, acsid=7)
    m.add_paero1(1)
    m.add_caero1(1001, 1, igroup=1, p1=[0, 0, 0], x12=0.2, p4=[1, 0, 0], x43=0.2, nspan=2,
                 nchord=2)
    fe = model_of(m)
    f = fe.wing_frame()
    assert np.allclose(f.up, [0, 1, 0]) and "panels" in f.source
    assert np.allclose(f.chord, [0, 0, 1])


def test_beam_line_up_is_the_weak_bending_direction():
    """A CBAR line along x whose sections bend more easily along basic y (I1 < I2 with v along
    y: I1 resists the displacement along the element's y)."""
    fe = model_of(tip_mass_beam(I1=2e-6, I2=8e-6))
    assert abs(fe.wing_frame().up @ fe.mesh.bars.v[0] / np.linalg.norm(fe.mesh.bars.v[0])) == \
        pytest.approx(1.0)
    round_ = model_of(tip_mass_beam(I1=4e-6, I2=4e-6))
    with pytest.raises(WingFrameError, match="--up-axis"):
        round_.wing_frame()
    assert set(round_.modes(2).kinds) == {"unknown"}


@pytest.fixture(scope="module")
def wingbox_rotations(tmp_path_factory):
    d = tmp_path_factory.mktemp("rotated")
    return {name: rotate_deck(WINGBOX, d / f"{i}.bdf", R, origin=(1.0, -2.0, 0.5),
                              coordinates=coords)
            for i, (name, (R, coords)) in enumerate(ROTATIONS.items())}


def test_wingbox_axes_come_from_its_structure():
    """The MACH tutorial wingbox is y-up with its span along z: before the wing frame its first
    bending mode was labelled in-plane."""
    fe = read_bdf(WINGBOX)
    f = fe.wing_frame()
    assert axis_name(f.up) == "+y" and f.span[2] > 0.9
    m = fe.modes(4)
    assert m.kinds[:3] == ["bending", "bending", "in-plane"]


@pytest.mark.parametrize("name", list(ROTATIONS))
def test_rotated_wingbox_has_the_same_modes_kinds_and_loads(name, wingbox_rotations):
    fe0, fe = read_bdf(WINGBOX), read_bdf(wingbox_rotations[name])
    m0, m = fe0.modes(8), fe.modes(8)
    assert np.allclose(m.frequencies_hz, m0.frequencies_hz, rtol=1e-8, atol=0)
    assert m.kinds == m0.kinds
    # the report's pressure (pushing up) and the tip deflection it causes, in the wing's axes;
    # a structure cannot tell up from down (the module docstring): the rotated deck is told
    R = ROTATIONS[name][0]
    assert abs(fe.wing_frame().up @ (R @ fe0.wing_frame().up)) == pytest.approx(1.0)
    fe.set_wing_axes(up=R @ fe0.wing_frame().up)
    from torchrom.identify.fe_backend import BuiltinFEBackend

    b0, b = BuiltinFEBackend(fe0), BuiltinFEBackend(fe)
    # the principal axes of rotated positions agree to ~1e-11 (SVD rounding)
    assert b.reference_length == pytest.approx(b0.reference_length, rel=1e-9)
    for key in ("uniform", "step"):
        u0 = fe0.linear_static(b0.load_shapes()[key])
        u = fe.linear_static(b.load_shapes()[key])
        t0, t = b0.transverse_displacements(u0), b.transverse_displacements(u)
        assert np.allclose(t, t0, rtol=0, atol=1e-8 * np.abs(t0).max()), key


def _identify(deck: Path, out: Path, *extra: str) -> None:
    run = subprocess.run([sys.executable, "-m", "torchrom", "identify", str(deck), "--linear",
                          "3", "--out", str(out), "-q", *extra],
                         capture_output=True, text=True, cwd=REPO, timeout=1800)
    assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("name,dual", [
    ("90 deg about x", ["--dual", "1", "--combinations", "1:1"]),
    pytest.param("CORD2R", ["--dual", "2"], marks=pytest.mark.slow),
])
def test_rotated_wingbox_gives_the_same_rom(name, dual, wingbox_rotations, tmp_path):
    """The same ROM tensors (up to each basis vector's sign) from the rotated deck."""
    from torchrom.rom import NonlinearROM

    _identify(WINGBOX, tmp_path / "r0.npz", *dual)
    _identify(wingbox_rotations[name], tmp_path / "r1.npz", *dual)
    r0, r1 = NonlinearROM.load(tmp_path / "r0.npz"), NonlinearROM.load(tmp_path / "r1.npz")
    assert r0.mode_kinds == r1.mode_kinds
    assert np.allclose(r1.frequencies_hz[:3], r0.frequencies_hz[:3], rtol=1e-8)
    assert_same_tensors(r0, r1)


#: relative agreement of the ROMs' tensors: stiffness 1e-7 (measured 9e-11); the nonlinear
#: damping D2, D3 of the optimum decomposition 2e-3 (measured 4.7e-4: the decomposition
#: amplifies the ~1e-8 rounding of the dual modes' static solutions about 1e4-fold, as
#: torchrom.identify.fe_backend says of the Goland ROM)
RTOL = {"D2": 2e-3, "D3": 2e-3}


def assert_same_tensors(r0, r1, rtol: float = 1e-7, rtols: dict | None = None):
    """Every tensor of the two ROMs equal, to ``rtol`` (:data:`RTOL`, updated by ``rtols``, for
    the tensors named there) of its largest entry, once each basis vector's sign is matched: an
    index's sign flips with its basis vector, so T_ab... becomes s_a s_b ... T_ab...; the signs
    are the pattern (of 2^(n-1)) that fits best. Returns those signs and each tensor's relative
    difference at them."""
    import itertools

    rtols = {**RTOL, **(rtols or {})}
    names = [k for k in r0.TENSORS if getattr(r0, k) is not None]
    T0 = {k: getattr(r0, k).numpy() for k in names}
    T1 = {k: getattr(r1, k).numpy() for k in names}
    best_err, best_signs, best_errs = np.inf, None, None
    for signs in itertools.product((1.0, -1.0), repeat=r0.n - 1):
        s = np.array((1.0, *signs))
        errs = {}
        for k, A in T0.items():
            S = s
            for _ in range(A.ndim - 1):
                S = np.multiply.outer(S, s)
            errs[k] = np.abs(T1[k] * S - A).max() / max(np.abs(A).max(), 1e-300)
        err = max(e * rtol / rtols.get(k, rtol) for k, e in errs.items())
        if err < best_err:
            best_err, best_signs, best_errs = err, s, errs
    assert best_err < rtol, best_errs
    return best_signs, best_errs


def _rotated_variants(src: Path, tmp_path: Path, names) -> dict[str, Path]:
    return {name: rotate_deck(src, tmp_path / f"rot{i}_{src.name}", *ROTATIONS[name][:1],
                              origin=(3.0, -1.0, 2.0), coordinates=ROTATIONS[name][1])
            for i, name in enumerate(names)}


def test_rotated_goland_deck_keeps_point_a_and_its_planform_aerodynamics(tmp_path):
    """The built-in Goland deck (no panels: the built-in planform is placed in the wing's
    axes): the same modes and kinds, point A on the same grid and components (told the up
    axis where the rotation turns the structure's conventional sign), and the same
    generalized aerodynamic forces on the Goland planform (hence the same flutter)."""
    from torchrom.aero.build import build
    from torchrom.fe.goland import updated_goland_bdf

    src = tmp_path / "goland.bdf"
    updated_goland_bdf().write_bdf(str(src), enddata=True)
    fe0 = read_bdf(src)
    m0 = fe0.modes(6)
    aero0 = build(fe0, n_modes=4, n_lags=2, k_list=[0.05, 0.3])
    for name, path in _rotated_variants(src, tmp_path, ["90 deg about x", "arbitrary"]).items():
        fe = read_bdf(path)
        R = ROTATIONS[name][0]
        m = fe.modes(6)
        assert np.allclose(m.frequencies_hz, m0.frequencies_hz, rtol=1e-8), name
        assert m.kinds == m0.kinds, name
        if fe.wing_frame().up @ (R @ fe0.wing_frame().up) < 0:
            fe = read_bdf(path)
            fe.set_wing_axes(up=R @ fe0.wing_frame().up)
            from torchrom.fe.goland_geometry import goland_output_points

            fe.set_output_points(goland_output_points(fe))
        assert fe.output_points == fe0.output_points, name
        aero = build(fe, n_modes=4, n_lags=2, k_list=[0.05, 0.3])
        Q0, Q = np.asarray(aero0.gaf.Q), np.asarray(aero.gaf.Q)
        # a mode's shape may flip sign with the rotation (its first large DOF is another):
        # Q_ij -> s_i s_j Q_ij, a similarity that leaves every flutter root as it is
        ratio = Q[-1, 0, :] / Q0[-1, 0, :]
        s = np.sign(ratio.real)
        S = s[None, :, None] * s[None, None, :]  # s_j = s_0 s_j of the true signs
        assert np.allclose(Q, S * Q0, rtol=1e-6, atol=1e-9 * np.abs(Q0).max()), name


def _flutter_speeds(res) -> list[float]:
    return sorted(p.velocity for r in res.results for p in r.points)


def test_rotated_bah_aircraft_has_the_same_modes_and_flutter(tmp_path):
    """The free-free BAH aircraft (its aerodynamic systems CORD2R 2 and 3 rotate with it):
    the same modes and kinds, and the deck's PK flutter within 0.1 %."""
    from torchrom.aero.nastran_flutter import run_deck

    from .test_public_decks import _bah_plane_both_subcases

    src = _bah_plane_both_subcases(tmp_path)
    res0 = run_deck(src, log=lambda *_: None)
    kinds0 = read_bdf(src).modes(8).kinds
    for name, path in _rotated_variants(src, tmp_path, ["90 deg about z", "CORD2R"]).items():
        res = run_deck(path, log=lambda *_: None)
        assert np.allclose(res.frequencies_hz, res0.frequencies_hz, rtol=1e-7, atol=1e-6)
        assert read_bdf(path).modes(8).kinds == kinds0, name
        v0, v = _flutter_speeds(res0), _flutter_speeds(res)
        assert len(v) == len(v0) >= 1 and np.allclose(v, v0, rtol=1e-3), (name, v, v0)


@pytest.mark.slow
def test_rotated_pazy_wing_has_the_same_modes_and_flutter(tmp_path):
    """The skinned Pazy wing (about 3,000 shell grids; its CAERO1 and AERO in basic): the same
    modes and kinds and the deck's PK flutter within 0.1 % after an arbitrary rotation."""
    from torchrom.aero.nastran_flutter import run_deck

    folder = DECKS / "aepw3_pazy_skin_flutter_tipmass1"
    src = folder / "sol145.dat"
    res0 = run_deck(src, log=lambda *_: None)
    (path,) = _rotated_variants(src, tmp_path, ["arbitrary"]).values()
    res = run_deck(path, log=lambda *_: None)
    assert np.allclose(res.frequencies_hz, res0.frequencies_hz, rtol=1e-7)
    v0, v = _flutter_speeds(res0), _flutter_speeds(res)
    assert len(v) == len(v0) >= 1 and np.allclose(v, v0, rtol=1e-3), (v, v0)


def test_rotated_pazy_wing_has_the_same_kinds(tmp_path):
    """The skinned Pazy deck's modes and kinds, rotated arbitrarily (CI form of the slow
    flutter test above). Frequencies within 1e-6: the rotated deck's stiffness differs from
    the original's by rounding only, which the ill-conditioned skinned wing (its 12 µm foil)
    and the eigensolver turn into 1e-7 (measured with OpenBLAS's Sandybridge kernel)."""
    src = DECKS / "aepw3_pazy_skin_flutter_tipmass1" / "sol145.dat"
    fe0 = read_bdf(src)
    m0 = fe0.modes(5)
    (path,) = _rotated_variants(src, tmp_path, ["CORD2R"]).values()
    m = read_bdf(path).modes(5)
    assert np.allclose(m.frequencies_hz, m0.frequencies_hz, rtol=1e-6)
    assert m.kinds == m0.kinds


def test_rotated_goland_chain_gives_the_same_rom_flutter_and_lco_rows(tmp_path):
    """The whole chain on the Goland deck and its copy turned 90° about z (grids in basic):
    identify 4L2D, aero on the built-in planform (placed in the wing's axes), ROM flutter and
    an LCO sweep. The ROM tensors agree up to basis signs (assert_same_tensors), the flutter
    speed within 0.1 % and each LCO row's amplitude within its certificate's output bound
    (measured: every printed digit equal)."""
    import pandas as pd

    from torchrom.fe.goland import updated_goland_bdf
    from torchrom.rom import NonlinearROM

    src = tmp_path / "goland.bdf"
    updated_goland_bdf().write_bdf(str(src), enddata=True)
    (rot,) = _rotated_variants(src, tmp_path, ["90 deg about z"]).values()
    speeds, tables = [], []
    for i, deck in enumerate((src, rot)):
        def cli(*argv):
            run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv), "-q"],
                                 capture_output=True, text=True, cwd=tmp_path, timeout=900)
            assert run.returncode == 0, run.stderr
        cli("identify", deck, "--linear", "4", "--dual", "2", "--out", f"r{i}.npz")
        cli("aero", deck, "--planform", "goland", "--mach", "0", "--modes", "4", "--out",
            f"a{i}.npz")
        cli("flutter", f"r{i}.npz", f"a{i}.npz", "--density", "0.0023769", "--json",
            f"f{i}.json")
        (tmp_path / f"s{i}.toml").write_text(
            f'title = "rotated Goland {i}"\nmethod = "hb"\n[model]\nrom = "r{i}.npz"\n'
            f'aero = "a{i}.npz"\n[initial]\nq0 = 0.05\nmode = 1\n[lco]\noutputs = ["A_Tz"]\n'
            'max_amplitude = 10.0\n[cases]\ndensity = 0.0023769\nspeed = [720.0, 760.0]\n'
            'alpha = 0.2565\ngamma = 1.338e-4\n')
        cli("sweep", f"s{i}.toml", "--out", f"o{i}")
        speeds.append(min(r["velocity"] for r in json.loads(
            (tmp_path / f"f{i}.json").read_text())["flutter"] if r.get("velocity")))
        tables.append(pd.read_parquet(tmp_path / f"o{i}" / "results.parquet"))
    r0, r1 = (NonlinearROM.load(tmp_path / f"r{i}.npz") for i in (0, 1))
    assert_same_tensors(r0, r1)
    assert speeds[1] == pytest.approx(speeds[0], rel=1e-3)
    t0, t1 = tables
    assert list(t0.status) == list(t1.status) == ["lco", "lco"]
    assert t0.certified.all() and t1.certified.all()
    bound = (t0.output_error + t1.output_error) * t0.amplitude
    assert np.all(np.abs(t1.amplitude - t0.amplitude) <= bound + 1e-12)


@pytest.mark.slow
def test_rotated_bah_aircraft_gives_the_same_rom(tmp_path):
    """The free-free BAH aircraft turned arbitrarily (grids in basic): identify 6L1D (its two
    rigid-body modes first) gives the same tensors up to basis signs. Measured: stiffness
    within 7e-10, D2 2.5e-5, D3 9.6e-4 (the decomposition's amplification, RTOL); 130 s per
    identification here, so not in CI (the CI form is the modes, kinds and deck flutter above)."""
    from torchrom.rom import NonlinearROM

    from .test_public_decks import _bah_plane_both_subcases

    src = _bah_plane_both_subcases(tmp_path)
    (rot,) = _rotated_variants(src, tmp_path, ["arbitrary"]).values()
    for i, deck in enumerate((src, rot)):
        run = subprocess.run([sys.executable, "-m", "torchrom", "identify", str(deck),
                              "--linear", "6", "--dual", "1", "--out", f"r{i}.npz", "-q"],
                             capture_output=True, text=True, cwd=tmp_path, timeout=1800)
        assert run.returncode == 0, run.stderr
    r0, r1 = (NonlinearROM.load(tmp_path / f"r{i}.npz") for i in (0, 1))
    assert r0.mode_kinds == r1.mode_kinds
    assert_same_tensors(r0, r1)


def test_rotated_bah_aircraft_gives_the_same_lco_rows(tmp_path):
    """The free BAH aircraft's LCO sweep (configs/bah_free_lco.toml: 8 modes, two of them
    rigid on a 0.05 Hz support) from the deck and from its arbitrary rotation: the same
    statuses, every row certified, amplitudes within the rows' stated accuracy (orbit_error +
    dt_error, relative: the certificate's distance to the discrete orbit plus the discrete
    orbit's to the continuous one). Measured: 5e-5 relative apart against a bound of 1.8e-3;
    not closer because the rigid-body modes are built along basic axes, so the rotated deck's
    rigid basis (on which the support acts) is another mix of the same six motions."""
    import pandas as pd

    from .test_public_decks import _bah_plane_both_subcases

    src = _bah_plane_both_subcases(tmp_path)
    (rot,) = _rotated_variants(src, tmp_path, ["arbitrary"]).values()
    config = (REPO / "configs" / "bah_free_lco.toml").read_text()
    tables = []
    for i, deck in enumerate((src, rot)):
        for argv in (["identify", deck, "--linear", "8", "--dual", "0", "--out", f"rom{i}.npz"],
                     ["aero", deck, "--mach", "0.2", "--modes", "8", "--kernel", "parabolic",
                      "--k", "0.001", "0.05", "0.1", "0.2", "0.5", "1.0", "--out",
                      f"aero{i}.npz"]):
            run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv), "-q"],
                                 capture_output=True, text=True, cwd=tmp_path, timeout=900)
            assert run.returncode == 0, run.stderr
        (tmp_path / f"c{i}.toml").write_text(config.replace('"rom.npz"', f'"rom{i}.npz"')
                                             .replace('"aero.npz"', f'"aero{i}.npz"'))
        run = subprocess.run([sys.executable, "-m", "torchrom", "sweep", f"c{i}.toml", "--out",
                              f"o{i}", "-q"], capture_output=True, text=True, cwd=tmp_path,
                             timeout=900)
        assert run.returncode == 0, run.stderr
        tables.append(pd.read_parquet(tmp_path / f"o{i}" / "results.parquet"))
    t0, t1 = tables
    assert list(t0.status) == list(t1.status) and set(t0.status) == {"lco"}
    assert t0.certified.all() and t1.certified.all()
    bound = (t0.orbit_error + t0.dt_error + t1.orbit_error + t1.dt_error) * t0.amplitude
    assert np.all(np.abs(t1.amplitude - t0.amplitude) <= bound)


PAZY_NOSKIN = DECKS / "aepw3_pazy_noskin_rigidtip" / "sol144_noskin.dat"
#: the condensed Pazy ROMs' tensors, relative to each one's largest entry (assert_same_tensors):
#: stiffness K2, K3 2e-5 (measured 3.6e-6 and 4.6e-7 at one nonlinear mode, 1.5e-6 and 2.2e-6
#: at three): each comes from static solves converged to 1e-8 of their load (fe_backend's
#: static_tol), whose solutions the thin wing's contrast of in-plane and bending stiffness
#: moves by ~1e-6 between two runs whose stiffness matrices differ by rounding; D2 1e-2, D3
#: 1e-3 (measured 2.3e-3 and 7.1e-5 at one nonlinear mode, 8.7e-5 and 2.2e-6 at three): the
#: damping decomposition's amplification of that difference (RTOL; at one nonlinear mode its
#: optimum sits on the extended matrix's semidefinite boundary, smallest scaled eigenvalue
#: 9e-10, where the free parameters follow K2's relative rounding ~600-fold)
PAZY_RTOL = {"K2": 2e-5, "K3": 2e-5, "D2": 1e-2, "D3": 1e-3}


def _assert_same_shapes(r0, r1, signs, R: np.ndarray, origin) -> None:
    """The ROMs' mesh shapes (basic frame) are the original's turned by R about ``origin``:
    positions to 1e-9 m (measured 5e-11: the rotated deck's 11-digit fields), translations to
    1e-7 of their largest (measured 1e-9), rotations to 1e-5 of theirs (measured 4.7e-7: the
    shells' drilling rotations, held by a small artificial stiffness, carry the eigen-solver's
    rounding of the massless DOFs)."""
    a, b = r0.shapes, r1.shapes
    assert np.array_equal(a.grid_ids, b.grid_ids)
    assert np.allclose(b.xyz, a.xyz @ R.T + np.asarray(origin), rtol=0, atol=1e-9)
    for part, tol in ((slice(0, 3), 1e-7), (slice(3, 6), 1e-5)):
        turned = np.einsum("ij,gjm->gim", R, a.phi[:, part, :]) * signs
        assert np.abs(b.phi[:, part, :] - turned).max() <= tol * np.abs(turned).max()


def test_rotated_pazy_wing_gives_the_same_condensed_rom(tmp_path):
    """The Pazy wing without skin (sol144_noskin.dat: 16,764 DOFs of co-rotational shells)
    turned arbitrarily, its grids in basic: the same modes and kinds, and the same condensed ROM
    (3 modes, the first one's cubic terms from its two static solves at a linear tip deflection
    of 10 % of the span): its tensors up to basis signs (PAZY_RTOL), its output (the tip's T3,
    in the grid's rotated CD frame) and its mesh shapes turned with the deck. Frequencies within
    1e-7 (measured 9e-10; 8e-9 with the grids in a CORD2R: the eigen-solver's rounding). The CI
    form of the chain below; 49 s on two shared cores."""
    from torchrom.identify.build import IdentifyOptions, identify

    name = "arbitrary"
    (rot,) = _rotated_variants(PAZY_NOSKIN, tmp_path, [name]).values()
    opt = IdentifyOptions(n_linear=3, n_dual=0, stiffness="condensed", amplitude=0.1, levels=1,
                          nonlinear_modes=1)
    kinds, roms = [], []
    for deck in (PAZY_NOSKIN, rot):
        fe = read_bdf(deck)
        kinds.append(fe.modes(3).kinds)
        roms.append(identify(fe, opt).rom)
    r0, r1 = roms
    assert kinds[0] == kinds[1] == ["bending", "bending", "torsion"]
    assert np.allclose(r1.frequencies_hz, r0.frequencies_hz, rtol=1e-7, atol=0)
    signs, _ = assert_same_tensors(r0, r1, rtols=PAZY_RTOL)
    assert sorted(r0.outputs) == sorted(r1.outputs) == ["max_mode1"]
    assert r0.metadata["output_points"] == r1.metadata["output_points"]
    c0, c1 = (np.asarray(r.outputs["max_mode1"], dtype=float) for r in roms)
    assert np.allclose(c1 * signs, c0, rtol=0, atol=1e-7 * np.abs(c0).max())  # measured 2e-9
    _assert_same_shapes(r0, r1, signs, ROTATIONS[name][0], (3.0, -1.0, 2.0))


@pytest.mark.slow
def test_rotated_pazy_chain_gives_the_same_rom_flutter_and_lco_rows(tmp_path):
    """The whole chain on the Pazy wing without skin and its arbitrary rotation with the grids in
    a CORD2R (its DLM panels, AERO system and beam spline turned with it), through the real CLI:
    identify a condensed 3-mode ROM (cubic terms of all three: two bendings and the torsion,
    loaded to 10 % of the span), aero on the deck's own panels, ROM flutter and an LCO sweep at
    72 and 76 m/s past the flutter speed (68.80 m/s, p-k). Measured: tensors as PAZY_RTOL says,
    Q(k) 1.1e-9 apart, flutter 6e-10, amplitudes 3.4e-7 (measured on two shared cores:
    identify 100 s, aero 18 s, flutter 9 s, sweep 8 s per deck; 257 s in all).

    The LCO rows cannot agree to their certificates' accuracy alone (output_error ~1e-9): the
    two ROMs themselves differ by rounding (K3 2e-6). A supercritical orbit's amplitude scales as
    the nonlinear stiffness to the power -1/2 (a cubic's closed form; the stiffness_nl = 1.01
    rows check it), so tensors apart by δ move it by about δ/2; allowed: δ (K2's and K3's
    measured difference), a factor 2 for a difference that is not a uniform scaling. γ = 0, so
    the damping tensors (the decomposition's amplified rounding) do not enter."""
    import pandas as pd

    from torchrom.rom import NonlinearROM

    (rot,) = _rotated_variants(PAZY_NOSKIN, tmp_path, ["CORD2R"]).values()
    speeds, tables, gafs = [], [], []
    for i, deck in enumerate((PAZY_NOSKIN, rot)):
        def cli(*argv):
            run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv), "-q"],
                                 capture_output=True, text=True, cwd=tmp_path, timeout=1200)
            assert run.returncode == 0, run.stderr
        cli("identify", deck, "--linear", "3", "--stiffness", "condensed", "--nonlinear-modes",
            "3", "--levels", "1", "--amplitude", "0.1", "--out", f"r{i}.npz")
        cli("aero", deck, "--mach", "0.001", "--modes", "3", "--lags", "4", "--k", "0.01",
            "0.05", "0.1", "0.2", "0.3", "0.5", "1.0", "--out", f"a{i}.npz")
        cli("flutter", f"r{i}.npz", f"a{i}.npz", "--density", "1.225", "--alpha", "0",
            "--gamma", "0", "--json", f"f{i}.json")
        (tmp_path / f"s{i}.toml").write_text(
            f'title = "rotated Pazy {i}"\nmethod = "hb"\n[model]\nrom = "r{i}.npz"\n'
            f'aero = "a{i}.npz"\n[aeroelastic]\nbaseline_alpha = 0.0\nbaseline_gamma = 0.0\n'
            '[initial]\nq0 = 0.01\nmode = 3\n[hb]\namplitude_scale = 0.1\n[lco]\n'
            'outputs = ["max_mode1"]\nmax_amplitude = 0.3\n[cases]\ndensity = 1.225\n'
            'speed = [72.0, 76.0]\nstiffness_nl = [1.0, 1.01]\nalpha = 0.0\ngamma = 0.0\n')
        cli("sweep", f"s{i}.toml", "--out", f"o{i}")
        speeds.append({r["method"]: r["velocity"] for r in json.loads(
            (tmp_path / f"f{i}.json").read_text())["flutter"] if r.get("velocity")})
        tables.append(pd.read_parquet(tmp_path / f"o{i}" / "results.parquet"))
        gafs.append(np.asarray(np.load(tmp_path / f"a{i}.npz")["Q"]))
    r0, r1 = (NonlinearROM.load(tmp_path / f"r{i}.npz") for i in (0, 1))
    assert np.allclose(r1.frequencies_hz, r0.frequencies_hz, rtol=1e-7, atol=0)
    signs, errs = assert_same_tensors(r0, r1, rtols=PAZY_RTOL)
    # Q_ij(k) -> s_i s_j Q_ij(k) (the aero's modes are identify's); measured 1.1e-9
    Q0, Q1 = gafs
    S = np.multiply.outer(signs, signs)[:, :, None]
    assert np.abs(Q1 * S - Q0).max() <= 1e-6 * np.abs(Q0).max()
    # the bound is 0.1 %; the inputs agree to 1e-9, so 1e-6 (measured 6e-10)
    assert set(speeds[0]) == set(speeds[1]) == {"p-k", "state-space"}
    for method, v in speeds[0].items():
        assert speeds[1][method] == pytest.approx(v, rel=1e-6), method
    t0, t1 = tables
    assert list(t0.status) == list(t1.status) == ["lco"] * 4
    assert t0.certified.all() and t1.certified.all()
    # the amplitude's scaling with the nonlinear stiffness (measured exponent -0.4998)
    for t in tables:
        a = t.set_index(["speed", "stiffness_nl"]).amplitude
        for v in (72.0, 76.0):
            assert np.log(a[v, 1.01] / a[v, 1.0]) / np.log(1.01) == pytest.approx(-0.5, abs=0.01)
    delta = max(errs["K2"], errs["K3"])
    bound = (t0.output_error + t1.output_error + delta) * t0.amplitude
    assert np.all(np.abs(t1.amplitude - t0.amplitude) <= bound)
