"""Nastran file exchange: decks read back by pyNastran with the intended cards; OP2/OP4 results
written (by pyNastran) from the synthetic FE's own results and read back give the same ROM."""

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.identify import nastran as nx
from torchrom.identify.basis import DualModeOptions, dual_loads, dual_modes_from_responses
from torchrom.identify.build import IdentifyOptions, identify
from torchrom.identify.damping import damping_from_material_tangents
from torchrom.identify.stiffness import stiffness_from_tangents

from .identify_fixtures import TrussWing

# the α of each load from its linear prediction: the plan that goes into one SOL 106 deck
DUAL = DualModeOptions(combinations=((1, 1), (1, 2)), n_amplitudes=6, amplitude_control="linear")


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("nastran")
    (d / "model.bdf").write_text("$ the user's bulk data (grids, elements, SPC 1)\n")
    return d / "model.bdf"


def test_load_deck_has_one_subcase_per_load(model_file):
    fe = TrussWing(n_bays=3)
    dm = fe.dofmap()
    loads = np.random.default_rng(0).normal(size=(4, fe.n_dof))
    path = nx.write_load_deck(model_file.parent / "dual.bdf", dm, loads, model_include=model_file)
    deck = nx.read_deck(path)
    assert "SOL 106" in deck.executive_control_lines
    subcases = [k for k in deck.case_control_deck.subcases if k > 0]
    assert subcases == [1, 2, 3, 4]
    assert deck.params["LGDISP"].values == [1]
    # the FORCE cards of each subcase add up to the intended free-DOF load vector
    for k, f in enumerate(loads, start=1):
        sub = deck.case_control_deck.subcases[k]
        sid = sub.get_parameter("LOAD")[0]
        G = np.zeros((len(dm.grid_ids), 6))
        for card in deck.loads[sid]:
            G[np.searchsorted(dm.grid_ids, card.node), :3] += card.mag * np.asarray(card.xyz)
        # 16-character double-precision fields keep 10 significant digits
        assert np.allclose(dm.free_values(G), f, rtol=1e-9, atol=1e-9 * np.abs(f).max())
    with pytest.raises(InputError, match="already exists"):
        nx.write_load_deck(path, dm, loads, model_include=model_file)


def test_displacement_decks_enforce_every_free_dof(model_file, tmp_path):
    fe = TrussWing(n_bays=3)
    dm = fe.dofmap()
    U = 1e-3 * np.random.default_rng(1).normal(size=(2, fe.n_dof))
    paths = nx.write_displacement_decks(tmp_path / "imposed", dm, U, model_include=model_file,
                                        material=True)
    assert [p.parent.name for p in paths] == ["p0001", "p0002"]
    assert (tmp_path / "imposed" / "run_all.sh").read_text().count("nastran imposed.bdf") == 2
    for u, p in zip(U, paths):
        deck = nx.read_deck(p)
        lines = "\n".join(deck.executive_control_lines)
        assert "OUTPUT4 KGGNL" in lines and "OUTPUT4 KMATNL" in lines
        assert "ASSIGN OUTPUT4='tangent.op4',UNIT=30" in p.read_text()
        assert deck.spcadds[902][0].sets == [1, 900]
        G = np.zeros((len(dm.grid_ids), 6))
        enforced = set()
        for card in deck.loads[901]:
            for nid, comp, val in zip(card.nodes, card.components, card.enforced):
                G[np.searchsorted(dm.grid_ids, nid), int(comp) - 1] = val
                enforced.add((nid, int(comp)))
        assert enforced == {tuple(r) for r in dm.free.tolist()}
        # 16-character double-precision fields keep 10 significant digits (with the sign)
        assert np.allclose(dm.free_values(G), u, rtol=1e-9, atol=1e-9 * np.abs(u).max())
        # the model's bulk data is included relative to the deck
        assert "INCLUDE '../../" in p.read_text()


