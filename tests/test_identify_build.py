"""The identification pipeline on the synthetic SVK truss: ROM vs the closed-form intrusive
projection, outputs and metadata, options and errors."""

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.identify.basis import DualModeOptions
from torchrom.identify.build import (
    IdentifyOptions,
    build_rom,
    identify,
    identify_each_damping,
)
from torchrom.rom import NonlinearROM

from .identify_fixtures import TrussWing, touze_backend

DUAL = DualModeOptions(combinations=((1, 1), (1, 2), (2, 2)), n_amplitudes=10)


def rel(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.fixture(scope="module")
def truss_exact():
    fe = TrussWing()
    return fe, identify(fe, IdentifyOptions(n_linear=5, n_dual=3, damping="exact", dual=DUAL))


def test_pipeline_matches_intrusive_projection(truss_exact):
    fe, res = truss_exact
    ref = fe.intrusive_rom(res.basis.Phi)
    rom = res.rom
    assert rom.n == 8 and rom.mode_kinds == ["linear"] * 5 + ["dual"] * 3
    # cubic FE, amplitude 1 % of span: rounding-level agreement (see test_identify_stiffness)
    for name in ("M", "K1", "K2", "K3", "D1", "D2", "D3"):
        assert rel(getattr(rom, name), getattr(ref, name)) < 1e-9, name
    # outputs are rows of the basis at point A, and the default: where mode 1 moves most
    assert set(rom.outputs) == {"A_Tx", "A_Ty", "A_Tz", "max_mode1"}
    trans = fe.translational_dofs
    assert np.abs(rom.outputs["max_mode1"][0]) == np.abs(res.basis.Phi[trans, 0]).max()
    assert np.array_equal(rom.outputs["A_Tz"], res.basis.Phi[fe.outputs["A_Tz"]])
    meta = rom.metadata
    assert meta["damping"]["method"] == "exact"
    assert meta["basis"]["n_dual"] == 3 and len(meta["identification"]["modal_amplitudes"]) == 8
    s = res.summary()
    # 30 dual-mode loads; "response" amplitudes take extra solves where the response softens
    solves = sum(r["solves"] for r in res.basis.snapshots)
    assert s["fe_static_solves"] == solves >= 30 and meta["basis"]["dual_fe_solves"] == solves
    assert s["fe_tangent_evaluations"] == 1 + 2 * 8 + 2 * 28


def test_rom_file_round_trip(truss_exact, tmp_path):
    _, res = truss_exact
    res.rom.save(tmp_path / "rom.npz")
    back = NonlinearROM.load(tmp_path / "rom.npz")
    assert torch.equal(back.K3, res.rom.K3) and back.mode_kinds == res.rom.mode_kinds
    assert back.metadata["damping"]["method"] == "exact"


def test_decomposition_pipeline_keeps_stiffness_and_dissipates():
    fe = TrussWing(n_bays=4)
    res = identify(fe, IdentifyOptions(n_linear=4, n_dual=2, dual=DUAL))
    ref = fe.intrusive_rom(res.basis.Phi)
    assert rel(res.rom.K3, ref.K3) < 1e-9           # stiffness is the identified one
    assert res.rom.extended_damping_min_eigenvalue() >= -1e-9 * res.rom.D1.abs().max()
    assert res.summary()["damping_method"] == "decomposition"


def test_each_damping_from_one_identification_is_each_identification_alone(truss_exact):
    """One FE pass for both damping methods (what ``torchrom paper`` builds its study's and
    its exact-damping check's ROMs with) gives, bit for bit, the tensors and basis of each
    method identified alone — the damping is identified after the stiffness from its results
    only — for the FE work of one (the exact method's, which adds the material tangents)."""
    fe = TrussWing()
    opt = IdentifyOptions(n_linear=5, n_dual=3, dual=DUAL)
    both = identify_each_damping(fe, opt, ("decomposition", "exact"))
    alone = {"decomposition": identify(TrussWing(), opt), "exact": truss_exact[1]}
    for method, res in alone.items():
        assert both[method].rom.metadata["damping"]["method"] == method
        assert np.array_equal(both[method].basis.Phi, res.basis.Phi)
        for name in ("M", "K1", "K2", "K3", "D1", "D2", "D3"):
            assert torch.equal(getattr(both[method].rom, name), getattr(res.rom, name)), name
    assert not torch.equal(both["exact"].rom.D3, both["decomposition"].rom.D3)
    assert (both["exact"].summary()["fe_static_solves"]
            == alone["exact"].summary()["fe_static_solves"])


def test_options_and_errors():
    with pytest.raises(InputError, match="damping"):
        build_rom(touze_backend(), n_linear=2, n_dual=0, damping="magic")
    be = touze_backend()
    be.has_material_tangent = False
    with pytest.raises(InputError, match="material tangent"):
        build_rom(be, n_linear=2, n_dual=0, damping="exact")
    with pytest.raises(InputError, match="cannot use"):
        build_rom(object())
    rom = build_rom(touze_backend(), n_linear=2, n_dual=0, damping="exact", stiffness="tangent")
    assert rom.n == 2


def test_dual_modes_of_a_linear_element_model_are_refused(tmp_path):
    """A stick model of small-rotation (linear) CBARs (the ExportNastranKM beam, root clamped)
    cannot give dual modes: refused before any dual-mode FE solve, saying what to do (issue 34:
    a Cholesky LinAlgError after 60 solves before); with n_dual = 0 it identifies. With the
    co-rotational CBARs (the default for decks) the same stick model has a geometric
    nonlinearity, and its dual modes give nonzero cubic stiffness."""
    from pathlib import Path

    from torchrom.fe import read_bdf

    deck = (Path(__file__).parent / "decks" / "ekm_bar_beam" / "test_case.bdf").read_text()
    path = tmp_path / "ekm_clamped.bdf"
    path.write_text(deck.replace("GRDSET,,,,,,,1256",
                                 "GRDSET,,,,,,,1256\nSPC1    2       123456  1"))
    fe = read_bdf(path, rotations="small")
    with pytest.raises(InputError, match="every element of the model is linear.*--dual 0"):
        identify(fe, IdentifyOptions(n_linear=2, n_dual=2))
    with pytest.warns(UserWarning, match="4 CBAR/CBEAM/CELAS/solid elements are linear"):
        assert identify(fe, IdentifyOptions(n_linear=2, n_dual=0)).rom.n == 2
    rom = identify(read_bdf(path), IdentifyOptions(n_linear=2, n_dual=2)).rom
    assert rom.n == 4 and float(abs(rom.K3).max()) > 1e-3 * float(abs(rom.K1).max())


def test_rom_keeps_its_basis_on_the_decks_grids(tmp_path):
    """Issue 47: a ROM identified from a deck keeps Φ on every grid (basic frame) with the
    grid ids and mesh; checked against the ROM's outputs, which are rows of the free-DOF basis
    taken by ``dof_index`` (not through the constraint expansion the shapes use): point A's
    T1..T3 rows equal the shapes at grid 1102 to rounding, an SPC'd root grid's shapes are zero,
    and the file keeps them bit for bit. A backend without a deck keeps none."""
    from torchrom.fe import goland

    fe = goland()
    rom = identify(fe, IdentifyOptions(n_linear=3, n_dual=0)).rom
    s = rom.shapes
    assert s is not None and s.n == rom.n == 3 and s.length_unit == "ft"
    np.testing.assert_array_equal(s.grid_ids, fe.grid_ids)
    assert (len(s.quads), len(s.lines)) == (len(fe.mesh.quads), len(fe.mesh.rods))
    row = {int(g): i for i, g in enumerate(s.grid_ids)}
    for c, name in enumerate(("A_Tx", "A_Ty", "A_Tz")):
        np.testing.assert_allclose(s.phi[row[1102], c], rom.outputs[name], rtol=0,
                                   atol=1e-14 * np.abs(rom.outputs["A_Tz"]).max())
    assert fe.mesh.spc  # the root's SPC'd components (no CD frames: basic components)
    for r, c in fe.mesh.spc:
        assert np.all(s.phi[r, c] == 0), (int(fe.grid_ids[r]), c + 1)
    rom.save(tmp_path / "rom.npz")
    back = NonlinearROM.load(tmp_path / "rom.npz").shapes
    np.testing.assert_array_equal(back.phi, s.phi)
    assert identify(touze_backend(), IdentifyOptions(n_linear=2, n_dual=0)).rom.shapes is None
