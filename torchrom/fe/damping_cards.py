"""The structural damping a Nastran deck states, as each mode's damping ratio.

Cards (MSC Nastran QRG: PARAM G, W3, W4; MAT1/MAT8 GE; TABDMP1; case control SDAMPING), read
from pyNastran's parsed deck (``bdf.params``, ``bdf.materials[mid].ge``,
``bdf.tables_sdamping``), each mapped as Nastran's transient solutions apply it, on
mass-normalised modes φ_i of circular frequency ω_i = 2π f_i:

- PARAM G with PARAM W3 (rad/time): the viscous damping (G/W3) K, so ζ_i = G ω_i / (2 W3),
  i.e. a stiffness-proportional γ = G/W3. G without W3 (or W3 = 0, Nastran's default, which
  drops G from a transient) is refused: the frequency that makes the loss factor viscous is
  missing.
- MAT1 and MAT8 GE with PARAM W4 (rad/time): the element damping Σ_e (GE_e / W4) K_e, so
  ζ_i = φ_iᵀ K_GE φ_i / (2 ω_i W4) with K_GE = Σ_m GE_m K_m (K_m: the stiffness of the elements
  of material m). K_GE is assembled on the model's free DOFs as K(E_m (1 + GE_m)) − K: the
  model rebuilt with each damped material's moduli scaled, exact because K is linear in them.
  GE without W4 is refused as G without W3.
- TABDMP1 selected by SDAMPING: ζ_i from the table at f_i (TYPE G: g/2, CRIT: ζ, Q: 1/(2Q);
  :class:`torchrom.fe.modal_damping.ModalDamping`), Nastran's modal damping.

The sources add, as in Nastran's transient. A ROM's α, γ are then fitted to the ratios
(:mod:`torchrom.rom.rayleigh`): γ alone where only G and GE are given (they are stiffness-
proportional), α and γ with a TABDMP1. Rigid-body modes get none. Other element damping
(PCOMP, PELAS, PBUSH GE) is not applied, and the line says so.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..rom.rayleigh import RayleighDamping, fit_modal_ratios, goland_damping, no_damping
from .modal_damping import ModalDamping, read_tabdmp1, sdamp_of

#: the moduli each damped material's GE scales (pyNastran attribute names)
MODULI = {"MAT1": ("e", "g"), "MAT8": ("e11", "e22", "g12", "g1z", "g2z")}


def _param(bdf, name: str) -> float | None:
    p = bdf.params.get(name)
    if p is None or not p.values or p.values[0] is None:
        return None
    try:
        return float(p.values[0])
    except (TypeError, ValueError):
        raise InputError(f"PARAM {name}: expected a number, got {p.values[0]!r}") from None


@dataclass(frozen=True)
class DeckDamping:
    """The damping cards of a deck, checked (:func:`read_deck_damping`).

    Attributes: ``g`` and ``w3`` (PARAM G, W3 in rad/time), ``ge`` (material id → GE),
    ``ge_cards`` (material id → its card, e.g. "MAT1") and ``w4`` (PARAM W4), ``table`` (the
    TABDMP1 that SDAMPING selects), ``notes`` (damping the deck states that is not applied).
    """

    fname: str
    g: float = 0.0
    w3: float | None = None
    ge: dict[int, float] = field(default_factory=dict)
    w4: float | None = None
    ge_cards: dict[int, str] = field(default_factory=dict)
    table: ModalDamping | None = None
    notes: tuple[str, ...] = ()

    @property
    def stated(self) -> bool:
        return bool(self.g) or bool(self.ge) or self.table is not None

    def describe(self) -> str:
        parts = []
        if self.g:
            parts.append(f"PARAM G {self.g:g} at W3 = {self.w3:g} rad/s")
        if self.ge:
            mats = ", ".join(f"{self.ge_cards.get(m, 'material')} {m} GE {g:g}"
                             for m, g in sorted(self.ge.items()))
            parts.append(f"{mats} at W4 = {self.w4:g} rad/s")
        if self.table is not None:
            parts.append(f"TABDMP1 {self.table.tid} ({self.table.kind}) by SDAMPING")
        return f"{self.fname}: " + ", ".join(parts)

    def modal_zeta(self, fe, shapes, frequencies_hz) -> np.ndarray:
        """ζ_i of each mode (mass-normalised ``shapes`` (n_dof, n) of ``fe``'s free DOFs at
        ``frequencies_hz``, all > 0), the sources added (module docstring)."""
        f = np.asarray(frequencies_hz, dtype=float)
        w = 2 * np.pi * f
        zeta = np.zeros_like(f)
        if self.g:
            zeta += self.g * w / (2 * self.w3)
        if self.ge:
            phi = np.asarray(shapes, dtype=float)
            k_ge = material_damping_stiffness(fe, self.ge, self.fname)
            zeta += np.einsum("ij,ij->j", phi, k_ge @ phi) / (2 * w * self.w4)
        if self.table is not None:
            zeta += self.table.zeta(f)
        return zeta


def _sdamping(bdf, fname: str) -> int | None:
    """The SDAMPING of the case control (one for every subcase that has one; a global one
    applies to all); InputError where subcases select different tables."""
    cc = bdf.case_control_deck
    if cc is None:
        return None
    found = {isub: sdamp_of(sub) for isub, sub in cc.subcases.items()}
    tids = {t for t in found.values() if t is not None}
    if len(tids) > 1:
        which = ", ".join(f"{t} (subcase {i})" for i, t in sorted(found.items())
                          if t is not None)
        raise InputError(f"{fname}: case control SDAMPING selects different tables, {which}: "
                         "the structure's damping is one (give --damping-ratio)")
    return tids.pop() if tids else None


def read_deck_damping(bdf, fname: str) -> DeckDamping:
    """The deck's PARAM G/W3/W4, material GE and TABDMP1-by-SDAMPING, checked: one-line
    InputError naming the card and field (a negative value, G without W3, GE without W4, a
    missing or malformed table)."""
    hint = "or give --damping-ratio ZETA"
    g = _param(bdf, "G") or 0.0
    w3, w4 = _param(bdf, "W3"), _param(bdf, "W4")
    if not np.isfinite(g) or g < 0:
        raise InputError(f"{fname}: PARAM G: expected a structural damping >= 0, got {g:g}")
    if g and not (w3 is not None and np.isfinite(w3) and w3 > 0):
        got = "none" if w3 is None else f"{w3:g}"
        raise InputError(f"{fname}: PARAM G {g:g} needs PARAM W3 > 0, the circular frequency "
                         f"(rad/s) at which G becomes the viscous damping (G/W3) K (got "
                         f"{got}; Nastran's transient ignores G without it): add PARAM W3, "
                         f"{hint} (G/2 = {g / 2:g} at every mode)")
    ge: dict[int, float] = {}
    for mid, mat in sorted(bdf.materials.items()):
        value = getattr(mat, "ge", None)
        if not value:
            continue
        value = float(value)
        if not np.isfinite(value) or value < 0:
            raise InputError(f"{fname}: {mat.type} {mid}: field GE: expected a structural "
                             f"damping >= 0, got {value:g}")
        if mat.type not in MODULI:
            raise InputError(f"{fname}: {mat.type} {mid}: field GE {value:g}: material "
                             f"damping is read from {', '.join(MODULI)} only ({hint})")
        ge[int(mid)] = value
    if ge and not (w4 is not None and np.isfinite(w4) and w4 > 0):
        got = "none" if w4 is None else f"{w4:g}"
        mid = next(iter(ge))
        raise InputError(f"{fname}: {bdf.materials[mid].type} {mid} GE {ge[mid]:g} needs "
                         f"PARAM W4 > 0, the circular frequency (rad/s) at which GE becomes "
                         f"the viscous damping (GE/W4) K of its elements (got {got}; Nastran's "
                         f"transient ignores GE without it): add PARAM W4, {hint}")
    tid = _sdamping(bdf, fname)
    table = read_tabdmp1(bdf, f"{fname}: case control", tid) if tid is not None else None
    if table is not None and np.any(table.value < 0):
        raise InputError(f"{fname}: TABDMP1 {tid}: expected damping values >= 0, got "
                         f"{table.value.tolist()}")
    notes = tuple(f"{p.type} {pid} GE {float(p.ge):g} not applied (element damping is read "
                  f"from {', '.join(MODULI)} GE)"
                  for pid, p in sorted(bdf.properties.items())
                  if isinstance(getattr(p, "ge", None), (int, float)) and p.ge)
    unselected = sorted(t for t in getattr(bdf, "tables_sdamping", {}) if t != tid)
    if unselected:
        notes += (f"TABDMP1 {', '.join(map(str, unselected))} selected by no SDAMPING: not "
                  "applied",)
    return DeckDamping(fname, g, w3 if g else None, ge, w4 if ge else None,
                       {m: bdf.materials[m].type for m in ge}, table, notes)


def material_damping_stiffness(fe, ge: dict[int, float], fname: str):
    """K_GE = Σ_m GE_m K_m on ``fe``'s free DOFs (sparse): the model rebuilt from its deck
    with each damped material's moduli times (1 + GE_m), minus K (module docstring)."""
    from .bdf_read import from_pynastran

    bdf = fe.bdf
    saved = []
    try:
        for mid, value in ge.items():
            mat = bdf.materials[mid]
            for attr in MODULI[mat.type]:
                old = getattr(mat, attr, None)
                if old is not None:
                    saved.append((mat, attr, old))
                    setattr(mat, attr, old * (1.0 + value))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the deck was read once already: no news
            scaled = from_pynastran(bdf, source=fe.source, name=fe.name, units=fe.units,
                                    unsupported="warn", rotations=fe.rotations)
    finally:
        for mat, attr, old in saved:
            setattr(mat, attr, old)
    if scaled.free_dofs() != fe.free_dofs():
        raise InputError(f"{fname}: material GE: the model with its damped materials' moduli "
                         "scaled has other free DOFs than the model (give --damping-ratio)")
    return scaled.stiffness_matrix() - fe.stiffness_matrix()