def test_op4_round_trip_double_precision(tmp_path):
    A = np.random.default_rng(2).normal(size=(7, 7))
    A = A + A.T
    nx.write_op4_matrices(tmp_path / "k.op4", {"KGGNL": A})
    assert np.array_equal(nx.read_op4_matrix(tmp_path / "k.op4", "KGGNL"), A)
    with pytest.raises(InputError, match="no matrix"):
        nx.read_op4_matrix(tmp_path / "k.op4", "KAA")


def test_exchange_gives_the_same_rom(tmp_path, model_file):
    """The whole identification through files: dual-mode loads -> SOL 106 deck; responses as OP2
    (written from the FE's own solutions) -> dual modes; imposed displacements -> decks; tangents
    as g-set OP4 per run -> stiffness; decomposition -> damping. Equals the direct ROM to the
    single precision of OP2 results (1e-5 relative on the tensors; the dual modes carry ~1e-7)."""
    fe = TrussWing(n_bays=4)
    opt = IdentifyOptions(n_linear=4, n_dual=2, damping="exact", dual=DUAL)
    direct = identify(fe, opt)
    dm = fe.dofmap()
    lin = nx_linear = direct.basis.__class__(direct.basis.Phi[:, :4], ["linear"] * 4,
                                            direct.basis.frequencies_hz[:4])
    loads = dual_loads(fe, lin, DUAL)
    deck = nx.write_load_deck(tmp_path / "dual.bdf", dm, np.array([ld.load for ld in loads]),
                              model_include=model_file)
    assert len(nx.read_deck(deck).case_control_deck.subcases) == len(loads) + 1
    # "Nastran": the FE's static solutions, written as OP2
    U = np.array([fe.static_solve(ld.load).u for ld in loads])
    nx.write_op2_results(tmp_path / "dual.op2", dm, displacements=U)
    U_back = nx.read_op2_displacements(tmp_path / "dual.op2", dm)
    assert np.allclose(U_back, U, rtol=1e-6, atol=1e-7 * np.abs(U).max())
    basis, _ = dual_modes_from_responses(nx_linear, fe.mass_matrix(), U_back, 2,
                                         K=fe.stiffness_matrix())
    assert np.allclose(basis.Phi, direct.basis.Phi, atol=1e-5 * np.abs(direct.basis.Phi).max())
    # imposed displacements of the tangent plan, tangents as OP4 beside each deck
    points = direct.plan_points
    Phi = basis.Phi
    paths = nx.write_displacement_decks(tmp_path / "imposed", dm, points @ Phi.T,
                                        model_include=model_file, material=True)
    for q, p in zip(points, paths):
        # g-set matrices whose free-set reductions are the FE's tangents
        for fname, block, K in (("tangent.op4", "KGGNL", fe.tangent_stiffness(Phi @ q)),
                                ("material.op4", "KMATNL", fe.material_tangent(Phi @ q))):
            nx.write_op4_matrices(p.parent / fname, {block: dm.T @ K.toarray() @ dm.T.T})
    KT, Km = nx.read_tangent_decks(paths, dm, material=True)
    from torchrom.identify.stiffness import TangentPlan

    plan = TangentPlan(np.asarray(direct.rom.metadata["identification"]["modal_amplitudes"]))
    assert np.array_equal(plan.points, points)
    stiff = stiffness_from_tangents(plan, np.einsum("ai,pij,jb->pab", Phi.T, KT, Phi),
                                    Phi.T @ fe.stiffness_matrix() @ Phi)
    for name in ("K1", "K2", "K3"):
        ref = getattr(direct.stiffness, name)
        assert np.abs(getattr(stiff, name) - ref).max() < 1e-5 * np.abs(ref).max()
    damp = damping_from_material_tangents(plan, np.einsum("ai,pij,jb->pab", Phi.T, Km, Phi))
    for name in ("D1", "D2", "D3"):
        ref = getattr(direct.damping, name)
        assert np.abs(getattr(damp, name) - ref).max() < 1e-5 * np.abs(ref).max()
