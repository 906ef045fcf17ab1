"""Nastran's FLUTTER SUMMARY (F06) written from torchrom's flutter sweeps (``flutter --f06``).

The layout is the one MSC and Simcenter Nastran print (the f06 files in tests/decks:
bah_plane.f06 for PK, pt145.f06 for KE, 0012_flutter2.f06 for PKNL): a page header of three
lines (TITLE; SUBTITLE; LABEL with ``SUBCASE n`` at column 110), ``FLUTTER  SUMMARY``, the
CONFIGURATION / XY- / XZ-SYMMETRY line, the POINT line (PK, KE: with the Mach number and the
density ratio; PKNL: per row), two blank lines, the column heading, then the rows

    PK, KE:  KFREQ  1./KFREQ  VELOCITY  DAMPING  FREQUENCY  COMPLEX EIGENVALUE (real, imag)
    PKNL:    KFREQ  1./KFREQ  DENSITY  MACH NO.  VELOCITY  DAMPING  FREQUENCY  ...

one table per POINT (a mode's branch) and flight condition, broken into pages of
:data:`ROWS_PER_PAGE` rows with the headers repeated, as Nastran does. pyNastran's reader
(``pyNastran.f06.parse_flutter.make_flutter_response``, ``plot_flutter_f06``) and
:func:`torchrom.f06.read_flutter_summary` read it back (tests/test_aero_f06_summary.py).

Printed precision (Nastran's formats): KFREQ to 4 decimals; PK and KE: the other columns to 8
significant digits (%.7E, 5e-8 relative); PKNL: 6 significant digits (%.5E, 5e-6 relative).
VELOCITY is in the model's speed unit (a deck: its length unit per second over PARAM VREF, as
Nastran prints it), FREQUENCY in Hz, the eigenvalue in 1/s, DAMPING is g = 2 Re s / |Im s|
(Nastran's finite g = 2 s b / (V ln 2) for a real root, :func:`~torchrom.aero.flutter.pk_damping`;
KE: the method's artificial g); the SUBTITLE line says the units. DENSITY and DENSITY RATIO are
ρ / RHOREF: a deck's AERO RHOREF; for a ROM, RHOREF = 1 in its density unit (so the column is the
density itself, which is how pyNastran's PKNL reader takes it). torchrom's state-space roots
(:mod:`torchrom.aero.state_space_branches`) are written in the p-k layout (METHOD = PK or PKNL,
whose columns they fill exactly), in their own subcase whose LABEL line says STATE-SPACE.
KE's COMPLEX EIGENVALUE is torchrom's s = ω (g/2 + i), whose ratio Re/Im = g/2 is Nastran's.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..f06 import FlutterTable
from .flutter import ModeSweep, pk_damping

#: data rows per page (Nastran's pages hold 35 to 40 rows of a flutter table)
ROWS_PER_PAGE = 35
#: 1./KFREQ printed where KFREQ is 0: Nastran's (1/1e-25 in single precision)
INVERSE_OF_ZERO = 9.9999996e24
#: the subcases of a ROM's summary: p-k first, the state space second
PK_SUBCASE, STATE_SPACE_SUBCASE = 1, 2


@dataclass
class SummarySubcase:
    """The FLUTTER SUMMARY tables of one subcase: ``label`` is the page's LABEL line (e.g.
    "PK METHOD, FLUTTER 501")."""

    subcase: int
    label: str
    tables: list[FlutterTable] = field(default_factory=list)


@dataclass
class FlutterSummary:
    """Everything a FLUTTER SUMMARY file holds: ``title`` and ``subtitle`` (the units) head
    every page; the symmetry words are Nastran's (SYMMETRIC, ANTISYMMETRIC, ASYMMETRIC)."""

    title: str
    subtitle: str
    subcases: list[SummarySubcase]
    xy_symmetry: str = "ASYMMETRIC"
    xz_symmetry: str = "ASYMMETRIC"


def sweep_tables(sweep: ModeSweep, method: str, mach: float, density_ratio: float | None,
                 rho_ref: float = 1.0, velocity_scale: float = 1.0) -> list[FlutterTable]:
    """One FLUTTER SUMMARY point per branch of ``sweep`` (POINT = branch + 1), rows in the
    sweep's order. ``method``: PK, KE or PKNL (PKNL: the DENSITY column is the sweep's
    density / ``rho_ref``, the MACH NO. column ``mach``); velocities divided by
    ``velocity_scale`` (PARAM VREF)."""
    method = method.upper()
    vel = sweep.velocity_by_mode
    eig = np.asarray(sweep.eigenvalues)
    # Nastran's g (finite for real roots, where a ROM's p-k keeps ±inf); KE keeps its own
    # (artificial structural) g, and its velocity per root
    g = (np.asarray(sweep.damping, float) if method == "KE"
         else pk_damping(eig, vel[:, 0], sweep.semichord, "nastran"))
    n = len(vel)
    tables = []
    for j in range(eig.shape[1]):
        pknl = method == "PKNL"
        tables.append(FlutterTable(
            point=j + 1, method=method, mach=None if pknl else float(mach),
            density_ratio=None if pknl else density_ratio,
            kfreq=np.asarray(sweep.k, float)[:, j].copy(),
            velocity=vel[:, j] / velocity_scale, damping=g[:, j].copy(),
            frequency=np.abs(eig[:, j].imag) / (2 * np.pi),
            density=np.asarray(sweep.density, float) / rho_ref if pknl else None,
            machs=np.full(n, float(mach)) if pknl else None,
            eigenvalue=eig[:, j].copy()))
    return tables


