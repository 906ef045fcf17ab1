"""SOL 145-style flutter analysis of a Nastran deck.

Delegated: reading the deck and its coordinate systems (pyNastran), the modal solution
(:func:`torchrom.fe.read_bdf`), the aerodynamic influence coefficients (PanelAero, through
:mod:`torchrom.aero.dlm`). Written here: the card semantics, reference checks with one-line
errors, and the Nastran-style output (V-g table, flutter summary); :func:`compare_f06` puts an
f06's FLUTTER SUMMARY beside ours.

Cards: FLUTTER (PK, PKNL, KE, K), FLFACT, MKAERO1/2, AERO/AEROS (ACSID, REFC, RHOREF, SYMXZ,
SYMXY), CAERO1/PAERO1 (+AEFACT), SPLINE1/2/4/5 with SET1/AELIST, EIGR/EIGRL, TABDMP1, PARAM
LMODES, RESVEC, VREF, KDAMP; case control FMETHOD, METHOD, RESVEC, SDAMP. Geometry is in the
aero frame (ACSID), flow along +x.
The reflection plane is the deck's SYMXZ (+1 image wing, −1 antisymmetric, 0/blank isolated half
wing) unless ``symxz`` overrides it. Results are in the deck's units (velocities in its length
unit per second over PARAM VREF, frequencies in Hz), labelled from DTI,UNITS or the caller.
The DLM kernel is Nastran's parabolic approximation (:data:`NASTRAN_KERNEL`, Rodden, Giesing &
Kalman 1971/72); ``kernel="quartic"`` the later refinement. Differences from Nastran: GAFs are
computed at each FLFACT Mach number instead of interpolated; modal damping (SDAMP, TABDMP1)
is the PK equation's viscous term (:mod:`torchrom.fe.modal_damping`; refused with K/KE and
KDAMP = −1); residual vectors are the inertia-relief kind (:mod:`torchrom.fe.resvec`);
branches are tracked by mode shape. Rigid-body modes of a free-free deck stay in the basis at
0 Hz, with quasi-steady aerodynamics below the lowest positive k and a real root's damping
g = 2sb/(V ln 2). Crossings are labelled sustained or hump and, with PK, solved between the
FLFACT speeds, humps between two speeds included; the rigid-body roots' crossings are listed
apart (:mod:`torchrom.aero.crossings`); Nastran's summary interpolates linearly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..fe.modal_damping import ModalDamping, modal_damping, subcase_sdamp
from ..fe.rigid import modal_basis_with_rigid
from .crossings import RIGID_FRACTION, pk_crossings, rigid_body_modes, split_rigid
from .dlm import BoxMotion, compute_gaf, exact_k_indices
from .flutter import (
    G_TOLERANCE,
    HUMP,
    SUSTAINED,
    AeroTable,
    FlutterPoint,
    ModalStructure,
    ModeSweep,
    excursions,
    ke_sweep,
    pk_sweep,
)
from .panels import (
    AeroFrame,
    AeroPanels,
    AeroReference,
    read_aero_frame,
    read_aero_reference,
    read_caero1,
    read_model,
)
from .splines import BeamSpline, PlateSpline

FLUTTER_METHODS = ("PK", "PKNL", "KE", "K")
#: the DLM kernel approximation of Nastran's doublet-lattice routines (see the module docstring)
NASTRAN_KERNEL = "parabolic"


@dataclass
class SplineDef:
    """A spline and the (half-model) boxes it drives."""

    eid: int
    kind: str
    grid_ids: np.ndarray
    box_index: np.ndarray
    spline: PlateSpline | BeamSpline


@dataclass
class FlutterCase:
    """One FLUTTER card with its FLFACT lists resolved (densities absolute)."""

    sid: int
    method: str
    density_ratios: np.ndarray
    densities: np.ndarray
    machs: np.ndarray
    values: np.ndarray  # reduced frequencies (K, KE) or velocities (PK, PKNL)
    imeth: str
    nvalue: int | None
    eps: float
    #: the subcase's SDAMP table (viscous modal damping), None without SDAMP
    damping: ModalDamping | None = None


@dataclass
class FlutterDeck:
    """Everything a SOL 145 run needs from the deck, checked, except the modes."""

    path: Path
    panels: AeroPanels  # half model as given by the CAERO1 cards, in the aero frame
    reference: AeroReference
    splines: list[SplineDef]
    cases: list[FlutterCase]
    mkaero: list[tuple[float, float]]
    n_modes: int | None
    frequency_range: tuple[float, float | None]
    vref: float = 1.0
    title: str = ""
    notes: list[str] = field(default_factory=list)
    frame: AeroFrame = field(default_factory=AeroFrame)  # AERO ACSID: flow along its +x
    length_unit: str = "length"
    #: the unit system its cards tell (torchrom.units; None: they do not say)
    units: str | None = None
    symmetry_source: str = "AERO SYMXZ"
    n_eigen: int | None = None  # ND of the EIGR/EIGRL (None: not given)
    lmodes: int | None = None  # PARAM LMODES (None: not given)
    resvec: bool = False  # augment the eigenmodes with residual vectors (RESVEC)
    resvec_source: str = ""

    @property
    def velocity_unit(self) -> str:
        """Label of the output velocities (deck length unit per second, over PARAM VREF)."""
        u = f"{self.length_unit}/s"
        return u if self.vref == 1.0 else f"{u} / VREF ({self.vref:g})"

    @property
    def symmetry(self) -> str:
        """One line: the reflection plane used and where it came from."""
        what = {0: "none (isolated half wing)", 1: "symmetric image (reflection plane xz)",
                -1: "antisymmetric image about xz"}[self.reference.symxz]
        xy = {0: "", -1: "; SYMXY = -1: mirror image about the aero xy plane (ground effect)",
              1: "; SYMXY = +1: antisymmetric image about the aero xy plane"}[
            self.reference.symxy]
        return f"SYMXZ = {self.reference.symxz}: {what}, from {self.symmetry_source}{xy}"

    @property
    def aero_panels(self) -> AeroPanels:
        """The panels the DLM sees: mirrored about xz when AERO SYMXZ = ±1, then about the aero
        xy plane (z -> -z) when SYMXY = ±1."""
        panels = self.panels.mirror() if self.reference.symxz != 0 else self.panels
        return panels.mirror_xy() if self.reference.symxy != 0 else panels

    def box_motion(self, grid_ids, grid_disp: np.ndarray) -> BoxMotion:
        """Modal box motion from grid displacements (n_modes, n_grid, 6) in basic axes."""
        grid_ids = np.asarray(grid_ids)
        nm, ng = grid_disp.shape[:2]
        # Translations and rotations in the aero frame, where the boxes and splines live.
        grid_disp = self.frame.vectors(np.asarray(grid_disp, float).reshape(nm, ng, 2, 3))
        grid_disp = grid_disp.reshape(nm, ng, 6)
        where = {int(g): i for i, g in enumerate(grid_ids)}
        half = self.panels
        h_l = np.zeros((nm, half.n))
        h_c = np.zeros((nm, half.n))
        sl_c = np.zeros((nm, half.n))
        for sp in self.splines:
            missing = [int(g) for g in sp.grid_ids if int(g) not in where]
            if missing:
                raise InputError(
                    f"{self.path}: {sp.kind} {sp.eid}: grid {missing[0]} has no "
                    "displacements in the structural model"
                )
            u = grid_disp[:, [where[int(g)] for g in sp.grid_ids], :].reshape(nm, -1)
            pts_l = half.doublet_points[sp.box_index]
            pts_c = half.control_points[sp.box_index]
            hl, _ = sp.spline.operators(pts_l)
            hc, hx = sp.spline.operators(pts_c)
            # The DLM reads h along each box's normal. A plate spline interpolates that
            # component already; a beam spline (SPLINE2/5) deflects along the z axis of its CID,
            # which may point either way (bah_plane: the wing's CID 0 z is opposite to its boxes'
            # normals, the tail's CID 3 z along them): project it on the normals.
            along = (half.normals[sp.box_index] @ sp.spline.axes[2]
                     if isinstance(sp.spline, BeamSpline) else 1.0)
            h_l[:, sp.box_index] = (u @ hl.T) * along
            h_c[:, sp.box_index] = (u @ hc.T) * along
            sl_c[:, sp.box_index] = (u @ hx.T) * along
        full = self.aero_panels
        anti = self.reference.symxz < 0
        xy = -1 if self.reference.symxy < 0 else 1  # SYMXY = -1: h' = -h on the xy images
        return BoxMotion(full.box_motion(h_l, anti, xy), full.box_motion(h_c, anti, xy),
                         full.box_motion(sl_c, anti, xy))


# -- reading -------------------------------------------------------------------------------------
def _case_ids(model, name: str) -> list[int]:
    cc = model.case_control_deck
    out = []
    if cc is None:
        return out
    for sub in cc.subcases.values():
        if sub.has_parameter(name)[0]:
            value = sub.get_parameter(name)[0]
            if int(value) not in out:
                out.append(int(value))
    return out


def _flfact(model, sid: int, where: str, what: str) -> np.ndarray:
    fl = model.flfacts.get(sid)
    if fl is None:
        raise InputError(f"{where}: FLFACT {sid} ({what}) not found")
    vals = np.asarray(fl.factors, dtype=float).reshape(-1)
    if len(vals) == 0 or not np.all(np.isfinite(vals)):
        raise InputError(f"{where}: FLFACT {sid} ({what}): expected a list of numbers")
    return vals


def _one_grid_per_station(where: str, setg: int, grid_ids, xyz, axis) -> None:
    """InputError (which grids, what to do) when two grids of a beam spline lie at one station
    along its axis: torchrom's beam spline interpolates one deflection per station (a torsion
    from the grids' rotations), not a pair of chordwise-offset grids as Nastran's rigid arms do
    (pyNastran's ha146c: front- and rear-spar grids of SET1 14 at each y)."""
    s = np.asarray(xyz, float) @ np.asarray(axis, float)
    order = np.argsort(s, kind="stable")
    gap = np.diff(s[order]) <= 1e-12 * max(1.0, float(np.ptp(s)))
    if len(s) >= 2 and gap.any():
        i = int(np.flatnonzero(gap)[0])
        a, b = (int(grid_ids[order[i]]), int(grid_ids[order[i + 1]]))
        raise InputError(f"{where}: SET1 {setg}: grids {a} and {b} lie at one station along the "
                         f"spline axis; this beam spline takes one grid per station (no "
                         f"chordwise-offset pairs): connect these grids with a SPLINE1 (surface "
                         f"spline) instead, or keep one grid per station in SET1 {setg}")
    if len(s) < 2:
        raise InputError(f"{where}: SET1 {setg}: a beam spline needs at least two grids")


def _spline_defs(model, path: Path, panels: AeroPanels, frame: AeroFrame) -> list[SplineDef]:
    """Splines in the aero frame (grid positions and SPLINE2 axes transformed to it)."""
    defs = []
    covered = np.zeros(panels.n, dtype=int)
    for eid in sorted(model.splines):
        sp = model.splines[eid]
        where = f"{path}: {sp.type} {eid}"
        if sp.type not in ("SPLINE1", "SPLINE2", "SPLINE4", "SPLINE5"):
            raise InputError(f"{where}: only SPLINE1, SPLINE2, SPLINE4 and SPLINE5 are supported")
        if sp.caero not in model.caeros:
            raise InputError(f"{where}: CAERO1 {sp.caero} not found")
        in_caero = panels.caero_ids == sp.caero
        if sp.type in ("SPLINE4", "SPLINE5"):  # boxes listed on an AELIST
            aelist = model.aelists.get(sp.aelist)
            if aelist is None:
                raise InputError(f"{where}: field AELIST: AELIST {sp.aelist} not found")
            ids = np.asarray(aelist.elements, dtype=int)
            box_index = np.flatnonzero(in_caero & np.isin(panels.box_ids, ids))
            if len(box_index) != len(np.unique(ids)):
                missing = sorted(set(ids.tolist()) - set(panels.box_ids[box_index].tolist()))
                raise InputError(f"{where}: AELIST {sp.aelist}: box {missing[0]} not in "
                                 f"CAERO1 {sp.caero}")
            if sp.type == "SPLINE4" and str(sp.method or "IPS").upper() != "IPS":
                raise InputError(f"{where}: field METH: only IPS (infinite plate) is supported, "
                                 f"got {sp.method}")
        else:
            b1, b2 = sp.box1, sp.box2
            box_index = np.flatnonzero(in_caero & (panels.box_ids >= b1) & (panels.box_ids <= b2))
            if b2 < b1 or len(box_index) != b2 - b1 + 1:
                raise InputError(f"{where}: boxes {b1}..{b2}: not all in CAERO1 {sp.caero}")
        setg = model.sets.get(sp.setg)
        if setg is None or setg.type != "SET1":
            raise InputError(f"{where}: SET1 {sp.setg} not found")
        grid_ids = np.asarray(setg.ids, dtype=int)
        for gid in grid_ids:
            if gid not in model.nodes:
                raise InputError(f"{path}: SET1 {sp.setg}: grid {gid} not found")
        xyz = frame.points(np.array([model.nodes[g].get_position() for g in grid_ids]))
        if sp.type in ("SPLINE1", "SPLINE4"):
            normal = panels.normals[box_index].mean(axis=0)
            spline = PlateSpline(xyz, normal=normal, dz=float(sp.dz or 0.0))
        else:  # SPLINE2, SPLINE5: beam spline along the y axis of CID
            dthx, dthy = (sp.dthx, sp.dthy) if sp.type == "SPLINE2" else (sp.thx, sp.thy)
            cid = sp.cid or 0
            if cid and cid not in model.coords:
                raise InputError(f"{where}: coordinate system {cid} not found")
            coord = model.coords[cid]
            axes = np.asarray(coord.beta(), dtype=float)
            _one_grid_per_station(where, sp.setg, grid_ids, xyz, frame.vectors(axes)[1])
            spline = BeamSpline(
                xyz,
                origin=frame.points(np.asarray(coord.origin, float)),
                axes=frame.vectors(axes),
                attach_slope=(dthx is None or dthx >= 0.0),
                attach_torsion=(dthy is None or dthy >= 0.0),
            )
        covered[box_index] += 1
        defs.append(SplineDef(eid, sp.type, grid_ids, box_index, spline))
    if np.any(covered > 1):
        raise InputError(f"{path}: aero box {panels.box_ids[np.argmax(covered)]} is in two splines")
    return defs


def load_deck(path, require_flutter: bool = True, *, symxz: int | None = None,
              length_unit: str | None = None, resvec: bool | None = None,
              includes=()) -> FlutterDeck:
    """Read and check the aeroelastic part of a deck (everything except the modal solution).

    ``require_flutter=False`` accepts a deck with aerodynamic boxes and splines but no FLUTTER
    cards (to build GAFs only). ``resvec`` overrides the deck's RESVEC (residual vectors,
    :func:`_with_residual_vectors`). ``symxz`` (-1, 0, +1) overrides the deck's AERO/AEROS SYMXZ;
    ``length_unit`` labels the output when the deck has no DTI,UNITS card; ``includes``: files of
    cards read as if INCLUDEd (``--panels``: :func:`torchrom.fe.bdf_read.with_includes`).
    """
    path = Path(path)
    model = read_model(path, includes)
    if not model.caeros:
        raise InputError(f"{path}: CAERO1: no aerodynamic panels in the deck: write them from "
                         f"its structure with torchrom panels {path.name} --out panels.bdf, "
                         f"then give --panels panels.bdf (or INCLUDE it in the deck)")
    frame = read_aero_frame(model, str(path))
    panels = read_caero1(model, str(path), frame)
    ref = read_aero_reference(model, str(path))
    card = "AERO" if model.aero is not None else "AEROS"
    source = f"the deck's {card} card" + (" (field blank)" if ref.symxz == 0 else "")
    if symxz is not None:
        if symxz not in (-1, 0, 1):
            raise InputError(f"--symxz: expected -1, 0 or 1, got {symxz}")
        if symxz != ref.symxz:
            source = f"the command line (the deck's {card} SYMXZ is {ref.symxz})"
        ref = replace(ref, symxz=int(symxz))
    if ref.symxy != 0:
        in_plane = np.all(np.abs(panels.corners[:, :, 2]) <= 1e-9 * np.abs(panels.corners).max(),
                          axis=1)
        if np.any(in_plane):
            raise InputError(
                f"{path}: {card}: SYMXY = {ref.symxy}: CAERO1 box {panels.box_ids[in_plane][0]} "
                "lies in the xy plane of the aero system, where it coincides with its image: "
                "expected the boxes off that plane (z != 0 in ACSID)")
    units = model.dti.get("UNITS")
    deck_length = (units.fields.get("length") if units is not None else None) or None
    system, conflict = _deck_system(model, path)
    splines = _spline_defs(model, path, panels, frame)
    if not splines:
        raise InputError(f"{path}: SPLINE1/SPLINE2: no spline connects the structure to the boxes")
    notes = [] if conflict is None else [f"{conflict}: the results are in the deck's own "
                                         f"units, labelled without a unit system"]
    n_unsplined = panels.n - len(np.unique(np.concatenate([s.box_index for s in splines])))
    if n_unsplined:
        notes.append(f"{n_unsplined} aerodynamic boxes are not splined (they do not move)")

    mkaero = []
    for mk in model.mkaeros:
        if mk.type == "MKAERO1":
            mkaero += [(float(m), float(k)) for m in mk.machs for k in mk.reduced_freqs]
        else:
            mkaero += [(float(m), float(k)) for m, k in zip(mk.machs, mk.reduced_freqs)]

    fmethods = _case_ids(model, "FMETHOD") or sorted(model.flutters)
    sdamp = subcase_sdamp(model)
    if not fmethods and require_flutter:
        raise InputError(f"{path}: FLUTTER: no flutter card (and no FMETHOD in case control)")
    cases = []
    for sid in fmethods:
        fl = model.flutters.get(sid)
        if fl is None:
            raise InputError(f"{path}: case control FMETHOD = {sid}: FLUTTER {sid} not found")
        where = f"{path}: FLUTTER {sid}"
        method = str(fl.method).upper()
        if method not in FLUTTER_METHODS:
            raise InputError(f"{where}: METHOD: expected one of {FLUTTER_METHODS}, got {method}")
        damping = modal_damping(model, where, sdamp[sid], method) if sid in sdamp else None
        dens_id = fl.density if isinstance(fl.density, int) else fl.density.sid
        mach_id = fl.mach if isinstance(fl.mach, int) else fl.mach.sid
        rv = fl.reduced_freq_velocity
        rv_id = rv if isinstance(rv, int) else rv.sid
        ratios = _flfact(model, dens_id, where, "density ratios")
        machs = _flfact(model, mach_id, where, "Mach numbers")
        what = "velocities" if method.startswith("PK") else "reduced frequencies"
        values = _flfact(model, rv_id, where, what)
        if method in ("K", "KE") and np.any(values <= 0):
            raise InputError(f"{where}: FLFACT {rv_id}: reduced frequencies must be positive")
        if method.startswith("PK") and not mkaero:
            raise InputError(f"{where}: PK needs MKAERO1/MKAERO2 reduced frequencies; none found")
        if np.any(machs >= 1.0):
            raise InputError(
                f"{where}: FLFACT {mach_id}: the doublet-lattice method needs Mach < 1"
            )
        cases.append(
            FlutterCase(
                sid,
                method,
                ratios,
                ratios * ref.rho_ref,
                machs,
                values,
                str(fl.imethod or "L").upper(),
                fl.nvalue,
                float(fl.epsilon or 1e-3),
                damping,
            )
        )

    n_modes, frange, nd, lmodes = (_mode_count(model, path) if require_flutter
                                   else (None, (0.0, None), None, None))
    use_resvec, resvec_source = _resvec(model, path)
    if resvec is not None:
        use_resvec, resvec_source = bool(resvec), "the command line"
    vref = _param_number(model, path, "VREF", 1.0, lambda x: x > 0, "a positive number")
    title = ""
    cc = model.case_control_deck
    if cc is not None and cc.subcases[0].has_parameter("TITLE")[0]:
        title = str(cc.subcases[0].get_parameter("TITLE")[0]).strip()
    return FlutterDeck(
        path, panels, ref, splines, cases, sorted(set(mkaero)), n_modes, frange, vref, title, notes,
        frame,
        length_unit=str(deck_length or length_unit
                        or (system.length if system else "length")).lower(),
        units=system.name if system else None,
        symmetry_source=source,
        n_eigen=nd,
        lmodes=lmodes,
        resvec=use_resvec,
        resvec_source=resvec_source,
    )


def _deck_system(model, path: Path):
    """(system, conflict): the unit system the deck's cards tell
    (:func:`torchrom.units.infer_units`), None when they do not or disagree (the labels then
    say "length", as a deck without DTI,UNITS); where they disagree (two cards, or FLFACT
    velocities against a card) the disagreement, without the advice to declare --units (the
    deck's flutter takes none)."""
    from ..fe.deck_units import deck_units
    from ..units import recorded_units

    record = deck_units(model, path.name)
    if record is None:
        return None, None
    conflict = record.get("unit_conflict")
    return recorded_units(record), None if conflict is None else conflict.split("; ")[0]


def _param_number(model, path: Path, key: str, default, ok, expected: str) -> float:
    """PARAM ``key`` of the deck as a finite number for which ``ok`` holds (else an InputError
    naming it); ``default`` when the deck has none."""
    p = model.params.get(key)
    value = p.values[0] if p is not None and p.values else default
    good = (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and ok(value))
    if not good:
        raise InputError(f"{path.name}: PARAM {key}: expected {expected}, got {value!r}")
    return float(value)


def _mode_count(model, path: Path):
    """(modes used without residual vectors, EIGR/EIGRL frequency range, ND, LMODES)."""
    lmodes = int(_param_number(model, path, "LMODES", 0,
                               lambda x: x >= 0 and float(x).is_integer(), "an integer >= 0"))
    methods = _case_ids(model, "METHOD")
    nd, frange = None, (0.0, None)
    if methods:
        sid = methods[0]
        card = model.methods.get(sid)
        if card is None:
            raise InputError(f"{path}: case control METHOD = {sid}: EIGR/EIGRL {sid} not found")
        if card.type == "EIGRL":
            nd = card.nd
            frange = (float(card.v1 or 0.0), float(card.v2) if card.v2 else None)
        else:
            nd = card.nd
            # Tridiagonal methods (GIV, HOU, ...) return ND roots when ND is given.
            if not nd:
                frange = (float(card.f1 or 0.0), float(card.f2) if card.f2 else None)
    nd_card = int(nd) if nd else None
    if lmodes > 0:
        nd = lmodes if nd is None else min(lmodes, nd) if nd else lmodes
    if nd is None and frange[1] is None:
        raise InputError(f"{path}: modes: give PARAM LMODES or an EIGR/EIGRL (ND or F2) via METHOD")
    return (int(nd) if nd else None), frange, nd_card, (lmodes or None)


def _resvec(model, path: Path) -> tuple[bool, str]:
    """Whether residual vectors augment the modes, and where that came from: case control
    RESVEC, else PARAM RESVEC, else Nastran's SOL 145 default (yes: the f06s of pt145 and
    bah_plane augment their modes without asking)."""
    cc = model.case_control_deck
    if cc is not None:
        for sub in cc.subcases.values():
            if sub.has_parameter("RESVEC")[0]:
                value = str(sub.get_parameter("RESVEC")[0]).upper()
                return value not in ("NO", "NOINRL"), f"case control RESVEC = {value}"
    if "RESVEC" in model.params:
        value = str(model.params["RESVEC"].values[0]).upper()
        if value not in ("YES", "NO"):
            raise InputError(f"{path}: PARAM RESVEC: expected YES or NO, got {value}")
        return value == "YES", f"PARAM RESVEC {value}"
    return True, "Nastran's default"


# -- running ---------------------------------------------------------------------------------------
@dataclass
class CaseResult:
    """Flutter results of one FLUTTER case at one Mach number and density."""

    case: FlutterCase
    mach: float
    density_ratio: float
    density: float
    sweep: ModeSweep
    points: list[FlutterPoint]  # flutter crossings, labelled sustained or hump
    #: crossings of the rigid-body modes' roots (:mod:`torchrom.aero.crossings`): not flutter
    rigid_points: list[FlutterPoint] = field(default_factory=list)
    #: crossings of real roots (zero frequency): divergence, not flutter
    divergence_points: list[FlutterPoint] = field(default_factory=list)
    #: 0-based branches whose |g| stays within the damping tolerance at every speed: not
    #: loaded by the aerodynamics (no flutter row, whatever the sign of their noise)
    not_loaded: list[int] = field(default_factory=list)


@dataclass
class DeckResult:
    deck: FlutterDeck
    frequencies_hz: np.ndarray
    results: list[CaseResult]
    notes: list[str]
    #: the damping tolerance of the crossings (:data:`torchrom.aero.flutter.G_TOLERANCE`)
    g_tolerance: float = G_TOLERANCE

    def unstable_at_start(self) -> list[tuple[CaseResult, int]]:
        """(case, branch) of the elastic roots already unstable (g above the tolerance) at the
        first speed of a sweep: no crossing in the range (bah_plane's FLUTTER 501: the 2.45 Hz
        root from 4,774 on, as the f06's POINT 4), but not stable either."""
        rigid = rigid_body_modes(self.frequencies_hz)
        return [(r, j) for r in self.results for j in range(r.sweep.damping.shape[1])
                if not rigid[j] and r.sweep.damping[0, j] > self.g_tolerance]

    def _density_unit(self) -> str:
        """The label of the densities: the unit system's when the deck's cards tell it (and
        the length label is that system's), else mass/length^3 in the deck's units."""
        from ..units import unit_system

        system = unit_system(self.deck.units) if self.deck.units else None
        if system is not None and system.length == self.deck.length_unit:
            return system.density
        return f"mass/{self.deck.length_unit}^3 (deck units)"

    def as_dict(self) -> dict:
        """Flat records for --json (velocities in deck units / VREF, frequencies in Hz)."""
        vref = self.deck.vref

        def scaled(rec: dict) -> dict:
            out = {**rec, "velocity": rec["velocity"] / vref}
            if rec.get("stable_velocity") is not None:
                out["stable_velocity"] = rec["stable_velocity"] / vref
            return out

        def points(attr: str) -> list[dict]:
            return [{"flutter_id": r.case.sid, "method": r.case.method, "mach": r.mach,
                     "density_ratio": r.density_ratio, **scaled(p.as_dict())}
                    for r in self.results for p in getattr(r, attr)]

        return {
            "deck": str(self.deck.path),
            "title": self.deck.title,
            "symxz": self.deck.reference.symxz,
            "symxy": self.deck.reference.symxy,
            "symmetry": self.deck.symmetry,
            "units": {"system": self.deck.units, "velocity": self.deck.velocity_unit,
                      "frequency": "Hz", "density": self._density_unit()},
            "modal_frequencies_hz": self.frequencies_hz.tolist(),
            "g_tolerance": self.g_tolerance,
            "flutter": points("points"),
            "divergence": points("divergence_points"),
            "rigid_body_roots": points("rigid_points"),
            "not_loaded": [
                {"flutter_id": r.case.sid, "method": r.case.method, "mach": r.mach,
                 "density_ratio": r.density_ratio, "mode": j + 1,
                 "frequency_hz": float(self.frequencies_hz[j]),
                 "max_abs_damping_g": float(np.max(np.abs(r.sweep.damping[:, j])))}
                for r in self.results for j in r.not_loaded],
            "unstable_at_first_speed": [
                {"flutter_id": r.case.sid, "method": r.case.method, "mach": r.mach,
                 "density_ratio": r.density_ratio, "mode": j + 1,
                 "velocity": float(r.sweep.velocity_by_mode[0, j]) / vref,
                 "damping_g": float(r.sweep.damping[0, j]),
                 "frequency_hz": float(r.sweep.frequency_hz[0, j])}
                for r, j in self.unstable_at_start()],
            "vg": [
                {
                    "flutter_id": r.case.sid,
                    "method": r.case.method,
                    "mach": r.mach,
                    "density_ratio": r.density_ratio,
                    **scaled(row),
                }
                for r in self.results
                for row in r.sweep.table()
            ],
            "notes": self.notes,
        }


def _modes(deck: FlutterDeck, fe, notes: list[str]):
    """The deck's modal basis (ND/LMODES or the EIGR/EIGRL frequency range), rigid-body modes
    included as Nastran does (a free-free aircraft keeps its rigid-body modes)."""
    n_dof = fe.n_dof
    n = deck.n_modes
    if n is None:  # frequency range only
        f, shapes = modal_basis_with_rigid(fe, fe.modes(min(n_dof, 100)), None, notes)
        lo, hi = deck.frequency_range
        keep = np.flatnonzero((f >= lo) & (f <= hi))
        return f[keep], shapes[:, keep]
    if deck.resvec and deck.n_eigen and (deck.lmodes is None or deck.lmodes > deck.n_eigen):
        return _with_residual_vectors(deck, fe, notes)
    f, shapes = modal_basis_with_rigid(fe, fe.modes(min(n, n_dof)), n, notes)
    lo = deck.frequency_range[0]
    keep = np.flatnonzero(f >= lo) if lo > 0 else np.arange(len(f))
    return f[keep], shapes[:, keep]


def _with_residual_vectors(deck: FlutterDeck, fe, notes: list[str]):
    """Nastran's augmented basis: the ND eigenmodes plus the residual vectors
    (:func:`torchrom.fe.resvec.inertia_residual_vectors`), of which the lowest LMODES - ND (all
    without LMODES) are used. Residual vectors lie above every computed eigenmode (they are
    orthogonal to them), so with LMODES <= ND none would be used and none is computed."""
    from ..fe.resvec import inertia_residual_vectors

    n_eig = deck.n_eigen
    f, shapes = modal_basis_with_rigid(fe, fe.modes(min(n_eig, fe.n_dof)), n_eig, notes)
    fr, vectors = inertia_residual_vectors(fe, shapes, shapes[:, f == 0.0])
    total = len(f) + len(fr) if deck.lmodes is None else deck.lmodes
    used = max(0, min(total - len(f), len(fr)))
    notes.append(f"residual vectors (RESVEC, inertia relief; from {deck.resvec_source}): "
                 f"{len(fr)} computed (" + ", ".join(f"{x:.4g}" for x in fr)
                 + f" Hz), {used} used")
    return (np.concatenate([f, fr[:used]]),
            np.concatenate([shapes, vectors[:, :used]], axis=1))


def run_deck(deck_or_path, fe=None, kernel: str = NASTRAN_KERNEL, log=print,
             k_exact: int | None = None, g_tolerance: float = G_TOLERANCE) -> DeckResult:
    """Run every FLUTTER case of a deck (modes from ``fe`` or :func:`torchrom.fe.read_bdf`).

    ``k_exact``: solve the DLM at no more than this many of each case's reduced frequencies and
    interpolate the GAFs at the others (:func:`torchrom.aero.dlm.compute_gaf`).
    ``g_tolerance``: a crossing counts only where the damping changes sign by more than it
    (:mod:`torchrom.aero.crossings`)."""
    deck = deck_or_path if isinstance(deck_or_path, FlutterDeck) else load_deck(deck_or_path)
    if fe is None:
        from ..fe import read_bdf

        fe = read_bdf(deck.path)
    mode_notes: list[str] = []
    freqs, shapes = _modes(deck, fe, mode_notes)
    if len(freqs) == 0:
        raise InputError(f"{deck.path}: modes: none in the requested range")
    log(f"{deck.path.name}: {len(freqs)} modes: " + ", ".join(f"{f:.4g}" for f in freqs) + " Hz")
    disp = np.asarray(fe.expand(shapes)).reshape(shapes.shape[1], -1, 6)  # (n_modes, n_grid, 6)
    motion = deck.box_motion(fe.grid_ids, disp)
    omega = 2 * np.pi * freqs
    structure = ModalStructure(np.eye(len(freqs)), np.diag(omega**2))
    b = deck.reference.semichord
    panels = deck.aero_panels
    results, notes = [], list(deck.notes) + list(getattr(fe, "notes", [])) + mode_notes
    def table_at(mach, k_list, case):
        solved = len(exact_k_indices(np.asarray(k_list, float), k_exact))
        log(
            f"FLUTTER {case.sid} ({case.method}): DLM at Mach {mach:g}, {len(k_list)} reduced "
            f"frequencies, {panels.n} boxes"
            + (f" (solved at {solved}, interpolated at the others)" if solved < len(k_list)
               else "")
        )
        gaf = compute_gaf(panels, motion, mach, k_list, b, kernel, k_exact=k_exact)
        return AeroTable.from_gaf(gaf, interpolation="linear" if case.imeth == "L" else "cubic")

    n_rigid = int(np.sum(freqs == 0.0))
    rigid = rigid_body_modes(freqs)  # their roots' crossings are reported apart

    def pk_k_list(mach):
        near = min({m for m, _ in deck.mkaero}, key=lambda m: abs(m - mach))
        k_list = {k for m, k in deck.mkaero if m == near}
        # rigid-body roots sit at k -> 0: the steady GAF (k = 0) is added so that their
        # aerodynamic stiffness is the steady one (none for a rigid plunge) rather than that of
        # the lowest MKAERO k (a small spurious stiffness: a plunge root of 5e-3 rad/s at
        # V = 30 in bah_plane, real +-9e-4 in its f06)
        return sorted(k_list | ({0.0} if n_rigid else set()))

    undamped = structure
    for case in deck.cases:
        structure = undamped
        if case.damping is not None:
            structure = ModalStructure(undamped.M, undamped.K,
                                       C0=np.diag(case.damping.viscous(freqs)))
            notes.append(f"FLUTTER {case.sid}: {case.damping.describe()}")
        if case.method == "PKNL":
            # PKNL: the i-th density, Mach number and velocity form one flight condition (no
            # loops over the lists, MSC QRG FLUTTER); one p-k path per Mach number.
            n = len(case.values)
            if len(case.densities) not in (1, n) or len(case.machs) not in (1, n):
                raise InputError(
                    f"{deck.path}: FLUTTER {case.sid}: PKNL needs density, Mach and velocity "
                    f"lists of the same length (got {len(case.densities)}, {len(case.machs)}, {n})"
                )
            rho_all = np.broadcast_to(case.densities, (n,))
            ratio_all = np.broadcast_to(case.density_ratios, (n,))
            mach_all = np.broadcast_to(case.machs, (n,))
            for mach in dict.fromkeys(mach_all.tolist()):
                sel = mach_all == mach
                aero = table_at(mach, pk_k_list(mach), case)
                sweep = pk_sweep(structure, aero, np.abs(case.values[sel]), rho_all[sel],
                                 mach=mach, eps=min(case.eps, 1e-4),
                                 real_root_damping="nastran")
                # linear in the path, as Nastran's summary
                found = split_rigid(sweep.crossings(g_tolerance), rigid, sweep, g_tolerance)
                for p in found.flutter + found.rigid_body + found.divergence:
                    p.mach = float(mach)
                notes += sweep.notes
                ratio = ratio_all[sel]
                results.append(CaseResult(case, float(mach), float(ratio[0]) if
                                          np.ptp(ratio) == 0 else float("nan"),
                                          float(rho_all[sel][0]), sweep, found.flutter,
                                          found.rigid_body, found.divergence,
                                          found.not_loaded))
            continue
        for mach in case.machs:
            if case.method.startswith("PK"):
                k_list = pk_k_list(mach)
            else:
                k_list = sorted(set(case.values.tolist()))
            aero = table_at(mach, k_list, case)
            for ratio, rho in zip(case.density_ratios, case.densities):
                if case.method.startswith("PK"):
                    v = np.sort(np.abs(case.values))
                    sweep = pk_sweep(structure, aero, v, rho, mach=mach,
                                     eps=min(case.eps, 1e-4), real_root_damping="nastran")
                    found = pk_crossings(structure, aero, sweep, rigid, tol=g_tolerance)
                else:
                    sweep = ke_sweep(structure, aero, case.values, rho)
                    found = split_rigid(sweep.crossings(g_tolerance), rigid, sweep,
                                        g_tolerance)
                for p in found.flutter + found.rigid_body + found.divergence:
                    p.mach = float(mach)
                notes += sweep.notes
                results.append(CaseResult(case, float(mach), float(ratio), float(rho), sweep,
                                          found.flutter, found.rigid_body, found.divergence,
                                          found.not_loaded))
    return DeckResult(deck, freqs, results, notes, float(g_tolerance))


def _case_mode(res: DeckResult, r: CaseResult, j: int) -> str:
    """"FLUTTER 1 (PK) Mach 0 density ratio 1: mode 3 (13.74 Hz in vacuo)"."""
    return (f"FLUTTER {r.case.sid} ({r.case.method}) Mach {r.mach:g} density ratio "
            f"{r.density_ratio:g}: mode {j + 1} ({res.frequencies_hz[j]:.4g} Hz in vacuo)")


def format_deck_result(res: DeckResult) -> str:
    """Nastran-like FLUTTER SUMMARY tables and the flutter points, in the deck's units."""
    vref = res.deck.vref
    vu = res.deck.velocity_unit
    lines = []
    if res.deck.title:
        lines.append(res.deck.title)
    lines.append(f"symmetry: {res.deck.symmetry}")
    lines.append(f"units: velocity {vu} (the deck's), frequency Hz")
    lines.append("modal frequencies (Hz): " + "  ".join(f"{f:.5g}" for f in res.frequencies_hz))
    for r in res.results:
        sw = r.sweep
        nv = r.case.nvalue or sw.damping.shape[1]
        vel = sw.velocity_by_mode
        for j in range(min(nv, sw.damping.shape[1])):
            lines.append("")
            lines.append(
                f"FLUTTER SUMMARY  FLUTTER {r.case.sid}  POINT = {j + 1}  MACH NUMBER = "
                f"{r.mach:.4f}  DENSITY RATIO = {r.density_ratio:.4e}  METHOD = {r.case.method}"
            )
            lines.append(
                f"{'KFREQ':>10} {'1./KFREQ':>12} {'VELOCITY':>13} {'DAMPING':>12} "
                f"{'FREQUENCY':>12} {'REAL EIGVAL':>13} {'IMAG EIGVAL':>13}"
            )
            for i in np.argsort(vel[:, j], kind="stable"):
                s = sw.eigenvalues[i, j]
                # a real p-k root has k = 0 (iterated at the floor K_FLOOR), printed as Nastran
                k = 0.0 if sw.method == "PK" and s.imag == 0 else sw.k[i, j]
                v = vel[i, j] / vref
                lines.append(
                    f"{k:10.4f} {1 / k if k > 0 else np.inf:12.4f} {v:13.5e} "
                    f"{sw.damping[i, j]:12.4e} {sw.frequency_hz[i, j]:12.5e} "
                    f"{s.real:13.5e} {s.imag:13.5e}"
                )
    lines.append("")
    lines.append("flutter crossings (sustained: unstable to the last speed; hump: stable again "
                 "further on; speeds solved between the sweep's speeds unless marked linear):")
    flutter = [(r, p) for r in res.results for p in r.points]
    for r, p in flutter:
        lines.append("  " + _crossing_line(res, r, p))
    if not flutter:
        lines.append("  none in the requested range")
    lines.append(f"  (a crossing counts where the damping g changes sign by more than "
                 f"{res.g_tolerance:g}: --g-tolerance)")
    for r in res.results:
        for j in r.not_loaded:
            lines.append(
                f"  {_case_mode(res, r, j)} is not loaded by the aerodynamics: |g| <= "
                f"{np.max(np.abs(r.sweep.damping[:, j])):.2g} at every speed, within "
                f"{res.g_tolerance:g}: no flutter row")
    divergence = [(r, p) for r in res.results for p in r.divergence_points]
    if divergence:
        lines.append("divergence (a real root, zero frequency, crosses zero: static, not "
                     "flutter):")
        for r, p in divergence:
            lines.append("  " + _crossing_line(res, r, p))
    for r, j in res.unstable_at_start():
        lines.append(
            f"  {_case_mode(res, r, j)} is unstable from the first speed "
            f"({r.sweep.velocity_by_mode[0, j] / res.deck.vref:.5g} {res.deck.velocity_unit}: "
            f"g = {r.sweep.damping[0, j]:+.4g} at "
            f"{r.sweep.frequency_hz[0, j]:.5g} Hz): no crossing in the range")
    rigid = [(r, p) for r in res.results for p in r.rigid_points]
    if rigid:
        lines.append(f"rigid-body roots (modes below {RIGID_FRACTION:g} of the lowest elastic "
                     "frequency; their damping crossing zero is not flutter):")
        for r, p in rigid:
            lines.append("  " + _crossing_line(res, r, p))
    for n in res.notes:
        lines.append(f"note: {n}")
    return "\n".join(lines)


def _crossing_line(res: DeckResult, r: CaseResult, p: FlutterPoint) -> str:
    """One crossing: case, mode, kind, onset speed and frequency, re-stabilisation, units."""
    vref, vu = res.deck.vref, res.deck.velocity_unit
    last = float(np.max(r.sweep.velocity_by_mode[:, p.mode])) / vref
    what = ("damping crosses zero at" if p.rigid_body else
            "divergence speed" if p.divergence else "flutter speed")
    head = _case_mode(res, r, p.mode)
    if p.divergence and not p.rigid_body:  # a real root: no frequency, no k
        text = f"{head}: {what} {p.velocity / vref:.5g} {vu} (a real root crosses zero); "
    else:
        text = (f"{head}, {p.kind}: {what} {p.velocity / vref:.5g} {vu}, frequency "
                f"{p.frequency_hz:.5g} Hz, k = {p.k:.4f}; ")
    if p.kind == HUMP:
        text += (f"stable again at {p.stable_velocity / vref:.5g} {vu} "
                 f"({p.stable_frequency_hz:.5g} Hz)")
    else:
        text += f"unstable to the last speed ({last:.5g} {vu})"
    return text + ("" if p.refined else " [linear between the sweep's speeds]")


# -- Nastran's f06 side by side ------------------------------------------------------------------
@dataclass
class F06Crossing:
    """A flutter point read from the f06: the branch, velocity, frequency (Hz) and k, labelled
    as ours (:data:`SUSTAINED` or :data:`HUMP`, with its re-stabilisation), and the sweep
    speeds that bracket the onset (and the re-stabilisation)."""

    point: int
    method: str
    mach: float | None
    density_ratio: float | None
    velocity: float
    frequency_hz: float
    kfreq: float
    kind: str = SUSTAINED
    stable_velocity: float | None = None
    bracket: tuple[float, float] = (math.nan, math.nan)
    stable_bracket: tuple[float, float] | None = None
    #: the root is real (k = 0, frequency 0) on either side of the onset: divergence-type
    real_root: bool = False


def _f06_runs(t) -> list[np.ndarray]:
    """Row indices of each sweep of an f06 table: PK prints its FLFACT speeds in the given order
    (BAH_Plane lists 250..4750, then the negated speeds by magnitude, 250.01..4750.01: two
    sweeps, their POINTs not the same roots), so a run ends where the speed decreases; KE prints
    by reduced frequency (one run, by velocity); PKNL: the path."""
    if t.method == "KE" or t.method == "K":
        return [np.argsort(t.velocity, kind="stable")]
    if t.method == "PKNL":
        return [np.arange(len(t.velocity))]
    breaks = np.flatnonzero(np.diff(t.velocity) < 0) + 1
    return np.split(np.arange(len(t.velocity)), breaks)


def f06_flutter_points(tables) -> list[F06Crossing]:
    """Zero-damping crossings (upwards, beyond round-off) of every f06 FLUTTER SUMMARY point
    (:func:`torchrom.f06.read_flutter_summary`), labelled sustained or hump
    (:func:`torchrom.aero.flutter.excursions`) on each run of speeds (:func:`_f06_runs`) and
    interpolated linearly in the printed order, as Nastran's own summary."""
    out = []
    for t in tables:
        for order in _f06_runs(t):
            g, vel, freq, kf = (t.damping[order], t.velocity[order], t.frequency[order],
                                t.kfreq[order])
            for i, back in excursions(g):

                def lerp(a, i, g=g):
                    s = g[i] / (g[i] - g[i + 1])
                    return float(a[i] + s * (a[i + 1] - a[i]))

                out.append(F06Crossing(
                    t.point, t.method, t.mach, t.density_ratio, lerp(vel, i), lerp(freq, i),
                    lerp(kf, i), SUSTAINED if back is None else HUMP,
                    None if back is None else lerp(vel, back),
                    (float(vel[i]), float(vel[i + 1])),
                    None if back is None else (float(vel[back]), float(vel[back + 1])),
                    bool(freq[i] == 0 or freq[i + 1] == 0)))
    return out


#: an f06 crossing is paired with one of ours only when their speeds and frequencies differ by
#: less than this, relative and summed (BAH_Plane's coarse speeds: 0.22 for the 393.8 hump
#: Nastran puts at 457.9; a real root against an oscillatory one: 1 and more)
MATCH_LIMIT = 0.5


def _distinct(crossings: list[F06Crossing]) -> list[F06Crossing]:
    """One of each crossing the f06 prints in several runs of the same speeds (BAH_Plane's
    speeds and the negated ones, 0.01 apart: the same kind, speed and frequency to 0.1 %)."""
    out: list[F06Crossing] = []
    for t in crossings:
        if not any(u.method == t.method and u.mach == t.mach and u.kind == t.kind
                   and abs(u.velocity - t.velocity) <= 1e-3 * abs(t.velocity)
                   and abs(u.frequency_hz - t.frequency_hz) <= 1e-3 * max(t.frequency_hz, 1e-3)
                   for u in out):
            out.append(t)
    return out


def _pair_crossings(ours, theirs: list[F06Crossing], vref: float) -> dict[int, int]:
    """{index in ours: index in theirs}: the same method, Mach and density ratio; pairs taken
    best first, the same kind before any other, then by the relative differences of speed and
    frequency summed (below :data:`MATCH_LIMIT`). POINT numbers are not used: they are
    Nastran's own root order (BAH_Plane's second run of speeds numbers its roots differently
    from its first)."""
    pairs = []
    for a, (r, p) in enumerate(ours):
        v = p.velocity / vref
        for b, t in enumerate(theirs):
            if t.method != r.case.method:
                continue
            if t.mach is not None and abs(t.mach - r.mach) > 1e-6:
                continue
            if t.density_ratio is not None and not np.isnan(r.density_ratio) and abs(
                    t.density_ratio - r.density_ratio) > 1e-6 * max(1.0, r.density_ratio):
                continue
            distance = (abs(t.velocity - v) / max(abs(v), 1e-300)
                        + abs(t.frequency_hz - p.frequency_hz)
                        / max(t.frequency_hz, p.frequency_hz, 1e-300))
            if distance <= MATCH_LIMIT:
                pairs.append(((t.kind != p.kind, distance), a, b))
    match: dict[int, int] = {}
    for _, a, b in sorted(pairs):
        if a not in match and b not in match.values():
            match[a] = b
    return match


def compare_f06(res: DeckResult, f06_path) -> tuple[str, list[dict]]:
    """torchrom's flutter points beside those of Nastran's FLUTTER SUMMARY (paired by
    :func:`_pair_crossings`), with the differences; plus the modes Nastran used."""
    from ..f06 import read_flutter_summary, read_real_eigenvalues

    vref = res.deck.vref
    theirs = _distinct(f06_flutter_points(read_flutter_summary(f06_path)))
    tables = read_real_eigenvalues(f06_path)
    lines, records = [], []
    if tables:
        ref = tables[-1].cycles  # the last table: the modes used in the dynamic analysis
        lines.append(f"{'mode':>5}{'torchrom Hz':>14}{'Nastran Hz':>14}{'diff %':>9}")
        floor = 1e-4 * float(np.abs(ref).max(initial=0.0))
        for i, f in enumerate(res.frequencies_hz):
            if i < len(ref):
                # rigid-body modes (zero up to round-off in both): no relative difference
                d = f"{100 * (f - ref[i]) / ref[i]:9.3f}" if abs(ref[i]) > floor else "    rigid"
                lines.append(f"{i + 1:>5}{f:14.5g}{ref[i]:14.5g}{d}")
    lines.append(f"{'method':>7}{'Mach':>7}{'rho ratio':>11}{'mode':>5}{'kind':>10}"
                 f"{'Nastran':>10}{'V torchrom':>13}"
                 f"{'V Nastran':>12}{'dV %':>8}{'f torchrom':>12}{'f Nastran':>11}{'df %':>8}")
    # a divergence of ours beside the f06's real-root crossings (Nastran prints them as points)
    ours = [(r, p) for r in res.results for p in r.points + r.divergence_points]
    match = _pair_crossings(ours, theirs, vref)
    used = set(match.values())
    for a, (r, p) in enumerate(ours):
        v = p.velocity / vref
        rec = {"flutter_id": r.case.sid, "method": r.case.method, "mach": r.mach,
               "density_ratio": r.density_ratio, "mode": p.mode + 1, "kind": p.kind,
               "divergence": p.divergence, "nastran_kind": None, "velocity": v,
               "frequency_hz": p.frequency_hz, "nastran_velocity": None,
               "nastran_frequency_hz": None, "velocity_diff_pct": None,
               "frequency_diff_pct": None}
        if a in match:
            t = theirs[match[a]]
            rec.update(nastran_kind=t.kind, nastran_velocity=t.velocity,
                       nastran_frequency_hz=t.frequency_hz,
                       velocity_diff_pct=100 * (v - t.velocity) / t.velocity,
                       frequency_diff_pct=None if t.frequency_hz == 0 else
                       100 * (p.frequency_hz - t.frequency_hz) / t.frequency_hz)
        records.append(rec)
    for k, t in enumerate(theirs):
        if k not in used:
            records.append({"method": t.method, "mach": t.mach, "density_ratio": t.density_ratio,
                            "mode": t.point, "kind": None, "nastran_kind": t.kind,
                            "velocity": None, "frequency_hz": None,
                            "nastran_velocity": t.velocity,
                            "nastran_frequency_hz": t.frequency_hz, "velocity_diff_pct": None,
                            "frequency_diff_pct": None})

    def fmt(x, spec):
        return format(x, spec) if x is not None else "-".rjust(len(format(0.0, spec)))

    for rec in records:
        ratio = rec["density_ratio"]
        lines.append(
            f"{rec['method']:>7}{fmt(rec['mach'], '7.3f')}"
            f"{fmt(None if ratio is None or np.isnan(ratio) else ratio, '11.4g')}"
            f"{rec['mode']:>5}{rec['kind'] or '-':>10}{rec['nastran_kind'] or '-':>10}"
            f"{fmt(rec['velocity'], '13.5g')}"
            f"{fmt(rec['nastran_velocity'], '12.5g')}"
            f"{fmt(rec['velocity_diff_pct'], '8.2f')}{fmt(rec['frequency_hz'], '12.5g')}"
            f"{fmt(rec['nastran_frequency_hz'], '11.5g')}{fmt(rec['frequency_diff_pct'], '8.2f')}"
        )
    if not records:
        lines.append("no flutter crossing in torchrom's run nor in the f06")
    return "\n".join(lines), records
