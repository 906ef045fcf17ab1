"""SOL 145-style flutter analysis of a Nastran deck.

Delegated: reading the deck and its coordinate systems (pyNastran), the modal solution
(:func:`torchrom.fe.read_bdf` and ``FEModel.modes``), the aerodynamic influence coefficients
(PanelAero, through :mod:`torchrom.aero.dlm`). Hand-written: the card semantics below, reference
checks with one-line errors, and the Nastran-style output (V-g table, flutter summary).

Cards honoured: FLUTTER (methods PK, PKNL, KE, K), FLFACT (density ratios, Mach numbers,
reduced frequencies or velocities; the ``THRU`` form is expanded by pyNastran), MKAERO1/MKAERO2,
AERO (REFC, RHOREF, SYMXZ), AEROS, CAERO1/PAERO1 (+AEFACT), SPLINE1/SPLINE2/SET1, EIGR/EIGRL
(ND, frequency range), PARAM LMODES and PARAM VREF; case control FMETHOD and METHOD.

Documented differences from Nastran: GAFs are computed directly at each FLFACT Mach number (on
the reduced frequencies of the nearest MKAERO Mach for PK; at the FLFACT reduced frequencies
themselves for K/KE) instead of being interpolated between MKAERO points; K and KE use the same
solver (KE without viscous damping, as in Nastran); structural damping tables (TABDMP1) are not
read; splines interpolate exactly (see :mod:`torchrom.aero.splines`). Modal matrices are those of
mass-normalised modes (M = I, K = diag ω²). Velocities are in the deck's units divided by
PARAM VREF.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .dlm import BoxMotion, compute_gaf
from .flutter import (
    AeroTable,
    FlutterPoint,
    ModalStructure,
    ModeSweep,
    ke_sweep,
    pk_sweep,
    refine_pk_crossings,
)
from .panels import AeroPanels, AeroReference, read_aero_reference, read_caero1, read_model
from .splines import BeamSpline, PlateSpline

FLUTTER_METHODS = ("PK", "PKNL", "KE", "K")


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


@dataclass
class FlutterDeck:
    """Everything a SOL 145 run needs from the deck, checked, except the modes."""

    path: Path
    panels: AeroPanels  # half model as given by the CAERO1 cards
    reference: AeroReference
    splines: list[SplineDef]
    cases: list[FlutterCase]
    mkaero: list[tuple[float, float]]
    n_modes: int | None
    frequency_range: tuple[float, float | None]
    vref: float = 1.0
    title: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def aero_panels(self) -> AeroPanels:
        """The panels the DLM sees: mirrored about xz when AERO SYMXZ = ±1."""
        return self.panels.mirror() if self.reference.symxz != 0 else self.panels

    def box_motion(self, grid_ids, grid_disp: np.ndarray) -> BoxMotion:
        """Modal box motion from grid displacements (n_modes, n_grid, 6) in basic axes."""
        grid_ids = np.asarray(grid_ids)
        where = {int(g): i for i, g in enumerate(grid_ids)}
        nm = grid_disp.shape[0]
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
            h_l[:, sp.box_index] = u @ hl.T
            h_c[:, sp.box_index] = u @ hc.T
            sl_c[:, sp.box_index] = u @ hx.T
        full = self.aero_panels
        anti = self.reference.symxz < 0
        return BoxMotion(
            full.box_motion(h_l, anti), full.box_motion(h_c, anti), full.box_motion(sl_c, anti)
        )


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


def _spline_defs(model, path: Path, panels: AeroPanels) -> list[SplineDef]:
    defs = []
    covered = np.zeros(panels.n, dtype=int)
    for eid in sorted(model.splines):
        sp = model.splines[eid]
        where = f"{path}: {sp.type} {eid}"
        if sp.type not in ("SPLINE1", "SPLINE2"):
            raise InputError(f"{where}: only SPLINE1 and SPLINE2 are supported")
        if sp.caero not in model.caeros:
            raise InputError(f"{where}: CAERO1 {sp.caero} not found")
        b1, b2 = sp.box1, sp.box2
        box_index = np.flatnonzero(
            (panels.caero_ids == sp.caero) & (panels.box_ids >= b1) & (panels.box_ids <= b2)
        )
        if b2 < b1 or len(box_index) != b2 - b1 + 1:
            raise InputError(f"{where}: boxes {b1}..{b2}: not all in CAERO1 {sp.caero}")
        setg = model.sets.get(sp.setg)
        if setg is None or setg.type != "SET1":
            raise InputError(f"{where}: SET1 {sp.setg} not found")
        grid_ids = np.asarray(setg.ids, dtype=int)
        for gid in grid_ids:
            if gid not in model.nodes:
                raise InputError(f"{path}: SET1 {sp.setg}: grid {gid} not found")
        xyz = np.array([model.nodes[g].get_position() for g in grid_ids])
        if sp.type == "SPLINE1":
            normal = panels.normals[box_index].mean(axis=0)
            spline = PlateSpline(xyz, normal=normal, dz=float(sp.dz or 0.0))
        else:
            cid = sp.cid or 0
            if cid and cid not in model.coords:
                raise InputError(f"{where}: coordinate system {cid} not found")
            coord = model.coords[cid]
            axes = np.asarray(coord.beta(), dtype=float)
            spline = BeamSpline(
                xyz,
                origin=np.asarray(coord.origin, float),
                axes=axes,
                attach_slope=(sp.dthx is None or sp.dthx >= 0.0),
                attach_torsion=(sp.dthy is None or sp.dthy >= 0.0),
            )
        covered[box_index] += 1
        defs.append(SplineDef(eid, sp.type, grid_ids, box_index, spline))
    if np.any(covered > 1):
        raise InputError(f"{path}: aero box {panels.box_ids[np.argmax(covered)]} is in two splines")
    return defs


def load_deck(path, require_flutter: bool = True) -> FlutterDeck:
    """Read and check the aeroelastic part of a deck (everything except the modal solution).

    ``require_flutter=False`` accepts a deck with aerodynamic boxes and splines but no FLUTTER
    cards (to build GAFs only).
    """
    path = Path(path)
    model = read_model(path)
    if not model.caeros:
        raise InputError(f"{path}: CAERO1: no aerodynamic panels in the deck")
    panels = read_caero1(model, str(path))
    ref = read_aero_reference(model, str(path))
    splines = _spline_defs(model, path, panels)
    if not splines:
        raise InputError(f"{path}: SPLINE1/SPLINE2: no spline connects the structure to the boxes")
    notes = []
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
            )
        )

    n_modes, frange = _mode_count(model, path) if require_flutter else (None, (0.0, None))
    vref = float(model.params["VREF"].values[0]) if "VREF" in model.params else 1.0
    title = ""
    cc = model.case_control_deck
    if cc is not None and cc.subcases[0].has_parameter("TITLE")[0]:
        title = str(cc.subcases[0].get_parameter("TITLE")[0]).strip()
    return FlutterDeck(
        path, panels, ref, splines, cases, sorted(set(mkaero)), n_modes, frange, vref, title, notes
    )


def _mode_count(model, path: Path) -> tuple[int | None, tuple[float, float | None]]:
    lmodes = int(model.params["LMODES"].values[0]) if "LMODES" in model.params else 0
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
    if lmodes > 0:
        nd = lmodes if nd is None else min(lmodes, nd) if nd else lmodes
    if nd is None and frange[1] is None:
        raise InputError(f"{path}: modes: give PARAM LMODES or an EIGR/EIGRL (ND or F2) via METHOD")
    return (int(nd) if nd else None), frange


# -- running ---------------------------------------------------------------------------------------
@dataclass
class CaseResult:
    """Flutter results of one FLUTTER case at one Mach number and density."""

    case: FlutterCase
    mach: float
    density_ratio: float
    density: float
    sweep: ModeSweep
    points: list[FlutterPoint]


@dataclass
class DeckResult:
    deck: FlutterDeck
    frequencies_hz: np.ndarray
    results: list[CaseResult]
    notes: list[str]

    def as_dict(self) -> dict:
        """Flat records for --json (velocities in deck units / VREF, frequencies in Hz)."""
        vref = self.deck.vref

        def scaled(rec: dict) -> dict:
            return {**rec, "velocity": rec["velocity"] / vref}

        return {
            "deck": str(self.deck.path),
            "title": self.deck.title,
            "modal_frequencies_hz": self.frequencies_hz.tolist(),
            "flutter": [
                {
                    "flutter_id": r.case.sid,
                    "method": r.case.method,
                    "mach": r.mach,
                    "density_ratio": r.density_ratio,
                    **scaled(p.as_dict()),
                }
                for r in self.results
                for p in r.points
            ],
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


def _modes(deck: FlutterDeck, fe):
    from ..fe.solvers import require_restrained

    n_dof = fe.n_dof
    n = deck.n_modes
    where = f"{deck.path.name}: flutter"
    if n is None:  # frequency range only
        probe = require_restrained(fe.modes(min(n_dof, 100)), where)
        f = np.asarray(probe.frequencies_hz)
        lo, hi = deck.frequency_range
        keep = np.flatnonzero((f >= lo) & (f <= hi))
        return f[keep], np.asarray(probe.shapes)[:, keep]
    modes = require_restrained(fe.modes(min(n, n_dof)), where)
    f = np.asarray(modes.frequencies_hz)
    shapes = np.asarray(modes.shapes)
    lo = deck.frequency_range[0]
    keep = np.flatnonzero(f >= lo) if lo > 0 else np.arange(len(f))
    return f[keep], shapes[:, keep]


def run_deck(deck_or_path, fe=None, kernel: str = "quartic", log=print) -> DeckResult:
    """Run every FLUTTER case of a deck (modes from ``fe`` or :func:`torchrom.fe.read_bdf`)."""
    deck = deck_or_path if isinstance(deck_or_path, FlutterDeck) else load_deck(deck_or_path)
    if fe is None:
        from ..fe import read_bdf

        fe = read_bdf(deck.path)
    freqs, shapes = _modes(deck, fe)
    if len(freqs) == 0:
        raise InputError(f"{deck.path}: modes: none in the requested range")
    log(f"{deck.path.name}: {len(freqs)} modes: " + ", ".join(f"{f:.4g}" for f in freqs) + " Hz")
    disp = np.asarray(fe.expand(shapes)).reshape(shapes.shape[1], -1, 6)  # (n_modes, n_grid, 6)
    motion = deck.box_motion(fe.grid_ids, disp)
    omega = 2 * np.pi * freqs
    structure = ModalStructure(np.eye(len(freqs)), np.diag(omega**2))
    b = deck.reference.semichord
    panels = deck.aero_panels
    results, notes = [], list(deck.notes)
    for case in deck.cases:
        for mach in case.machs:
            if case.method.startswith("PK"):
                near = min({m for m, _ in deck.mkaero}, key=lambda m: abs(m - mach))
                k_list = sorted({k for m, k in deck.mkaero if m == near})
            else:
                k_list = sorted(set(case.values.tolist()))
            log(
                f"FLUTTER {case.sid} ({case.method}): DLM at Mach {mach:g}, {len(k_list)} reduced "
                f"frequencies, {panels.n} boxes"
            )
            gaf = compute_gaf(panels, motion, mach, k_list, b, kernel)
            interp = "linear" if case.imeth == "L" else "cubic"
            aero = AeroTable.from_gaf(gaf, interpolation=interp)
            for ratio, rho in zip(case.density_ratios, case.densities):
                if case.method.startswith("PK"):
                    v = np.sort(np.abs(case.values))
                    sweep = pk_sweep(structure, aero, v, rho, mach=mach, eps=min(case.eps, 1e-4))
                    points = refine_pk_crossings(structure, aero, sweep)
                else:
                    sweep = ke_sweep(structure, aero, case.values, rho)
                    points = sweep.crossings()
                for p in points:
                    p.mach = float(mach)
                notes += sweep.notes
                results.append(
                    CaseResult(case, float(mach), float(ratio), float(rho), sweep, points)
                )
    return DeckResult(deck, freqs, results, notes)


def format_deck_result(res: DeckResult) -> str:
    """Nastran-like FLUTTER SUMMARY tables and the flutter points, in the deck's units."""
    vref = res.deck.vref
    lines = []
    if res.deck.title:
        lines.append(res.deck.title)
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
                k = sw.k[i, j]
                v = vel[i, j] / vref
                s = sw.eigenvalues[i, j]
                lines.append(
                    f"{k:10.4f} {1 / k if k > 0 else np.inf:12.4f} {v:13.5e} "
                    f"{sw.damping[i, j]:12.4e} {sw.frequency_hz[i, j]:12.5e} "
                    f"{s.real:13.5e} {s.imag:13.5e}"
                )
    lines.append("")
    any_point = False
    for r in res.results:
        for p in r.points:
            any_point = True
            lines.append(
                f"FLUTTER {r.case.sid} ({r.case.method}) Mach {r.mach:g} density ratio "
                f"{r.density_ratio:g}: mode {p.mode + 1} flutter speed {p.velocity / vref:.5g}, "
                f"frequency {p.frequency_hz:.5g} Hz, k = {p.k:.4f}"
            )
    if not any_point:
        lines.append("no flutter crossing (damping stays negative) in the requested range")
    for n in res.notes:
        lines.append(f"note: {n}")
    return "\n".join(lines)