def _symmetry(sign: int, symmetric: int) -> str:
    """Nastran's word for a SYMXZ/SYMXY value (``symmetric``: the value meaning symmetric)."""
    return "ASYMMETRIC" if sign == 0 else "SYMMETRIC" if sign == symmetric else "ANTISYMMETRIC"


def deck_summary(res) -> FlutterSummary:
    """The summary of a deck's flutter (:class:`torchrom.aero.nastran_flutter.DeckResult`):
    one subcase per FLUTTER card, in the deck's order; one table per branch at each Mach
    number and density ratio (PKNL: per Mach number), velocities over VREF."""
    deck = res.deck
    units = res.as_dict()["units"]
    subcases: dict[int, SummarySubcase] = {}
    for r in res.results:
        method = r.case.method if r.case.method != "K" else "KE"
        if r.case.sid not in subcases:
            subcases[r.case.sid] = SummarySubcase(
                len(subcases) + 1, f"{method} METHOD, FLUTTER {r.case.sid}")
        ratio = None if method == "PKNL" else r.density_ratio
        subcases[r.case.sid].tables += sweep_tables(r.sweep, method, r.mach, ratio,
                                                    deck.reference.rho_ref, deck.vref)
    return FlutterSummary(
        deck.title or deck.path.name,
        f"TORCHROM FLUTTER {deck.path.name}: VELOCITY IN {units['velocity']}, FREQUENCY IN "
        f"HZ, DENSITY RATIO = DENSITY / RHOREF ({deck.reference.rho_ref:g} {units['density']})",
        list(subcases.values()),
        _symmetry(deck.reference.symxy, -1), _symmetry(deck.reference.symxz, 1))


def rom_subtitle(labels: dict) -> str:
    """The SUBTITLE of a ROM's summary: its units (:meth:`torchrom.units.UnitSystem.labels`)."""
    return (f"TORCHROM FLUTTER: VELOCITY IN {labels['speed']}, FREQUENCY IN HZ, DENSITY RATIO "
            f"= DENSITY IN {labels['density']} (RHOREF = 1)")


def rom_summary(title: str, labels: dict, pk: list[tuple[ModeSweep, float | None]],
                state_space: list[tuple[ModeSweep, float | None]], mach: float
                ) -> FlutterSummary:
    """The summary of a ROM's flutter: the p-k sweeps in subcase :data:`PK_SUBCASE`, the
    state space's branches in :data:`STATE_SPACE_SUBCASE`, each given with its density (PK
    layout, one density per sweep) or None (PKNL: a matched-point path, density and velocity
    per row); densities are ratios to RHOREF = 1."""
    subcases = []
    for number, what, sweeps in ((PK_SUBCASE, "PK METHOD", pk),
                                 (STATE_SPACE_SUBCASE, "STATE-SPACE (RFA) ROOTS IN THE PK LAYOUT",
                                  state_space)):
        if not sweeps:
            continue
        sub = SummarySubcase(number, what)
        for sweep, density in sweeps:
            sub.tables += sweep_tables(sweep, "PKNL" if density is None else "PK", mach, density)
        subcases.append(sub)
    return FlutterSummary(title, rom_subtitle(labels), subcases)


def matched_summary(title: str, labels: dict, results, structure, rfa, mach: float
                    ) -> FlutterSummary:
    """:func:`rom_summary` of a matched point (``results``:
    :class:`~torchrom.aero.flutter.MatchedPointResult` by p-k and/or the state space): PKNL
    tables along the altitude path, high to low; the state space's roots at the same
    conditions as branches (:func:`~torchrom.aero.state_space_branches.state_space_branches`)."""
    from .state_space_branches import state_space_branches

    pk = [(r.sweep, None) for r in results if r.method == "p-k" and r.sweep is not None]
    ss = [(state_space_branches(structure, rfa, r.sweep["velocity"], r.sweep["density"],
                                r.sweep["altitude"], mach), None)
          for r in results if r.method == "state-space" and r.sweep is not None]
    return rom_summary(title, labels, pk, ss, mach)


