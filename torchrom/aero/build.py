"""From an FE model to ``AeroData`` (GAF + RFA) and to flutter results: the Python API.

Glue: modes from the FE model (:mod:`torchrom.fe`), box motion through a spline
(:mod:`torchrom.aero.splines`), DLM GAFs (:mod:`torchrom.aero.dlm`, PanelAero), the RFA
(:mod:`torchrom.aero.rfa`) and the matched-point flutter solvers (:mod:`torchrom.aero.flutter`).

For a deck with CAERO1/SPLINE cards the deck's boxes and splines are used; otherwise the built-in
Goland planform (chord 6 ft, semispan 20 ft, LE at x = 0, mirrored to full span) with an
infinite-plate spline over the structural grids that lie in the planform.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..reference import paper_reference
from ..units import METADATA_KEY, recorded_units
from .dlm import BoxMotion, compute_gaf
from .files import AeroData
from .flutter import (
    AeroTable,
    MatchedPointResult,
    ModalStructure,
    flutter_altitude_pk,
    flutter_altitude_state_space,
    rigid_body_modes,
)
from .panels import GOLAND_CHORD_FT, GOLAND_SEMISPAN_FT, AeroPanels, goland_panels, goland_reference
from .rfa import fit_minimum_state, fit_roger, impose_quasi_steady_slope, quasi_steady_slope
from .splines import PlateSpline, SectionSpline
from .steady import split_incidence, with_incidence

#: reduced frequencies (k = ω b / V) of the Goland GAF table; the paper's flutter point has
#: k ≈ 0.05 and the 9th mode (29 Hz) at 4,000 ft reaches k ≈ 0.7
GOLAND_K_LIST = (
    0.0,
    0.001,
    0.005,
    0.01,
    0.02,
    0.03,
    0.04,
    0.05,
    0.06,
    0.08,
    0.1,
    0.125,
    0.15,
    0.2,
    0.25,
    0.3,
    0.4,
    0.5,
    0.6,
    0.8,
    1.0,
)

_PAPER = paper_reference()
#: paper's baseline Rayleigh damping (Eq. 46): α0 (1/s), β0 = γ (s) with D̄1 = K1
BASELINE_ALPHA = _PAPER.alpha0_per_s
BASELINE_GAMMA = _PAPER.beta0_s

#: paper's reference results at Mach 0.70 (Sec. III.C, Table 3; data/paper_reference.toml)
PAPER_FLUTTER_ALTITUDE_FT = _PAPER.flutter_altitude_ft
PAPER_FLUTTER_FREQUENCY_HZ = _PAPER.flutter_frequency_hz
PAPER_TABLE3 = dict(_PAPER.table3_hz)


@dataclass
class ModalData:
    """Modes of an FE model on its grids: frequencies (m,) and displacements (m, n_grid, 6).

    ``element_grids``: mask of the grids that carry structural elements (None: all), so that
    mass-only or rigid-element reference grids (e.g. the Goland store grid, an RBE3 reference
    point at the store's chordwise position) do not enter the aerodynamic spline.
    """

    frequencies_hz: np.ndarray
    grid_ids: np.ndarray
    grid_xyz: np.ndarray
    displacements: np.ndarray
    element_grids: np.ndarray | None = None

    def in_planform_axes(self, frame) -> ModalData:
        """The same modes in the axes of the built-in planforms (x along the chord from the
        structure's leading edge, y along the span from the root, z up) of the wing's
        :class:`~torchrom.fe.wing_frame.WingFrame`: a deck in any orientation meets its planform
        as the unrotated deck does (for the Goland planform, whose leading edge is the front of
        the 4 ft box)."""
        P = np.stack((frame.chord, frame.span, frame.up))
        xyz = (self.grid_xyz - frame.origin) @ P.T
        front = xyz[self.element_grids] if self.element_grids is not None else xyz
        xyz[:, 0] -= front[:, 0].min()
        u = np.array(self.displacements, dtype=float)
        # rotation vectors are pseudo-vectors: an improper P flips them once more
        u[..., :3] = u[..., :3] @ P.T
        u[..., 3:] = np.linalg.det(P) * (u[..., 3:] @ P.T)
        return replace(self, grid_xyz=xyz, displacements=u)

    def structure(self, alpha: float = 0.0, gamma: float = 0.0) -> ModalStructure:
        """Mass-normalised modal structure M = I, K = diag ω², D̄1 = K (Rayleigh γ K)."""
        w = 2 * np.pi * self.frequencies_hz
        return ModalStructure(np.eye(len(w)), np.diag(w**2), alpha=alpha, gamma=gamma)


def modal_data(fe, n_modes: int) -> ModalData:
    from ..fe.rigid import modal_basis_with_rigid

    # a free aircraft's rigid-body modes first, at 0 Hz, as SOL 145 and the ROM basis keep them
    # (the same shapes as torchrom.identify's: GAFs on the ROM's linear modes)
    modes = fe.modes(int(n_modes))
    if getattr(modes, "n_rigid", 0):  # modes of another source (closed form) have none
        frequencies, shapes = modal_basis_with_rigid(fe, modes, int(n_modes), [])
    else:
        frequencies, shapes = modes.frequencies_hz, modes.shapes
    shapes = np.asarray(shapes, dtype=float)
    grid_ids = np.asarray(fe.grid_ids)
    return ModalData(
        frequencies_hz=np.asarray(frequencies, dtype=float),
        grid_ids=grid_ids,
        grid_xyz=np.asarray(fe.grid_xyz, dtype=float),
        displacements=np.asarray(fe.expand(shapes), dtype=float).reshape(shapes.shape[1], -1, 6),
        element_grids=_element_grid_mask(fe, grid_ids),
    )


def planform_modes(fe, modes: ModalData) -> ModalData:
    """``modes`` in the built-in planform's axes (:meth:`ModalData.in_planform_axes`); as they
    are where the wing's axes cannot be told (a deck in basic x-y)."""
    from ..fe.wing_frame import WingFrameError

    try:
        frame = fe.wing_frame()
    except (WingFrameError, AttributeError):
        return modes
    return modes.in_planform_axes(frame)


def _element_grid_mask(fe, grid_ids) -> np.ndarray | None:
    """Grids connected to structural elements of the FE model's deck (``fe.bdf``), if known."""
    deck = getattr(fe, "bdf", None)
    elements = getattr(deck, "elements", None)
    if not elements:
        return None
    ids = set()
    for element in elements.values():
        ids.update(int(n) for n in element.node_ids if n)
    return np.isin(grid_ids, sorted(ids))


def planform_grid_mask(
    grid_xyz, x_le=0.0, chord=GOLAND_CHORD_FT, semispan=GOLAND_SEMISPAN_FT, tol=1e-6
) -> np.ndarray:
    """Grids whose (x, y) lie inside the rectangular planform (the spline's structural points)."""
    xyz = np.asarray(grid_xyz)
    return (
        (xyz[:, 0] >= x_le - tol)
        & (xyz[:, 0] <= x_le + chord + tol)
        & (xyz[:, 1] >= -tol)
        & (xyz[:, 1] <= semispan + tol)
    )


SPLINES = ("section", "plate")
#: least share of the planform's span that the splined structural grids must cover (beyond
#: it the spline extrapolates the motion of a small structure over a large wing)
MIN_SPAN_COVERAGE = 0.5


def check_structure_spans_planform(xyz, panels: AeroPanels) -> None:
    """InputError when the structural grids of the spline cover less than
    :data:`MIN_SPAN_COVERAGE` of the half planform's span (e.g. the 20 ft Goland planform on
    a 0.5 m plate deck)."""
    y = np.asarray(xyz, dtype=float)[:, 1]
    half = panels.doublet_points[~panels.mirrored][:, 1]
    span = float(half.max() - min(half.min(), 0.0)) if half.size else 0.0
    covered = float(y.max() - y.min())
    if span > 0 and covered < MIN_SPAN_COVERAGE * span:
        # the rotation into the planform's axes leaves rounding (-1.5e-17) where a grid is on 0
        lo, hi = (0.0 if abs(v) <= 1e-12 * max(abs(y).max(), 1e-300) else float(v)
                  for v in (y.min(), y.max()))
        raise InputError(f"aero spline: the structure's grids span {lo:.4g} .. "
                         f"{hi:.4g} along the wing's span but the planform's boxes span "
                         f"{span:.4g} (the built-in "
                         f"planform is the Goland wing, {GOLAND_CHORD_FT:g} x "
                         f"{GOLAND_SEMISPAN_FT:g} ft); expected the structure to cover at least "
                         f"{MIN_SPAN_COVERAGE:.0%} of it: use the deck's own CAERO planform")


def planform_box_motion(
    modes: ModalData, panels: AeroPanels, grid_mask=None, spline: str = "section"
) -> BoxMotion:
    """Box motion of a mirrored (symmetric) or half model from the structural grids' T3.

    ``spline``: "section" (chordwise-rigid strips, the wing box has rigid ribs; exact chordwise
    extrapolation from the 4 ft box to the 6 ft chord) or "plate" (infinite-plate spline).
    """
    if grid_mask is None:
        mask = planform_grid_mask(modes.grid_xyz)
        if modes.element_grids is not None:
            mask &= modes.element_grids
    else:
        mask = np.asarray(grid_mask)
    if mask.sum() < 3:
        raise InputError("aero spline: fewer than three structural grids inside the planform")
    check_structure_spans_planform(modes.grid_xyz[mask], panels)
    if spline == "section":
        xyz = modes.grid_xyz[mask]
        spline_op = SectionSpline(xyz, x_ref=float(np.mean(xyz[:, 0])))
    elif spline == "plate":
        spline_op = PlateSpline(modes.grid_xyz[mask])
    else:
        raise InputError(f"aero spline: expected one of {SPLINES}, got {spline!r}")
    half = ~panels.mirrored
    src = np.flatnonzero(half)
    u = modes.displacements[:, mask, :].reshape(len(modes.frequencies_hz), -1)
    hl, _ = spline_op.operators(panels.doublet_points[src])
    hc, hx = spline_op.operators(panels.control_points[src])
    # Values per half-model box (``src`` is in half-model order), spread to the image boxes
    # (symmetric shapes).
    return BoxMotion(
        panels.box_motion(u @ hl.T), panels.box_motion(u @ hc.T), panels.box_motion(u @ hx.T)
    )


def build_from_modes(
    modes: ModalData,
    mach: float = 0.7,
    n_lags: int = 13,
    k_list=GOLAND_K_LIST,
    panels: AeroPanels | None = None,
    semichord: float | None = None,
    kernel: str = "quartic",
    rfa_kind: str = "minimum-state",
    optimize_roots: bool = False,
    progress=None,
    spline: str = "section",
) -> AeroData:
    """GAF + RFA on the given modes over the built-in Goland planform (or given panels)."""
    panels = goland_panels() if panels is None else panels
    b = goland_reference().semichord if semichord is None else float(semichord)
    motion = with_incidence(planform_box_motion(modes, panels, spline=spline), panels)
    gaf, incidence = split_incidence(
        compute_gaf(panels, motion, mach, _with_zero(k_list), b, kernel, progress=progress))
    rfa = _fit(gaf, n_lags, rfa_kind, optimize_roots, modes.frequencies_hz)
    meta = {
        "frequencies_hz": modes.frequencies_hz.tolist(),
        "n_boxes": int(panels.n),
        "n_lags": int(n_lags),
        "spline": spline,
        "units": "ft, slug, s",
        METADATA_KEY: "ft-slug-s",  # the built-in Goland planform's (ft)
    }
    return AeroData(gaf, rfa, meta, incidence)


def build(
    fe,
    mach: float = 0.7,
    n_modes: int = 9,
    n_lags: int = 13,
    k_list=GOLAND_K_LIST,
    panels: AeroPanels | None = None,
    kernel: str = "quartic",
    rfa_kind: str = "minimum-state",
    progress=None,
) -> AeroData:
    """``tr.aero.build(fe, mach=0.7, n_modes=9, n_lags=13)`` (DESIGN Python API)."""
    modes = modal_data(fe, n_modes)
    if panels is None:  # the built-in planform, in the wing's own axes
        modes = planform_modes(fe, modes)
    data = build_from_modes(
        modes, mach, n_lags, k_list, panels, None, kernel, rfa_kind, progress=progress
    )
    data.metadata["source"] = str(getattr(fe, "source", ""))
    return data


def build_from_deck(
    path,
    fe,
    mach: float,
    n_modes: int,
    n_lags: int = 13,
    k_list=None,
    kernel: str = "quartic",
    rfa_kind: str = "minimum-state",
    progress=None,
    speeds=None,
    includes=(),
) -> AeroData:
    """GAF + RFA with the deck's CAERO1 boxes and SPLINE1/SPLINE2 cards (AERO SYMXZ honoured);
    ``includes``: files of cards read as if INCLUDEd (``--panels``).

    Default reduced frequencies: chosen to cover the flutter range of the modes, the deck's
    MKAERO values at the nearest Mach number among them, and the RFA fitted on those that
    matter (:mod:`torchrom.aero.reduced_frequencies`; ``speeds``: the speed range, deck length
    unit per s). ``k_list`` (k = 0 is always added for the A0 = Q(0) constraint) replaces the
    table, and the RFA is fitted on all of it. Either way the fit is checked where it matters;
    the survey, its check and any warning are ``metadata["reduced_frequencies"]``.
    """
    from . import reduced_frequencies as rf
    from .nastran_flutter import load_deck

    deck = load_deck(path, require_flutter=False, includes=includes)
    modes = modal_data(fe, n_modes)
    motion = with_incidence(deck.box_motion(modes.grid_ids, modes.displacements),
                            deck.aero_panels)
    system = recorded_units(getattr(fe, "units", None) or {})
    listed = []
    if deck.mkaero:
        near = min({m for m, _ in deck.mkaero}, key=lambda m: abs(m - mach))
        listed = [k for m, k in deck.mkaero if m == near]
    survey = rf.plan(modes.frequencies_hz, deck.reference.semichord,
                     *rf.deck_density(deck, system), listed_k=listed,
                     flutter_velocities=[v for c in deck.cases if c.method.startswith("PK")
                                         for v in c.values],
                     speeds=speeds, k_list=k_list)
    gaf, incidence = split_incidence(compute_gaf(
        deck.aero_panels, motion, mach, survey.k_table, deck.reference.semichord, kernel,
        progress=progress))
    rfa = rf.fit_and_check(
        survey, gaf, lambda g: _fit(g, n_lags, rfa_kind, False, modes.frequencies_hz),
        cut=k_list is None)
    meta = {
        "frequencies_hz": modes.frequencies_hz.tolist(),
        "n_boxes": int(deck.aero_panels.n),
        "n_lags": int(n_lags),
        "source": str(path),
        "reduced_frequencies": survey.as_dict(),
    }
    if system is not None:  # the deck's, as the modes' and the boxes' lengths
        meta[METADATA_KEY] = system.name
    return AeroData(gaf, rfa, meta, incidence)


def _with_zero(k_list) -> list[float]:
    """The reduced frequencies with k = 0 (the RFA's A0 = Q(0) and the incidence's load)."""
    return sorted({0.0, *(float(k) for k in k_list)})


#: entry-weight floor of the minimum-state fit relative to the largest |Q_ij|. REFERENCE's
#: 1/max(|Q_ij|, 1) assumes GAFs of order 1..100; with mass-normalised modes in ft-slug units
#: the Goland GAFs are O(1), where an absolute floor of 1 would weight all entries alike.
RELATIVE_WEIGHT_FLOOR = 1e-2
#: residual weighting of the minimum-state fit ("point": relative error at every k; with
#: Karpel's per-entry weights the 13-lag Goland fit misses the low-k GAFs near the flutter point
#: by ~1 %, which moves the state-space flutter altitude ~1.2 % from p-k)
RFA_WEIGHTING = "point"


def _fit(gaf, n_lags, rfa_kind, optimize_roots, frequencies_hz):
    """The RFA of ``gaf``; a free structure's rigid-body columns (0 Hz modes) then take the
    table's quasi-steady slope (:func:`~torchrom.aero.rfa.impose_quasi_steady_slope`: the
    fit alone splits the free aircraft's double root s = 0 into a spurious divergence)."""
    floor = 1.0
    if rfa_kind == "minimum-state":
        floor = RELATIVE_WEIGHT_FLOOR * float(np.abs(gaf.Q).max())
        rfa = fit_minimum_state(
            gaf,
            n_lags=n_lags,
            optimize_roots=optimize_roots,
            weight_floor=floor,
            weighting=RFA_WEIGHTING,
        )
    elif rfa_kind == "roger":
        rfa = fit_roger(gaf, n_lags=n_lags)
    else:
        raise InputError(f"aero: rfa: expected 'minimum-state' or 'roger', got {rfa_kind!r}")
    rigid = rigid_body_modes(frequencies_hz)
    if len(rigid) == gaf.n_modes and rigid.any() and not rigid.all():
        rfa = impose_quasi_steady_slope(rfa, gaf, rigid, floor)
        rfa.fit_error["rigid_slope_k"] = quasi_steady_slope(gaf)[1]
    return rfa


def flutter_altitude(
    rom_or_structure,
    aero: AeroData,
    mach: float | None = None,
    alpha: float = BASELINE_ALPHA,
    gamma: float = BASELINE_GAMMA,
    alt_range=(0.0, 40000.0),
    method: str = "state-space",
    units: str = "ft",
    n_grid: int = 41,
    altitude_unit: str | None = None,
) -> MatchedPointResult:
    """Flutter altitude at fixed Mach (DESIGN Python API): ``method`` 'state-space' or 'p-k';
    ``alt_range`` and the result's altitude in ``altitude_unit`` ("m" or "ft"; default the
    system's altitude unit, ft for ``units="ft"``)."""
    if isinstance(rom_or_structure, ModalStructure):
        st = rom_or_structure.with_damping(alpha, gamma)
    else:
        st = ModalStructure.from_rom(rom_or_structure, aero.n_modes, alpha, gamma)
    mach = aero.mach if mach is None else float(mach)
    if abs(mach - aero.mach) > 1e-9:
        raise InputError(
            f"flutter: mach {mach:g} differs from the GAF Mach {aero.mach:g} of the aero file"
        )
    if method == "state-space":
        return flutter_altitude_state_space(st, aero.rfa, mach, alt_range, n_grid, units,
                                            altitude_unit=altitude_unit)
    if method == "p-k":
        return flutter_altitude_pk(st, AeroTable.from_gaf(aero.gaf), mach, alt_range, n_grid,
                                   units, altitude_unit=altitude_unit)
    raise InputError(f"flutter: method: expected 'state-space' or 'p-k', got {method!r}")


def structure_from_rom_file(path, n_modes: int, alpha: float, gamma: float) -> ModalStructure:
    """Linear part (M, K1, D̄1) of a ``rom.npz`` (NonlinearROM) on its first m basis functions."""
    from ..rom import NonlinearROM

    return structure_from_rom(NonlinearROM.load(path), n_modes, alpha, gamma, path)


def structure_from_rom(rom, n_modes: int, alpha: float, gamma: float,
                       where="ROM") -> ModalStructure:
    """Linear part (M, K1, D̄1) of a NonlinearROM on its first ``n_modes`` basis functions
    (InputError naming ``where`` when it has fewer)."""
    if rom.n < n_modes:
        raise InputError(
            f"{where}: the ROM has {rom.n} basis functions, the aero file {n_modes} modes"
        )
    return ModalStructure.from_rom(rom, n_modes, alpha, gamma)
