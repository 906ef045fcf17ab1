"""Nastran bulk data → :class:`torchrom.fe.model.FEModel`.

Delegated to pyNastran: parsing the deck (free/small/large field, continuations, INCLUDE),
card objects and the coordinate systems' axes (``Coord.beta()``, ``GRID.get_position()``).
Written here: which cards are supported, the checks that turn bad input into one-line
:class:`~torchrom.errors.InputError` messages naming the file, card and ID, the conversion of
properties/materials/constraints/loads into the plain arrays of :mod:`torchrom.fe.mesh`, and the
selection of the SPC set and eigenvalue method from the case control (or the only one present).

Supported structural cards: GRID (CP, CD, PS), GRDSET, SPOINT (a one-DOF row after the grids),
CORD1R/C/S, CORD2R/C/S, SPC, SPC1, SPCADD, MPC/MPCADD, MAT1, CROD/PROD, CONROD, CQUAD4/CTRIA3
with PSHELL or PCOMP (MAT1/MAT8 plies, :mod:`torchrom.fe.laminate`) and ZOFFS
(:mod:`torchrom.fe.elements.offset`), CHEXA/CPENTA/CTETRA/PSOLID (corner grids, or with all
their edge grids), CSHEAR/PSHEAR, CBAR/PBAR/PBARL, CBEAM/PBEAM/PBEAML (:mod:`torchrom.fe.sections`;
offsets with every CBAR OFFT code, pin flags, I12: :mod:`torchrom.fe.elements.bar`), CELAS1/PELAS,
CELAS2, CONM1, CONM2, CMASS1/PMASS, CMASS2, CBUSH/PBUSH, GENEL, RBE1, RBE2, RBAR, RBE3, EIGR,
EIGRL, FORCE,
MOMENT, PLOAD2, PLOAD4, GRAV, LOAD, PARAM (COUPMASS, WTMASS are used). Cards without effect on modes
and flutter are accepted with a note (:data:`torchrom.fe.bdf_cards.NOTED_CARDS`); a SOL 200
deck's cards must agree with its design relations at the initial design
(:mod:`torchrom.fe.design`).
Aerodynamic and solution-control cards (CAERO1, PAERO1, SPLINE*, SET1, AERO, AEROS, MKAERO*,
FLFACT, FLUTTER, ...) are kept in ``fe.bdf`` for :mod:`torchrom.aero` and ignored here. Any other
card is an error listing the card names and counts (``unsupported="warn"`` demotes it to a
warning and ignores those cards).
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import re
import warnings
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .bdf_cards import NOTED_CARDS, apply_grdset, reason, refuse_gset_matrices
from .bdf_checks import card_error_message, check_complete, check_fields, duplicate_message
from .bdf_extra import SOLID_GRIDS, ExtraCards
from .coords import axes_at
from .coords import components as _comps
from .design import check_initial_design
from .elements.bar import frames_between, mechanism_pins
from .elements.quad4 import quad_frames, shape
from .goland_geometry import (  # noqa: F401 - GOLAND_* re-exported (public names of this module)
    GOLAND_ROTATIONS_NOTE,
    GOLAND_TITLE,
    GOLAND_UNITS,
    WING_CHORD,
    goland_output_points,
)
from .mesh import (
    BarSet,
    InterpRBE3,
    Mesh,
    PointMass,
    QuadSet,
    RigidRBE2,
    RodSet,
    ScalarMass,
    ShearSet,
    SolidSet,
    TriaSet,
)
from .sections import section

STRUCTURAL_CARDS = frozenset(
    "GRID GRDSET SPOINT CORD1R CORD1C CORD1S CORD2R CORD2C CORD2S SPC SPC1 SPCADD MPC MPCADD MAT1 "
    "CROD PROD CONROD CQUAD4 CTRIA3 PSHELL PCOMP MAT8 CSHEAR PSHEAR CBAR PBAR PBARL CBEAM PBEAM "
    "PBEAML CONM2 CMASS2 CHEXA CPENTA CTETRA PSOLID RBE1 RBE2 RBE3 RBAR CELAS1 CELAS2 PELAS "
    "CMASS1 PMASS CONM1 CBUSH PBUSH GENEL EIGR EIGRL FORCE MOMENT PLOAD2 PLOAD4 GRAV LOAD PARAM "
    "ENDDATA".split()
)
# Kept for the aerodynamics (and for Nastran itself when the deck is written back); no effect on
# the structure.
PASSIVE_CARDS = frozenset(
    "AERO AEROS CAERO1 CAERO2 CAERO3 CAERO4 CAERO5 PAERO1 PAERO2 PAERO3 PAERO4 PAERO5 SPLINE1 "
    "SPLINE2 SPLINE3 SPLINE4 SPLINE5 SPLINE6 SPLINE7 SET1 SET2 MKAERO1 MKAERO2 FLFACT FLUTTER "
    "AEFACT AELIST AESURF AESURFS AESTAT AELINK AEPARM TRIM DIVERG CSSCHD EIGC TABDMP1 MONPNT1 "
    "GUST NLPARM TSTEP DMI".split()
)
CORNERS = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0))


class UnsupportedCardWarning(UserWarning):
    """Cards the FE reader ignores (only with ``unsupported='warn'``)."""


def _quiet_logger() -> logging.Logger:
    log = logging.getLogger("torchrom.pyNastran")
    if not log.handlers:
        log.addHandler(logging.NullHandler())
    log.propagate = False
    return log


_FIELD_MSG = re.compile(r"^(\w+) = (.*?) \(field #(\d+)\) on card (.*)$")
_CARD_MSG = re.compile(r"card=\[(.*?)\]", re.S)


def _pynastran_error(fname: str, exc: Exception) -> InputError:
    """One line from a pyNastran parsing error: file, card, id, field and what was wrong."""
    text = str(exc)
    duplicate = duplicate_message(fname, text)
    if duplicate is not None:
        return InputError(duplicate)
    first = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
    card = ""
    m = _CARD_MSG.search(text)
    if m:
        parts = [p.strip().strip("'\"") for p in m.group(1).split(",")]
        card = " ".join(p for p in parts[:2] if p and p != "None")
    f = _FIELD_MSG.match(first)
    if f:
        name, value, num, rest = f.groups()
        what = re.sub(r"\s*\(not an? [^)]*\)", "", rest.rstrip(".")).replace("must be", "expected")
        return InputError(f"{fname}: {card}: field #{num} ({name}): {what}, got {value}")
    known = card_error_message(fname, exc, first)
    if known is not None:
        return InputError(known)
    where = f"{card}: " if card else ""
    return InputError(f"{fname}: {where}{first}")


_INCLUDE = re.compile(r"^\s*INCLUDE\s+'([^']*)'?", re.IGNORECASE)


def _check_includes(text: str, path: Path) -> None:
    """Every INCLUDE of the deck (and of the files it includes) names a regular file inside the
    deck's folder or the working directory (:func:`torchrom.io.check_referenced_path`)."""
    from ..io import check_referenced_path

    seen = {path.resolve()}
    todo = [(text, path)]
    while todo:
        body, owner = todo.pop()
        for line in body.splitlines():
            m = _INCLUDE.match(line)
            if m is None:
                continue
            inc = check_referenced_path(m.group(1).strip(), owner, "INCLUDE")
            if inc not in seen:
                seen.add(inc)
                try:
                    todo.append((inc.read_text(errors="replace"), inc))
                except OSError as exc:
                    raise InputError(f"{owner}: INCLUDE {m.group(1)}: cannot read: "
                                     f"{exc.strerror or exc}") from None