def density_summary(title: str, labels: dict, pk_sweeps: list[ModeSweep], ss_results,
                    structure, rfa, mach: float) -> FlutterSummary:
    """:func:`rom_summary` of flutter speeds at fixed densities: the p-k sweeps (PK tables at
    each density) and, for each state-space result
    (:class:`~torchrom.aero.flutter_speed.FlutterSpeed`), its roots as branches over the
    speeds it searched (:func:`~torchrom.aero.flutter_speed.flutter_speed_at_density`)."""
    from .flutter_speed import N_SPEEDS
    from .state_space_branches import state_space_branches

    pk = [(s, float(s.density[0])) for s in pk_sweeps]
    ss = [(state_space_branches(structure, rfa, np.geomspace(*r.speed_range, N_SPEEDS),
                                r.density, mach=mach), float(r.density))
          for r in ss_results if r.speed_range is not None]
    return rom_summary(title, labels, pk, ss, mach)


# -- writing ---------------------------------------------------------------------------------------
_PK_HEADING = ("       KFREQ            1./KFREQ         VELOCITY            DAMPING         "
               "FREQUENCY            COMPLEX   EIGENVALUE")
_PKNL_HEADING = ("    KFREQ          1./KFREQ       DENSITY     MACH NO.      VELOCITY       "
                 "DAMPING     FREQUENCY      COMPLEX   EIGENVALUE")


def _inverse(k: float) -> float:
    return INVERSE_OF_ZERO if k == 0 else 1.0 / k


def _rows(t: FlutterTable) -> list[str]:
    s = np.asarray(t.eigenvalue, complex)
    if t.method == "PKNL":
        return [f"{k:9.4f}{_inverse(k):18.5E}{d:14.5E}{m:14.5E}{v:14.5E}{g:14.5E}{f:14.5E}"
                f"{z.real:14.5E}{z.imag:14.5E}"
                for k, d, m, v, g, f, z in zip(t.kfreq, t.density, t.machs, t.velocity,
                                                t.damping, t.frequency, s)]
    return [f"{k:14.4f}{_inverse(k):20.7E}{v:18.7E}{g:18.7E}{f:18.7E}{z.real:18.7E}{z.imag:18.7E}"
            for k, v, g, f, z in zip(t.kfreq, t.velocity, t.damping, t.frequency, s)]


def _point_line(t: FlutterTable) -> str:
    if t.method == "PKNL":
        return f"       POINT = {t.point:4d}     METHOD = PKNL"
    return (f"       POINT = {t.point:4d}     MACH NUMBER = {t.mach:7.4f}     DENSITY RATIO = "
            f"{t.density_ratio:11.4E}     METHOD = {t.method:<4}")


def format_flutter_summary(summary: FlutterSummary, date: datetime.date | None = None) -> str:
    """The F06 text of ``summary`` (module docstring), pages numbered from 1."""
    from .. import __version__

    date = date or datetime.date.today()
    # the first line of a page ends pyNastran's rows of a table (it reads rows while a line has
    # 7 (PK, KE) or 9 (PKNL) words): 8 words here and at least one of title, never 7 or 9
    stamp = (f"{date.strftime('%B').upper():>9} {date.day:2d}, {date.year}  TORCHROM "
             f"{__version__} FLUTTER")
    title = " ".join(summary.title.split()) or "TORCHROM"
    lines: list[str] = []
    page = 0
    for sub in summary.subcases:
        for t in sub.tables:
            rows = _rows(t)
            for start in range(0, max(len(rows), 1), ROWS_PER_PAGE):
                page += 1
                lines += [
                    f"1    {title[:64]:<64}    {stamp:<40}  PAGE {page:5d}",
                    f"      {summary.subtitle}",
                    f"0     {sub.label[:100]:<100}   SUBCASE {sub.subcase}",
                    "0                                                       FLUTTER  SUMMARY",
                    f"                         CONFIGURATION = AEROSG2D     XY-SYMMETRY = "
                    f"{summary.xy_symmetry}     XZ-SYMMETRY = {summary.xz_symmetry}",
                    _point_line(t), "", "",
                    _PKNL_HEADING if t.method == "PKNL" else _PK_HEADING,
                ]
                lines += rows[start:start + ROWS_PER_PAGE]
    # a blank line ends the last table for pyNastran (which takes any other line for a row)
    lines += ["", "1                                        * * * END OF JOB * * *", ""]
    return "\n".join(lines)


def write_flutter_summary(path, summary: FlutterSummary) -> Path:
    """Write ``summary`` to ``path`` (atomically, :func:`torchrom.io.write_text_atomic`)."""
    from ..io import write_text_atomic

    return write_text_atomic(path, format_flutter_summary(summary))
