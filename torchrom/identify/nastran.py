"""Identification with MSC/NX Nastran by file exchange (no Nastran is run by torchrom).

torchrom writes the decks a user runs, and reads the results back, through pyNastran:

- **dual modes** — :func:`write_load_deck`: one SOL 106 deck with one subcase per static load
  (FORCE/MOMENT cards in the basic system, NLPARM load stepping, ``DISPLACEMENT`` to the OP2);
  :func:`read_op2_displacements` returns the free-DOF responses in subcase order.
- **stiffness / damping** — :func:`write_displacement_decks`: one SOL 106 deck per imposed
  displacement u = Φq (every independent DOF enforced by SPC1 + SPCD), requesting the restoring
  forces (``SPCFORCES``, STEP) and, through a DMAP alter, the converged tangent stiffness (and
  optionally the material tangent) as OUTPUT4 matrices in double precision;
  :func:`read_op2_spc_forces` and :func:`read_op4_matrix` read them back. OP2 results are single
  precision (float32) in Nastran and in pyNastran; tangent matrices come through OP4 in double
  precision, which is why the tangent method is the recommended route with Nastran.

Free-DOF vectors are mapped to Nastran's g-set (6 components per grid, grids in id order) with a
:class:`DofMap` (from a ``torchrom.fe`` model of the same deck: ``DofMap.from_fe(fe)``); matrices
come back to the free set as Tᵀ K_gg T, forces at the enforced DOFs are read where they act.

The DMAP alter is a template (``TANGENT_DMAP``): the name of the data block that holds the
converged tangent differs between Nastran versions; it is a parameter of the writer. The decks are
checked here by reading them back with pyNastran; they have not been run through Nastran.
Delegated to pyNastran: card formatting, OP2/OP4 reading and writing.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import atomic_path, check_can_write

#: DMAP alter writing the converged tangent of SOL 106 to OUTPUT4 unit 30 in double precision.
#: ``{block}`` is the tangent data block (version dependent); ``{mat_block}`` the material part.
TANGENT_DMAP = """COMPILE NLSTATIC
ALTER 'NLITER' $ after the nonlinear iterations of the subcase: converged state
OUTPUT4 {block},,,,//-1/30/-2 $ tangent stiffness (g-set), double precision
"""
MATERIAL_DMAP = "OUTPUT4 {mat_block},,,,//-1/31/-2 $ material tangent (g-set)\n"


@dataclass
class DofMap:
    """Map between torchrom's free-DOF vectors and Nastran's g-set.

    grid_ids (n_grid,) in g-set order (ascending ids), free (n_dof, 2) = (grid id, component
    1..6) of each free (independent) DOF, T (6 n_grid, n_dof) with u_g = T u (dependent DOFs of
    rigid elements filled in, constrained ones zero).
    """

    grid_ids: np.ndarray
    free: np.ndarray
    T: np.ndarray

    @classmethod
    def from_fe(cls, fe) -> DofMap:
        n = fe.n_dof
        T = np.asarray(fe.expand(np.eye(n))).reshape(n, -1).T
        grid_ids = np.asarray(fe.grid_ids, dtype=int)
        if np.any(np.diff(grid_ids) <= 0):
            order = np.argsort(grid_ids)
            T = T.reshape(len(grid_ids), 6, n)[order].reshape(-1, n)
            grid_ids = grid_ids[order]
        return cls(grid_ids, np.asarray(fe.free_dofs(), dtype=int).reshape(-1, 2), T)

    @property
    def n_dof(self) -> int:
        return self.free.shape[0]

    @property
    def gset_positions(self) -> np.ndarray:
        row = {g: i for i, g in enumerate(self.grid_ids.tolist())}
        return np.array([6 * row[g] + c - 1 for g, c in self.free.tolist()], dtype=int)

    def to_gset(self, u: np.ndarray) -> np.ndarray:
        return (self.T @ np.asarray(u, float)).reshape(-1, 6)

    def free_values(self, U: np.ndarray) -> np.ndarray:
        """Values of a (n_grid, 6) g-set field at the free DOFs (displacements, SPC forces)."""
        return np.asarray(U, float).reshape(-1)[self.gset_positions]

    def free_matrix(self, K_gg: np.ndarray) -> np.ndarray:
        """Free-set matrix Tᵀ K_gg T of a g-set matrix."""
        K = K_gg.toarray() if hasattr(K_gg, "toarray") else np.asarray(K_gg, float)
        return self.T.T @ K @ self.T


def write_bulk_include(fe, path, *, force: bool = False) -> Path:
    """The bulk data of a ``torchrom.fe`` model's deck (no executive/case control), to be
    INCLUDEd by the decks written here."""
    if getattr(fe, "bdf", None) is None:
        raise InputError(f"write_bulk_include: model {getattr(fe, 'name', '')!r} has no deck")
    buf = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fe.bdf.write_bdf(buf, size=16, is_double=True, enddata=False, close=False)
    text = buf.getvalue()
    start = text.upper().find("BEGIN BULK")
    if start >= 0:
        text = text[text.index("\n", start) + 1:]
    return _write_text(path, text, force)


def _new_bdf():
    from pyNastran.bdf.bdf import BDF

    model = BDF(debug=None, log=None)
    model.log.level = "error"
    return model


def _write(model, path: Path, force: bool) -> Path:
    check_can_write(path, force, "deck")
    with atomic_path(path) as tmp, contextlib.redirect_stdout(io.StringIO()), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.write_bdf(str(tmp), size=16, is_double=True, enddata=True)
    return path


def write_load_deck(path, dofmap: DofMap, loads: np.ndarray, *, model_include,
                    model_spc: int = 1, nlparm_increments: int = 10, title: str = "torchrom",
                    force: bool = False) -> Path:
    """SOL 106 deck: one subcase per free-DOF load vector (rows of ``loads``), static
    nonlinear (PARAM,LGDISP,1), displacements to the OP2 (PARAM,POST,-1)."""
    loads = np.atleast_2d(np.asarray(loads, float))
    if loads.shape[1] != dofmap.n_dof:
        raise InputError(f"write_load_deck: loads have {loads.shape[1]} entries, expected "
                         f"{dofmap.n_dof}")
    model = _new_bdf()
    model.executive_control_lines = ["SOL 106", "CEND"]
    cc = [f"TITLE = {title}: dual-mode static loads", "ECHO = NONE", f"SPC = {model_spc}",
          "NLPARM = 1", "DISPLACEMENT(PLOT) = ALL"]
    for k, f in enumerate(loads, start=1):
        cc += [f"SUBCASE {k}", f"  LOAD = {1000 + k}"]
        G = dofmap.to_gset(np.zeros(dofmap.n_dof))
        G.reshape(-1)[dofmap.gset_positions] = f
        for gi, gid in enumerate(dofmap.grid_ids.tolist()):
            F, Mo = G[gi, :3], G[gi, 3:]
            if np.any(F):
                mag = float(np.linalg.norm(F))
                model.add_force(1000 + k, gid, mag, (F / mag).tolist())
            if np.any(Mo):
                mag = float(np.linalg.norm(Mo))
                model.add_moment(1000 + k, gid, mag, (Mo / mag).tolist())
    from pyNastran.bdf.bdf import CaseControlDeck

    model.case_control_deck = CaseControlDeck(cc)
    model.add_nlparm(1, ninc=nlparm_increments, kmethod="AUTO", max_iter=25, conv="UPW")
    model.add_param("LGDISP", [1])
    model.add_param("POST", [-1])
    path = Path(path)
    return _write_text(path, _with_include(model, _relative(model_include, path.parent)), force)


def write_displacement_decks(directory, dofmap: DofMap, displacements: np.ndarray, *,
                             model_include, model_spc: int = 1, tangent: bool = True,
                             material: bool = False, tangent_block: str = "KGGNL",
                             material_block: str = "KMATNL", title: str = "torchrom",
                             force: bool = False) -> list[Path]:
    """One SOL 106 deck per imposed free-DOF displacement (rows of ``displacements``):
    ``directory/p0001/imposed.bdf`` ... Every free DOF is enforced (SPC1 set 900 + SPCD set 901,
    combined with the model's SPC set by SPCADD 902). Requests SPCFORCES (restoring forces, STEP)
    and, with ``tangent``/``material``, the DMAP alter writing the tangent matrices to
    ``tangent.op4`` / ``material.op4``. A ``run_all.sh`` lists the runs in order.
    """
    directory = Path(directory)
    U = np.atleast_2d(np.asarray(displacements, float))
    if U.shape[1] != dofmap.n_dof:
        raise InputError(f"write_displacement_decks: displacements have {U.shape[1]} entries, "
                         f"expected {dofmap.n_dof}")
    paths = []
    for k, u in enumerate(U, start=1):
        model = _new_bdf()
        execs = []
        if tangent or material:
            execs += ["ASSIGN OUTPUT4='tangent.op4',UNIT=30,FORM=FORMATTED"]
            if material:
                execs += ["ASSIGN OUTPUT4='material.op4',UNIT=31,FORM=FORMATTED"]
        execs += ["SOL 106"]
        if tangent or material:
            dmap = TANGENT_DMAP.format(block=tangent_block) if tangent else (
                "COMPILE NLSTATIC\nALTER 'NLITER'\n")
            if material:
                dmap += MATERIAL_DMAP.format(mat_block=material_block)
            execs += dmap.strip().splitlines()
        execs += ["CEND"]
        model.executive_control_lines = execs
        from pyNastran.bdf.bdf import CaseControlDeck

        model.case_control_deck = CaseControlDeck([
            f"TITLE = {title}: imposed displacement {k} of {len(U)}", "ECHO = NONE",
            "SUBCASE 1", "  SPC = 902", "  LOAD = 901", "  NLPARM = 1",
            "  SPCFORCES(PLOT) = ALL", "  DISPLACEMENT(PLOT) = ALL"])
        nodes, comps, vals = [], [], []
        G = dofmap.to_gset(u)
        for gid, c in dofmap.free.tolist():
            nodes.append(gid)
            comps.append(str(c))
            vals.append(float(G[np.searchsorted(dofmap.grid_ids, gid), c - 1]))
        for gid, c, v in zip(nodes, comps, vals):
            model.add_spc1(900, c, [gid])
            model.add_spcd(901, [gid], [c], [v])
        model.add_spcadd(902, [model_spc, 900])
        model.add_nlparm(1, ninc=10, kmethod="AUTO", max_iter=25, conv="UPW")
        model.add_param("LGDISP", [1])
        model.add_param("POST", [-1])
        path = directory / f"p{k:04d}" / "imposed.bdf"
        path.parent.mkdir(parents=True, exist_ok=True)
        paths.append(_write_text(path, _with_include(model, _relative(model_include, path.parent)),
                                 force))
    script = "#!/bin/sh\n# run every imposed-displacement deck (edit the nastran command)\n"
    script += "".join(f"(cd {p.parent.name} && nastran imposed.bdf)\n" for p in paths)
    _write_text(directory / "run_all.sh", script, True)
    return paths


def _relative(target, start: Path) -> str:
    import os

    return os.path.relpath(Path(target).resolve(), Path(start).resolve())


def _with_include(model, include: str) -> str:
    buf = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.write_bdf(buf, size=16, is_double=True, enddata=False, close=False)
    text = buf.getvalue()
    # the model's own bulk data (grids, elements, materials, its SPC set) comes by INCLUDE
    return text + f"INCLUDE '{include}'\nENDDATA\n"


def _write_text(path, text: str, force: bool) -> Path:
    path = Path(path)
    check_can_write(path, force, "deck")
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path


def read_deck(path):
    """Read a deck written here back with pyNastran (includes resolved)."""
    model = _new_bdf()
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.read_bdf(str(path), punch=False, validate=False, xref=False)
    return model


# ------------------------------------------------------------------------------------------------
# results
# ------------------------------------------------------------------------------------------------
def _read_op2(path):
    from pyNastran.op2.op2 import read_op2

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such OP2 file")
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return read_op2(str(path), debug=None, build_dataframe=False, log=None)
        except Exception as exc:  # pyNastran raises many types on a corrupt file
            raise InputError(f"{path}: not a readable OP2 file ({exc})") from None


def _table_to_free(path, table: dict, dofmap: DofMap, what: str) -> np.ndarray:
    if not table:
        raise InputError(f"{path}: no {what} results in the OP2 file")
    rows = []
    for isub in sorted(table):
        res = table[isub]
        nids = res.node_gridtype[:, 0]
        G = np.zeros((len(dofmap.grid_ids), 6))
        pos = np.searchsorted(dofmap.grid_ids, nids)
        ok = (pos < len(dofmap.grid_ids)) & (dofmap.grid_ids[np.minimum(
            pos, len(dofmap.grid_ids) - 1)] == nids)
        G[pos[ok]] = res.data[-1][ok]
        rows.append(dofmap.free_values(G))
    return np.array(rows)


def read_op2_displacements(path, dofmap: DofMap) -> np.ndarray:
    """Free-DOF displacements (n_subcases, n_dof), subcases in ascending order."""
    return _table_to_free(path, _read_op2(path).displacements, dofmap, "DISPLACEMENT")


def read_op2_spc_forces(path, dofmap: DofMap) -> np.ndarray:
    """Restoring forces at the enforced free DOFs (n_subcases, n_dof) (STEP)."""
    return _table_to_free(path, _read_op2(path).spc_forces, dofmap, "SPCFORCES")


def write_op2_results(path, dofmap: DofMap, displacements=None, spc_forces=None, *,
                      force: bool = False) -> Path:
    """Write free-DOF results as an OP2 (one static subcase per row) with pyNastran.

    Used to exchange results computed elsewhere and by the tests (built-in FE results standing in
    for Nastran's). Values are stored in single precision, as Nastran does.
    """
    from pyNastran.op2.op2 import OP2
    from pyNastran.op2.tables.oqg_constraintForces.oqg_spc_forces import RealSPCForcesArray
    from pyNastran.op2.tables.oug.oug_displacements import RealDisplacementArray

    path = check_can_write(Path(path), force, "OP2 file")
    op2 = OP2(debug=None, log=None)
    op2.set_mode("msc")
    ngt = np.column_stack([dofmap.grid_ids, np.ones(len(dofmap.grid_ids), int)])
    pos = dofmap.gset_positions
    for table, cls, rows, name in ((op2.displacements, RealDisplacementArray, displacements,
                                    "OUGV1"),
                                   (op2.spc_forces, RealSPCForcesArray, spc_forces, "OQG1")):
        if rows is None:
            continue
        for isub, r in enumerate(np.atleast_2d(rows), start=1):
            G = np.zeros(6 * len(dofmap.grid_ids))
            G[pos] = r
            table[isub] = cls.add_static_case(name, ngt, G.reshape(1, -1, 6), isub,
                                              is_sort1=True)
    with atomic_path(path) as tmp, contextlib.redirect_stdout(io.StringIO()), \
            warnings.catch_warnings():
        # pyNastran warns when it stores float64 results in single precision: that is the format
        warnings.simplefilter("ignore")
        op2.write_op2(str(tmp), post=-1, endian=b"<", nastran_format="msc")
    return path


def write_op4_matrices(path, matrices: dict[str, np.ndarray], *, force: bool = False) -> Path:
    """Write dense matrices to an ASCII OP4 file in double precision (pyNastran)."""
    from pyNastran.op4.op4 import OP4

    path = check_can_write(Path(path), force, "OP4 file")
    op4 = OP4(log=None)
    op4.log.level = "error"
    mats = {name: (2 if np.allclose(m, m.T) else 1, np.asarray(m, float))
            for name, m in matrices.items()}
    with atomic_path(path) as tmp:
        op4.write_op4(str(tmp), mats, precision="double", is_binary=False)
    return path


def read_op4_matrix(path, name: str | None = None) -> np.ndarray:
    """One matrix of an OP4 file as a dense float64 array (the only one if ``name`` is None)."""
    from pyNastran.op4.op4 import read_op4

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such OP4 file")
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            mats = read_op4(str(path), precision="double", debug=False)
        except Exception as exc:  # pyNastran raises many types on a corrupt file
            raise InputError(f"{path}: not a readable OP4 file ({exc})") from None
    if name is None:
        if len(mats) != 1:
            raise InputError(f"{path}: holds {sorted(mats)}; name the matrix to read")
        name = next(iter(mats))
    if name not in mats:
        raise InputError(f"{path}: no matrix {name!r} (it has {sorted(mats)})")
    m = mats[name].data
    return np.asarray(m.toarray() if hasattr(m, "toarray") else m, dtype=float)


def read_tangent_decks(paths, dofmap: DofMap, *, tangent_block: str = "KGGNL",
                       material_block: str = "KMATNL", material: bool = False):
    """Free-set tangents (P, n_dof, n_dof) (and material tangents) from the run directories of
    :func:`write_displacement_decks` (``tangent.op4`` / ``material.op4`` beside each deck)."""
    KT, Km = [], []
    for p in paths:
        d = Path(p).parent
        KT.append(dofmap.free_matrix(read_op4_matrix(d / "tangent.op4", tangent_block)))
        if material:
            Km.append(dofmap.free_matrix(read_op4_matrix(d / "material.op4", material_block)))
    return np.array(KT), (np.array(Km) if material else None)