def is_goland_deck(bdf) -> bool:
    """Whether the deck is the heavy Goland wing ``torchrom goland`` writes (by its TITLE)."""
    from .bdf_read import _title
    from .goland_geometry import GOLAND_TITLE

    return bdf is not None and _title(bdf).startswith(GOLAND_TITLE)


def rom_damping(fe, cards: DeckDamping | None, shapes, frequencies_hz,
                free: bool) -> RayleighDamping:
    """The ROM's α, γ from the deck: its cards' ratios at the elastic modes (``shapes``,
    ``frequencies_hz``) fitted (:func:`torchrom.rom.rayleigh.fit_modal_ratios`); else the
    paper's values for the heavy Goland wing; else none, said so."""
    if cards is not None and cards.stated:
        f = np.asarray(frequencies_hz, dtype=float)
        if f.size == 0:
            raise InputError(f"{cards.describe()}: the ROM has no elastic mode to apply the "
                             "damping to (give --damping-ratio)")
        zeta = cards.modal_zeta(fe, shapes, f)
        rec = fit_modal_ratios(cards.describe(), f, zeta, free=free,
                               mass_proportional=cards.table is not None)
        if cards.notes:
            rec = RayleighDamping(rec.alpha, rec.gamma, rec.source,
                                  f"{rec.description} ({'; '.join(cards.notes)})",
                                  rec.frequencies_hz, rec.zeta_target)
        return rec
    if is_goland_deck(getattr(fe, "bdf", None)):
        return goland_damping()
    why = "no PARAM G/W3, material GE/W4 or TABDMP1 selected by SDAMPING in the deck"
    if cards is not None and cards.notes:
        why += f"; {'; '.join(cards.notes)}"
    return no_damping(why)