_ENDDATA = re.compile(r"^\s*ENDDATA", re.IGNORECASE | re.MULTILINE)


def with_includes(text: str, includes=()) -> str:
    """The deck's ``text`` with an INCLUDE of each file of ``includes`` (e.g. the cards of
    ``torchrom panels``) before its ENDDATA (at its end without one): the deck read as if the
    user had added the lines, the file itself untouched."""
    if not includes:
        return text
    lines = "".join(f"INCLUDE '{Path(p).resolve()}'\n" for p in includes)
    m = _ENDDATA.search(text)
    if m is None:
        return text.rstrip("\n") + "\n" + lines
    return text[: m.start()] + lines + text[m.start():]


def check_include_files(includes, option: str = "--panels") -> None:
    """Each extra include file exists and is a text deck (InputError naming ``option``)."""
    from ..checks import expect_text_file

    for p in includes or ():
        if not Path(p).is_file():
            raise InputError(f"{option} {p}: no such file")
        expect_text_file(Path(p), "a file of Nastran cards", "panels.bdf")


def _read_pynastran(path: Path, includes=()):
    from pyNastran.bdf.bdf import read_bdf as pn_read_bdf

    try:
        text = path.read_text(errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read the deck: {exc.strerror or exc}") from None
    check_complete(text, path.name)
    _check_includes(text, path)
    check_include_files(includes)
    text = with_includes(text, includes)
    upper = [ln.split("$")[0].strip().upper() for ln in text.splitlines()]
    has_cend = any(ln == "CEND" for ln in upper)
    has_begin = any(ln.startswith("BEGIN") and "BULK" in ln for ln in upper)
    if not has_cend:
        # A bulk-data-only deck: give pyNastran an empty executive/case control section.
        text = "SOL 103\nCEND\n" + ("" if has_begin else "BEGIN BULK\n") + text
    sink = io.StringIO()
    try:
        # INCLUDE paths are relative to the deck (pyNastran reads a text stream relative to
        # the working directory).
        with contextlib.redirect_stdout(sink), warnings.catch_warnings(), \
                contextlib.chdir(path.resolve().parent):
            warnings.simplefilter("ignore")
            model = pn_read_bdf(io.StringIO(text), xref=False, validate=False, log=_quiet_logger())
    except Exception as exc:  # pyNastran raises many types for bad cards
        raise _pynastran_error(path.name, exc) from None
    return model


#: a deck at least this large (bytes) reports its reading stages (parse, mesh, assembly)
LARGE_DECK_BYTES = 1_000_000


def read_bdf(
    path,
    *,
    spc_id: int | None = None,
    unsupported: str = "error",
    drilling: float = 1e-4,
    autospc: bool | None = None,
    output_points: dict[str, tuple[int, int]] | None = None,
    rotations: str | None = None,
    without_properties=(),
    includes=(),
):
    """Read a Nastran deck into an :class:`~torchrom.fe.model.FEModel`.

    ``spc_id`` selects the SPC set (default: the case control's SPC, else the only set);
    ``unsupported`` is ``"error"`` (default) or ``"warn"``; ``drilling`` scales the CQUAD4
    drilling penalty; ``autospc`` removes DOFs without stiffness (Nastran's AUTOSPC; default:
    the deck's case control AUTOSPC or PARAM AUTOSPC, else yes);
    ``output_points`` maps names to (grid id, component 1..6) — decks written by
    ``torchrom goland`` get the Goland point A automatically; ``rotations`` "large"
    (co-rotational plate bending, beams and rod torsion in nonlinear analyses) or "small"
    (those linear); default "large", except "small" for a deck written by ``torchrom goland``
    (the paper's model); ``without_properties``: PSHELL/PCOMP ids whose CQUAD4/CTRIA3 are left
    out (:func:`shell_ids_of`; the structure without its foil skin); ``includes``: files of
    cards read as if INCLUDEd at the deck's end (:func:`with_includes`).
    """
    from ..checks import expect_text_file
    from ..progress import Stages

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such deck")
    expect_text_file(path, "a Nastran deck", "model.bdf")
    size = path.stat().st_size
    stages = Stages(f"reading {path.name}", size >= LARGE_DECK_BYTES)
    stages.start(f"parsing {size / 1e6:.0f} MB of cards")
    model = _read_pynastran(path, includes)
    return from_pynastran(
        model,
        stages=stages,
        source=str(path),
        name=path.stem,
        spc_id=spc_id,
        unsupported=unsupported,
        drilling=drilling,
        autospc=autospc,
        output_points=output_points,
        rotations=rotations,
        without_properties=without_properties,
    )


def shell_ids_of(model, pids, fname: str, option: str = "--linear-skin") -> np.ndarray:
    """The CQUAD4/CTRIA3 ids of the shell properties ``pids`` (a foil skin). A property that
    is missing or carries no such shell is refused in one line naming ``option``."""
    eids: list[int] = []
    for pid in pids:
        prop = model.properties.get(int(pid))
        if prop is None:
            raise InputError(f"{fname}: {option} {pid}: no property {pid} in the deck")
        ids = sorted(eid for eid, e in model.elements.items()
                     if e.type in ("CQUAD4", "CTRIA3") and e.pid == int(pid))
        if not ids:
            raise InputError(f"{fname}: {option} {pid}: {prop.type} {pid} is used by no "
                             "CQUAD4 or CTRIA3 (only a shell skin can be left out)")
        eids.extend(ids)
    return np.array(eids, dtype=int)


def _without_shells(mesh, eids: np.ndarray):
    """The mesh without the CQUAD4/CTRIA3 ``eids`` (their grids stay; AUTOSPC removes the DOFs
    that nothing else holds)."""
    from dataclasses import replace

    return replace(mesh, quads=mesh.quads.select(~np.isin(mesh.quads.eids, eids)),
                   trias=mesh.trias.select(~np.isin(mesh.trias.eids, eids)))


def _case_value(model, key: str):
    """First value of a case-control entry (global subcase first), or None."""
    cc = model.case_control_deck
    if cc is None:
        return None
    for isub in sorted(cc.subcases):
        try:
            return cc.subcases[isub].get_parameter(key)[0]
        except KeyError:
            continue
    return None


def _deck_autospc(model) -> bool:
    """Nastran's AUTOSPC switch of the deck: case control AUTOSPC, else PARAM AUTOSPC, else
    YES (SOL 103's default)."""
    value = _case_value(model, "AUTOSPC")
    if value is None:
        p = model.params.get("AUTOSPC")
        value = p.values[0] if p is not None and p.values else "YES"
    return str(value).strip().upper() not in ("NO", "N", "-1")


def _title(model) -> str:
    value = _case_value(model, "TITLE")
    return "" if value is None else str(value).strip()


def from_pynastran(
    model,
    *,
    source: str,
    name: str,
    spc_id: int | None = None,
    unsupported: str = "error",
    drilling: float = 1e-4,
    autospc: bool | None = None,
    output_points: dict[str, tuple[int, int]] | None = None,
    units: dict[str, str] | None = None,
    stages=None,
    rotations: str | None = None,
    without_properties=(),
):
    """Build an FEModel from a pyNastran ``BDF`` object (read from a file or built in memory);
    ``stages`` (:class:`torchrom.progress.Stages`) reports the mesh and assembly stages."""
    from ..progress import Stages
    from .model import FEModel

    stages = stages or Stages(name, enabled=False)
    fname = Path(source).name
    if unsupported not in ("error", "warn"):
        raise InputError(f"unsupported: expected 'error' or 'warn', got {unsupported!r}")
    notes = _check_cards(model, fname, unsupported)
    refuse_gset_matrices(model, fname)
    notes += check_initial_design(model, fname)
    if autospc is None:
        autospc = _deck_autospc(model)
    check_fields(model, fname)
    reader = _Reader(model, fname)
    stages.start(f"building the mesh of {len(model.nodes)} grids and {len(model.elements)} "
                 f"elements")
    mesh = reader.mesh(spc_id)
    if len(without_properties):
        mesh = _without_shells(mesh, shell_ids_of(model, without_properties, fname))
    loads = reader.loads(mesh)
    stages.start("assembling the stiffness and mass matrices")
    title = _title(model)
    wing_chord = None
    goland_deck = title.startswith(GOLAND_TITLE)
    if rotations is None:
        # the heavy Goland wing is the paper's small-rotation model (plate bending linear)
        rotations = "small" if goland_deck else "large"
        if goland_deck:
            notes.append(GOLAND_ROTATIONS_NOTE)
    goland_points = goland_deck and output_points is None
    if goland_deck:
        wing_chord = WING_CHORD
        if goland_points:
            units = units or dict(GOLAND_UNITS)
    if units is None:
        from .deck_units import deck_units

        units = deck_units(model, fname)
    fe = FEModel(
        mesh,
        name=name,
        source=source,
        units=units or {"system": "consistent units of the deck"},
        bdf=model,
        loads=loads,
        n_modes_requested=reader.n_modes(),
        output_points=output_points or {},
        drilling=drilling,
        autospc=autospc,
        rotations=rotations,
    )
    fe.wing_chord = wing_chord
    if goland_points:
        fe.set_output_points(goland_output_points(fe))
    fe.notes = notes + reader.notes + _unused_params(model) + fe.notes
    stages.done()
    return fe


#: PARAMs that torchrom reads: the FE reader's, the flutter solution's (torchrom.aero) and the
#: structural damping's of a ROM (torchrom.fe.damping_cards)
READ_PARAMS = frozenset({"AUTOSPC", "COUPMASS", "WTMASS", "LGDISP", "POST", "LMODES", "VREF",
                         "RESVEC", "KDAMP", "G", "W3", "W4"})


def _unused_params(model) -> list[str]:
    """One note naming the deck's PARAMs that no solution here reads (a K6ROT, a G, a GRDPNT
    changes what Nastran computes or prints, not what is computed here)."""
    unused = sorted(k for k in model.params if str(k).upper() not in READ_PARAMS)
    return [f"PARAM {', '.join(unused)}: not applied (read: "
            f"{', '.join(sorted(READ_PARAMS))})"] if unused else []


def _check_cards(model, fname: str, unsupported: str) -> list[str]:
    """Refuse (or with ``unsupported='warn'`` ignore) unknown cards; notes for the cards that
    change nothing in a modes/flutter solution (:data:`~torchrom.fe.bdf_cards.NOTED_CARDS`)."""
    counts = Counter({k: v for k, v in model.card_count.items() if v})
    notes = [f"{k} ({v}) accepted, ignored: {NOTED_CARDS[k]}"
             for k, v in sorted(counts.items()) if k in NOTED_CARDS]
    known = STRUCTURAL_CARDS | PASSIVE_CARDS | NOTED_CARDS.keys()
    bad = {k: v for k, v in counts.items() if k not in known}
    if not bad:
        return notes
    listing = "; ".join(f"{k} ({v}): {reason(k)}" for k, v in sorted(bad.items()))
    if unsupported == "error":
        raise InputError(
            f"{fname}: unsupported cards: {listing}. The FE reader supports "
            f"{', '.join(sorted(STRUCTURAL_CARDS - {'ENDDATA', 'PARAM', 'GRDSET'}))} "
            "(unsupported='warn' or --unsupported warn ignores them)"
        )
    warnings.warn(f"{fname}: ignoring unsupported cards: {listing}", UnsupportedCardWarning,
                  stacklevel=3)
    return notes + [f"ignored unsupported cards: {listing}"]


class _Reader(ExtraCards):
    """Turns a pyNastran model into a :class:`Mesh` with card-level checks."""

    def __init__(self, model, fname: str):
        self.m = model
        self.f = fname
        self.notes: list[str] = []

    def err(self, msg: str) -> InputError:
        return InputError(f"{self.f}: {msg}")

    # -- grids -------------------------------------------------------------------------------
    def grids(self):
        m = self.m
        apply_grdset(m)
        for nid, node in m.nodes.items():
            for field, cid in (("CP", node.cp), ("CD", node.cd)):
                if cid not in (0, None, -1) and cid not in m.coords:
                    raise self.err(f"GRID {nid}: field {field}: coordinate system {cid} not found")
        for cid, coord in m.coords.items():
            rid = getattr(coord, "rid", 0)
            if rid not in (0, None) and rid not in m.coords:
                raise self.err(f"{coord.type} {cid}: field RID: coordinate system {rid} not found")
        if not m.nodes:
            raise self.err("no GRID cards")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m.cross_reference(
                    xref=True, xref_nodes=True, xref_elements=False,
                    xref_nodes_with_elements=False, xref_properties=False, xref_masses=False,
                    xref_materials=False, xref_loads=False, xref_constraints=False,
                    xref_aero=False, xref_sets=False, xref_optimization=False,
                )
        except Exception as exc:
            raise _pynastran_error(self.f, exc) from None
        grid_ids = sorted(m.nodes)
        xyz = np.array([m.nodes[i].get_position() for i in grid_ids], float).reshape(-1, 3)
        cd = np.empty((len(grid_ids), 3, 3))
        for k, i in enumerate(grid_ids):
            node = m.nodes[i]
            cd[k] = axes_at(m.coords[node.cd or 0], xyz[k]) if node.cd else np.eye(3)
        # SPOINTs: rows after the grids, at the origin, with one DOF (component 1 here, 0 in
        # Nastran); the other five are constrained in _spcs
        self.spoints = sorted(int(i) for i in getattr(m, "spoints", {}))
        clash = sorted(set(self.spoints) & set(grid_ids))
        if clash:
            raise self.err(f"SPOINT {clash[0]}: the ID of a GRID too")
        ids = np.array(grid_ids + self.spoints, dtype=int)
        xyz = np.vstack((xyz, np.zeros((len(self.spoints), 3))))
        cd = np.concatenate((cd, np.tile(np.eye(3), (len(self.spoints), 1, 1))))
        return ids, xyz, cd

    def scalar_components(self, nid: int, comp, where: str) -> list[int]:
        """Components of (grid or SPOINT, C): an SPOINT has the one component 0 (or blank)."""
        if nid in self.spoints:
            if comp not in (None, "", 0, "0"):
                raise self.err(f"{where}: SPOINT {nid}: expected component 0 or blank, "
                               f"got {comp!r}")
            return [0]
        return _comps(comp, self.f, where)

    # -- materials and properties --------------------------------------------------------------
    def mat1(self, mid, owner: str, field: str):
        mat = self.m.materials.get(mid)
        if mat is None:
            raise self.err(f"{owner}: field {field}: material {mid} not found")
        if mat.type != "MAT1":
            raise self.err(f"{owner}: field {field}: material {mid} is a {mat.type}; "
                           "only MAT1 is supported")
        E = float(mat.e or 0.0)
        G = float(mat.g or 0.0)
        nu = float(mat.nu or 0.0)
        rho = float(mat.rho or 0.0)
        return E, G, nu, rho

    def prop(self, pid, card: str, eid: int, expected: tuple[str, ...]):
        p = self.m.properties.get(pid)
        if p is None:
            raise self.err(f"{card} {eid}: field PID: property {pid} not found")
        if p.type not in expected:
            raise self.err(f"{card} {eid}: field PID: property {pid} is a {p.type}; "
                           f"expected {' or '.join(expected)}")
        return p

    def rows(self, nids, card: str, eid, field="G"):
        out = []
        for k, nid in enumerate(nids):
            if nid not in self.row:
                raise self.err(f"{card} {eid}: field {field}{k + 1}: grid {nid} not found")
            out.append(self.row[nid])
        return out

    # -- mesh ----------------------------------------------------------------------------------
    def mesh(self, spc_id: int | None) -> Mesh:
        ids, xyz, cd = self.grids()
        self.row = {int(g): k for k, g in enumerate(ids)}
        self.ids = ids
        self.xyz = xyz
        mesh = Mesh(grid_ids=ids, xyz=xyz, cd_axes=cd)
        mesh.coupled_mass = self._param("COUPMASS", -1) > 0
        wtmass = self._param_number("WTMASS", 1.0)
        rods, quads, shears, bars, trias = [], [], [], [], []
        self.tapers = {}
        solids: dict[int, list] = {8: [], 6: [], 4: [], 10: [], 20: [], 15: []}
        for eid in sorted(self.m.elements):
            e = self.m.elements[eid]
            if e.type in ("CROD", "CONROD"):
                rods.append(self._rod(e))
            elif e.type in ("CQUAD4", "CTRIA3"):
                (quads if e.type == "CQUAD4" else trias).append(self._quad(e))
            elif e.type == "CSHEAR":
                shears.append(self._shear(e))
            elif e.type in ("CBAR", "CBEAM"):
                bars.append(self._bar(e))
            elif e.type in ("CELAS1", "CELAS2"):
                mesh.celas.append(self._celas(e))
            elif e.type == "CBUSH":
                mesh.bushes.append(self._cbush(e))
            elif e.type == "GENEL":
                mesh.genel.append(self._genel(e))
            elif e.type in SOLID_GRIDS:
                row = self._solid(e)
                solids[len(row["nodes"])].append(row)
        mesh.rods = _stack(RodSet, rods)
        mesh.quads = _stack(QuadSet, quads)
        mesh.trias = _stack(TriaSet, trias)
        mesh.solids = [_stack(SolidSet, rows) for rows in solids.values() if rows]
        self._check_trias(mesh.trias)
        mesh.shears = _stack(ShearSet, shears)
        self._check_surfaces("CQUAD4", mesh.quads.eids, mesh.quads.nodes)
        self._check_surfaces("CSHEAR", mesh.shears.eids, mesh.shears.nodes)
        mesh.bars = _stack(BarSet, bars)
        row = {int(eid): k for k, eid in enumerate(mesh.bars.eids)}
        for eid, taper in self.tapers.items():
            mesh.bars.taper[row[eid]] = replace(taper, nsm=taper.nsm * wtmass,
                                                nsi=taper.nsi * wtmass)
        for k in mechanism_pins(mesh.bars, xyz):
            eid = int(mesh.bars.eids[k])
            card = self.m.elements[eid].type
            raise self.err(f"{card} {eid}: fields PA/PB: the pin flags release components "
                           "without stiffness or leave the element a mechanism")
        for solid in mesh.solids:
            solid.rho *= wtmass
        for sel in (mesh.rods, mesh.quads, mesh.trias, mesh.shears, mesh.bars):
            sel.rho *= wtmass
            sel.nsm *= wtmass
        mesh.bars.polar *= wtmass
        for eid in sorted(self.m.masses):
            c = self.m.masses[eid]
            if c.type == "CONM2":
                mesh.conm2.append(self._conm2(c, wtmass))
            elif c.type in ("CMASS1", "CMASS2"):
                mesh.cmass2.append(self._cmass(c, wtmass))
            elif c.type == "CONM1":
                mesh.conm1.append(self._conm1(c, wtmass))
        for eid in sorted(self.m.rigid_elements):
            c = self.m.rigid_elements[eid]
            if c.type == "RBE2":
                (nrow,) = self.rows([c.gn], "RBE2", eid, "GN")
                dep = self.rows(c.Gmi, "RBE2", eid, "GM")
                comps = _comps(c.cm, self.f, f"RBE2 {eid}: field CM")
                mesh.rbe2.append(RigidRBE2(eid, nrow, comps, dep))
            elif c.type == "RBE3":
                mesh.rbe3.append(self._rbe3(c))
            elif c.type == "RBAR":
                mesh.rbe2.append(self._rbar(c))
            elif c.type == "RBE1":
                mesh.rbe1.append(self._rbe1(c))
        self._spcs(mesh, spc_id)
        self._mpcs(mesh)
        return mesh

    def _param(self, key: str, default):
        p = self.m.params.get(key)
        if p is None or not p.values:
            return default
        return p.values[0]

    def _param_number(self, key: str, default: float) -> float:
        """A PARAM that scales a physical quantity (WTMASS: mass units): a positive finite
        number, else the error names the PARAM."""
        value = self._param(key, default)
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) \
            and math.isfinite(value) and value > 0
        if not ok:
            raise self.err(f"PARAM {key}: expected a positive finite number, got {value!r}")
        return float(value)

    def _rod(self, e):
        eid = e.eid
        if e.type == "CROD":
            p = self.prop(e.pid, "CROD", eid, ("PROD",))
            owner = f"PROD {p.pid}"
            mid, A, J, nsm = p.mid, p.A, p.j, p.nsm
        else:
            owner = f"CONROD {eid}"
            mid, A, J, nsm = e.mid, e.A, e.j, e.nsm
        E, G, _, rho = self.mat1(mid, owner, "MID")
        n1, n2 = self.rows(e.nodes, e.type, eid)
        if not float(A or 0.0) > 0.0:
            raise self.err(f"{owner}: field A: expected a positive area, got {A}")
        if np.linalg.norm(self.xyz[n2] - self.xyz[n1]) <= 1e-12 * (1 + np.abs(self.xyz).max()):
            raise self.err(f"{e.type} {eid}: zero length (grids {e.nodes[0]} and {e.nodes[1]} "
                           "coincide)")
        return dict(eids=eid, nodes=[n1, n2], E=E, G=G, A=float(A), J=float(J or 0.0), rho=rho,
                    nsm=float(nsm or 0.0))

    def _surface(self, e, card: str) -> list[int]:
        nodes = self.rows(e.nodes, card, e.eid)
        if len(set(nodes)) < len(nodes):
            raise self.err(f"{card} {e.eid}: repeated grid in {e.nodes}")
        return nodes

    def _check_surfaces(self, card: str, eids: np.ndarray, nodes: np.ndarray) -> None:
        """Jacobian at the corners (all elements at once): positive at all four iff the quad is
        convex (no interior angle of 180° or more); relative to the mean, so that a sliver is
        also rejected."""
        if not len(eids):
            return
        _, xy = quad_frames(self.xyz[nodes])
        dets = []
        for xi, eta in CORNERS:
            J = np.einsum("ra,nai->nri", shape(xi, eta)[1], xy)
            dets.append(J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0])
        dets = np.stack(dets, axis=1)
        bad = ~np.all(np.isfinite(dets), axis=1) | (
            dets.min(axis=1) <= 1e-8 * np.abs(dets.mean(axis=1)))
        if bad.any():
            k = int(np.argmax(bad))
            grids = [int(g) for g in self.ids[nodes[k]]]
            raise self.err(f"{card} {int(eids[k])}: zero-area, degenerate or concave element "
                           f"(grids {grids})")

    def _quad(self, e):
        """CQUAD4 or CTRIA3 with PSHELL (the same property handling) or PCOMP."""
        eid, card = e.eid, e.type
        p = self.prop(e.pid, card, eid, ("PSHELL", "PCOMP"))
        owner = f"{p.type} {p.pid}"
        zoffs = float(e.zoffset or 0.0)
        if not np.isfinite(zoffs):
            raise self.err(f"{card} {eid}: field ZOFFS: expected a finite offset, got {e.zoffset}")
        if p.type == "PCOMP":
            return dict(self._pcomp_shell(e, p), zoffs=zoffs)
        t = p.t
        if t is None or not float(t) > 0.0:
            raise self.err(f"{owner}: field T: expected a positive thickness, got {t}")
        t = float(t)
        names = ("T1", "T2", "T3", "T4") if card == "CQUAD4" else ("T1", "T2", "T3")
        corner = [x for x in (getattr(e, n) for n in names) if x is not None]
        if corner and (e.tflag or any(abs(x - t) > 1e-12 * t for x in corner)):
            raise self.err(f"{card} {eid}: fields {names[0]}-{names[-1]}: corner thicknesses "
                           "differing from PSHELL T are not supported")
        if p.mid4 not in (None, 0):
            raise self.err(f"{owner}: field MID4: membrane-bending coupling is not supported")
        nodes = self._surface(e, card)
        E = G = nu = rho = 0.0
        if p.mid1 not in (None, 0):
            E, G, nu, rho = self.mat1(p.mid1, owner, "MID1")
        bend_E = bend_nu = shear_G = 0.0
        if p.mid2 not in (None, 0):
            if p.mid2 < 0:
                raise self.err(f"{owner}: field MID2: plane strain (MID2 = -1) is not supported")
            Eb, Gb, nub, rho_b = self.mat1(p.mid2, owner, "MID2")
            bend_E = Eb * float(p.twelveIt3 if p.twelveIt3 is not None else 1.0)
            bend_nu = nub
            shear_G = Gb * 5.0 / 6.0
            if p.mid3 not in (None, 0):
                Gs = self.mat1(p.mid3, owner, "MID3")[1]
                shear_G = Gs * float(p.tst if p.tst is not None else 5.0 / 6.0)
            if p.mid1 in (None, 0):
                rho = rho_b
        return dict(eids=eid, nodes=nodes, t=t, E=E, nu=nu, G=G, rho=rho,
                    nsm=float(p.nsm or 0.0), bend_E=bend_E, bend_nu=bend_nu, shear_G=shear_G,
                    lam_A=np.zeros((3, 3)), lam_D=np.zeros((3, 3)), lam_shear=0.0, zoffs=zoffs)

    def _shear(self, e):
        eid = e.eid
        p = self.prop(e.pid, "CSHEAR", eid, ("PSHEAR",))
        owner = f"PSHEAR {p.pid}"
        if float(p.f1 or 0.0) or float(p.f2 or 0.0):
            raise self.err(f"{owner}: fields F1/F2: extensional effectiveness is not supported "
                           f"(expected 0, got {p.f1}, {p.f2})")
        if not float(p.t or 0.0) > 0.0:
            raise self.err(f"{owner}: field T: expected a positive thickness, got {p.t}")
        _, G, _, rho = self.mat1(p.mid, owner, "MID")
        nodes = self._surface(e, "CSHEAR")
        return dict(eids=eid, nodes=nodes, t=float(p.t), G=G, rho=rho, nsm=float(p.nsm or 0.0))

    def _bar(self, e):
        """CBAR (PBAR, PBARL) or CBEAM (PBEAM, PBEAML, prismatic): the linear beam element, with
        offsets (OFFT), pin flags and the product of inertia I12."""
        eid, card = e.eid, e.type
        expected = ("PBAR", "PBARL") if card == "CBAR" else ("PBEAM", "PBEAML")
        p = self.prop(e.pid, card, eid, expected)
        owner = f"{p.type} {p.pid}"
        sec = section(p, owner)
        E, G, _, rho = self.mat1(sec.mid, owner, "MID")
        n1, n2 = self.rows(e.nodes, card, eid)
        where = f"{card} {eid}"
        offt = self._offt(e, where)
        v = self._orientation(e, offt, n1)
        wa, wb = self._bar_offsets(e, where, offt, v, n1, n2)
        ends = (self.xyz[n1] + wa, self.xyz[n2] + wb)
        L = np.linalg.norm(ends[1] - ends[0])
        if L <= 1e-12 * (1 + np.abs(self.xyz).max()):
            raise self.err(f"{where}: zero length (the ends of grids {e.nodes[0]} and "
                           f"{e.nodes[1]}, offsets included, coincide)")
        axis = (ends[1] - ends[0]) / L
        if np.linalg.norm(np.cross(axis, v)) <= 1e-9 * max(np.linalg.norm(v), 1e-300):
            raise self.err(f"{where}: fields X1-X3/G0: orientation vector is parallel to "
                           "the bar axis or zero")
        if sec.I12 and sec.I1 * sec.I2 <= sec.I12**2:
            raise self.err(f"{owner}: field I12: expected I1 I2 > I12², got I1 = {sec.I1:g}, "
                           f"I2 = {sec.I2:g}, I12 = {sec.I12:g}")
        note = (f"{owner}: {getattr(p, 'beam_type', '')} section without shear "
                "flexibility (its Nastran shear factor is not known here)")
        if p.type in ("PBARL", "PBEAML") and not sec.k1 and note not in self.notes:
            self.notes.append(note)
        polar = rho * (sec.I1 + sec.I2) if card == "CBEAM" else 0.0
        if card == "CBEAM" and (e.sa or e.sb):
            raise self.err(f"{where}: fields SA/SB: warping scalar points are not supported "
                           f"(got {e.sa}, {e.sb})")
        if sec.taper is not None:
            self.tapers[eid] = sec.taper
        pins = [np.isin(np.arange(6), _comps(flag or "", self.f, f"{where}: field {name}"))
                for name, flag in (("PA", e.pa), ("PB", e.pb))]
        return dict(eids=eid, nodes=[n1, n2], v=v, A=sec.A, I1=sec.I1, I2=sec.I2, J=sec.J, E=E,
                    G=G, rho=rho, nsm=sec.nsm, k1=sec.k1, k2=sec.k2, polar=polar, I12=sec.I12,
                    wa=wa, wb=wb, pa=pins[0].astype(float), pb=pins[1].astype(float),
                    na=np.asarray(sec.na, dtype=float))

    #: OFFT codes (MSC QRG CBAR remark): orientation vector in GA's displacement system (G) or
    #: basic (B); each end's offset in its grid's displacement system (G), basic (B) or the
    #: offset system (O: x from GA to GB, y in the plane of x and v)
    OFFT_CODES = ("GGG", "BGG", "GGO", "BGO", "GOG", "BOG", "GOO", "BOO")

    def _offt(self, e, where: str) -> str:
        offt = e.offt if isinstance(e.offt, str) and e.offt.strip() else "GGG"
        if offt.upper() not in self.OFFT_CODES:
            raise self.err(f"{where}: field OFFT: expected one of {', '.join(self.OFFT_CODES)}, "
                           f"got {offt!r}")
        return offt.upper()

    def _grid_axes(self, row: int) -> np.ndarray:
        """Displacement-system axes (columns, basic) of the grid at ``row``."""
        cd = self.m.nodes[int(self.ids[row])].cd
        return axes_at(self.m.coords[cd], self.xyz[row]) if cd else np.eye(3)

    def _orientation(self, e, offt: str, n1: int) -> np.ndarray:
        """Orientation vector v in basic: GA → G0 (grid positions; Nastran moves it to end A),
        or X1-X3 in GA's displacement system (OFFT G..) or basic (B..)."""
        if e.g0 not in (None, 0):
            (g0,) = self.rows([e.g0], e.type, e.eid, "G0")
            return self.xyz[g0] - self.xyz[n1]
        x = np.asarray(e.x, dtype=float)
        return self._grid_axes(n1) @ x if offt[0] == "G" else x

    def _bar_offsets(self, e, where: str, offt: str, v, n1: int, n2: int):
        """WA, WB in basic, per OFFT's second (end A) and third (end B) letter."""
        out = []
        for field, w, code, row in (("WA", e.wa, offt[1], n1), ("WB", e.wb, offt[2], n2)):
            w = np.zeros(3) if w is None else np.asarray(w, dtype=float).reshape(3)
            if not np.all(np.isfinite(w)):
                raise self.err(f"{where}: field {field}: expected finite offsets, got {w}")
            if code == "G":
                w = self._grid_axes(row) @ w
            elif code == "O":
                d = self.xyz[n2] - self.xyz[n1]
                if not np.linalg.norm(d) > 0 or not np.linalg.norm(np.cross(d, v)) > 0:
                    raise self.err(f"{where}: field OFFT: offsets in the offset system need "
                                   "GA ≠ GB and an orientation vector off the GA-GB line")
                _, R = frames_between(self.xyz[n1][None], self.xyz[n2][None], v[None])
                w = R[0].T @ w
            out.append(w)
        return out

    def _conm2(self, c, wtmass: float) -> PointMass:
        (g,) = self.rows([c.nid], "CONM2", c.eid)
        I6 = np.asarray(c.I, dtype=float)
        inertia = np.array([[I6[0], -I6[1], -I6[3]], [-I6[1], I6[2], -I6[4]],
                            [-I6[3], -I6[4], I6[5]]])
        X = np.asarray(c.X, dtype=float)
        cid = c.cid if c.cid is not None else 0
        if cid == -1:
            offset = X - self.xyz[g]
        elif cid == 0:
            offset = X
        else:
            coord = self.m.coords.get(cid)
            if coord is None:
                raise self.err(f"CONM2 {c.eid}: field CID: coordinate system {cid} not found")
            if coord.type[-1] != "R":
                raise self.err(f"CONM2 {c.eid}: field CID: only rectangular systems are "
                               f"supported, got {coord.type} {cid}")
            Rb = axes_at(coord, self.xyz[g])
            offset = Rb @ X
            inertia = Rb @ inertia @ Rb.T
        return PointMass(c.eid, g, float(c.mass) * wtmass, offset, inertia * wtmass)

    def _scalar_pair(self, c) -> tuple[int, int, int, int]:
        """(grid row, component 0..5) twice of a CMASS1/2 or CELAS1/2 (row -1: ground)."""
        card = c.type
        n1, n2 = (list(c.nodes) + [None, None])[:2]
        if n1 in (None, 0):
            n1, n2, c1, c2 = n2, None, c.c2, c.c1
        else:
            c1, c2 = c.c1, c.c2
        (g1,) = self.rows([n1], card, c.eid)
        comp1 = self.scalar_components(n1, c1, f"{card} {c.eid}: field C1")
        g2, comp2 = -1, [0]
        if n2 not in (None, 0):
            (g2,) = self.rows([n2], card, c.eid)
            comp2 = self.scalar_components(n2, c2, f"{card} {c.eid}: field C2")
        if len(comp1) != 1 or len(comp2) != 1:
            raise self.err(f"{card} {c.eid}: fields C1/C2: expected one component each")
        return g1, comp1[0], g2, comp2[0]

    def _cmass(self, c, wtmass: float) -> ScalarMass:
        if c.type == "CMASS1":
            p = self.m.properties_mass.get(c.pid)
            if p is None or p.type != "PMASS":
                raise self.err(f"CMASS1 {c.eid}: field PID: PMASS {c.pid} not found")
            mass = float(p.mass)
        else:
            mass = float(c.mass)
        pair = self._scalar_pair(c)
        if mass < 0 and pair[2] < 0:
            raise self.err(f"{c.type} {c.eid}: field M: expected a number >= 0 for a mass to "
                           f"ground, got {mass:g} (a negative mass couples two DOFs only)")
        return ScalarMass(c.eid, mass * wtmass, *pair)

    def _rbe3(self, c) -> InterpRBE3:
        eid = c.eid
        if c.Gmi:
            raise self.err(f"RBE3 {eid}: fields UM: alternative dependent DOFs are not supported")
        (ref,) = self.rows([c.refgrid], "RBE3", eid, "REFGRID")
        groups = []
        for w, comps, grids in zip(c.weights, c.comps, c.Gijs):
            rows = self.rows(grids, "RBE3", eid, "G")
            cc = _comps(comps, self.f, f"RBE3 {eid}: field C")
            if not float(w) > 0:
                raise self.err(f"RBE3 {eid}: field WT: expected a positive weight, got {w}")
            groups.append((float(w), cc, rows))
        refc = _comps(c.refc, self.f, f"RBE3 {eid}: field REFC")
        return InterpRBE3(eid, ref, refc, groups)

    # -- constraints ---------------------------------------------------------------------------
    def _case_value(self, key: str):
        return _case_value(self.m, key)

    def _spcs(self, mesh: Mesh, spc_id: int | None) -> None:
        for nid, node in self.m.nodes.items():
            for c in _comps(node.ps, self.f, f"GRID {nid}: field PS"):
                dof = (self.row[nid], c)
                mesh.spc.append(dof)
                mesh.spc_source[dof] = f"GRID {nid} PS"
        for nid in self.spoints:
            for c in range(1, 6):
                dof = (self.row[nid], c)
                mesh.spc.append(dof)
                mesh.spc_source[dof] = f"SPOINT {nid} (a scalar point has one DOF)"
        ids = sorted(set(self.m.spcs) | set(self.m.spcadds))
        if spc_id is None:
            spc_id = self._case_value("SPC")
            if spc_id is None and len(ids) > 1:
                raise self.err(f"several SPC sets {ids} and no SPC in the case control; "
                               "select one (spc_id=...)")
            if spc_id is None and ids:
                spc_id = ids[0]
        if spc_id is None:
            return
        if spc_id not in ids:
            if ids:
                raise self.err(f"case control SPC = {spc_id}: no SPC/SPC1/SPCADD with that ID "
                               f"(the deck has {ids})")
            # As Nastran (USER WARNING 2053, undefined SPC set): no SPC applied.
            self.notes.append(f"case control SPC = {spc_id}: the deck has no SPC cards; none "
                              "applied (Nastran: USER WARNING 2053)")
            return
        for sid in self._spc_ids(spc_id, set()):
            for card in self.m.spcs.get(sid, []):
                self._spc_card(card, sid, mesh)

    def _spc_ids(self, sid: int, seen: set) -> list[int]:
        if sid in seen:
            raise self.err(f"SPCADD {sid}: refers to itself")
        seen.add(sid)
        out = [sid] if sid in self.m.spcs else []
        for add in self.m.spcadds.get(sid, []):
            for s in add.sets:
                if s not in self.m.spcs and s not in self.m.spcadds:
                    raise self.err(f"SPCADD {sid}: field S: SPC set {s} not found")
                out += self._spc_ids(s, seen)
        return out

    def _spc_card(self, card, sid: int, mesh: Mesh) -> None:
        if card.type == "SPC1":
            pairs = [(nid, card.components) for nid in card.node_ids]
            enforced = [0.0] * len(pairs)
        elif card.type == "SPC":
            pairs = list(zip(card.node_ids, card.components))
            enforced = list(card.enforced)
        else:
            raise self.err(f"{card.type} {sid}: not supported")
        for (nid, comps), d in zip(pairs, enforced):
            if d not in (None, 0, 0.0):
                raise self.err(f"SPC {sid}: grid {nid}: enforced displacement {d} is not "
                               "supported (use static_solve(prescribed=...))")
            (g,) = self.rows([nid], card.type, sid, "G")
            for c in _comps(comps, self.f, f"{card.type} {sid}: field C"):
                mesh.spc.append((g, c))
                mesh.spc_source[(g, c)] = f"{card.type} {sid}"

    # -- methods -------------------------------------------------------------------------------
    def n_modes(self) -> int | None:
        methods = self.m.methods
        sid = self._case_value("METHOD")
        if sid is None and len(methods) == 1:
            sid = next(iter(methods))
        card = methods.get(sid) if sid is not None else None
        if card is not None:
            self._note_method_fields(card)
        return int(card.nd) if card is not None and card.nd else None

    def _note_method_fields(self, card) -> None:
        """Notes for the fields of the eigenvalue card that change what Nastran computes but
        not what is computed here (the lowest ND modes, mass-normalised)."""
        name = f"{card.type} {card.sid}"
        lo, hi = (getattr(card, "v1", None), getattr(card, "v2", None)) if card.type == "EIGRL" \
            else (getattr(card, "f1", None), getattr(card, "f2", None))
        if lo not in (None, "") or hi not in (None, ""):
            band = f"{'' if lo in (None, '') else lo} .. {'' if hi in (None, '') else hi}"
            self.notes.append(f"{name}: frequency band {band} Hz not applied: the lowest "
                              f"{card.nd or 'requested'} modes are computed (modes --n sets "
                              f"how many)")
        norm = getattr(card, "norm", None)
        if norm not in (None, "", "MASS"):
            self.notes.append(f"{name}: NORM={norm} not applied: shapes are mass-normalised")

    # -- loads ---------------------------------------------------------------------------------
    def loads(self, mesh: Mesh) -> dict[int, np.ndarray]:
        from .loads import LoadBuilder

        return LoadBuilder(self, mesh).all()


def _stack(cls, rows: list[dict[str, Any]]):
    if not rows:
        return cls()
    fields = rows[0].keys()
    out = {}
    for k in fields:
        dtype = int if k in ("eids", "nodes") else float
        out[k] = np.array([r[k] for r in rows], dtype=dtype)
    return cls(**out)
