"""Aerodynamic boxes: CAERO1-style lattices, the built-in Goland planform, full-span mirroring.

Written here: box geometry (corner points, quarter/half/three-quarter chord points, normals,
areas), the CAERO1 lattice (equal NSPAN/NCHORD divisions or AEFACT fractions), mirroring about
the xz plane (AERO SYMXZ) and the xy plane (SYMXY, ground effect), and the conversion to the
``aerogrid`` dictionary that PanelAero expects.
Delegated: reading CAERO1/PAERO1/AEFACT/AERO/AEROS cards and coordinate systems (pyNastran).

Conventions (REFERENCE Sec. 7): every box is stored *left to right* — corners
``[LE-left, TE-left, TE-right, LE-right]`` with ``y_left < y_right`` — because PanelAero's
doublet-lattice kernel assumes it (a flipped box gets a flipped normal). Full-span models are
built by mirroring the half wing (PanelAero's own ``xz_symmetry=True`` path disagrees with an
explicit full-span model); ``source`` maps every box to the half-wing box whose motion it
follows, and ``mirrored`` marks the image boxes so that symmetric (h' = h) or antisymmetric
(h' = -h) mode shapes can be applied.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..bounds import check_boxes
from ..errors import InputError

#: built-in Goland planform (paper Sec. III.A: classic Goland chord 6 ft, 20 ft semispan)
GOLAND_CHORD_FT = 6.0
GOLAND_SEMISPAN_FT = 20.0


@dataclass(frozen=True)
class AeroReference:
    """Reference quantities of an aerodynamic model (AERO/AEROS cards or a built-in planform).

    ``chord`` is the reference chord c (AERO REFC); the reduced frequency is k = ω b / V with
    the reference semichord ``semichord`` b = c/2 (Nastran/ZAERO convention).
    ``symxz``: 0 none, +1 symmetric, -1 antisymmetric about the xz plane (mirrored image).
    ``symxy``: 0 none, -1 symmetric about the xy plane of the aero system (ground effect: the
    image is the mirror image, with the opposite circulation), +1 antisymmetric; MSC QRG AERO/
    AEROS: "SYMXY = -1 for symmetry, 0 for no symmetry, +1 for antisymmetry", the opposite
    sign convention to SYMXZ.
    """

    chord: float
    span: float | None = None
    area: float | None = None
    rho_ref: float = 1.0
    symxz: int = 0
    velocity: float | None = None
    symxy: int = 0

    @property
    def semichord(self) -> float:
        return 0.5 * self.chord


@dataclass
class AeroPanels:
    """A set of trapezoidal aerodynamic boxes (quadrilaterals), stored left to right.

    corners:   (n, 4, 3) basic coordinates [LE-left, TE-left, TE-right, LE-right]
    box_ids:   (n,) Nastran box ids (CAERO EID + running index, chordwise first); image boxes
               of a mirrored model carry the negative id of their source box
    caero_ids: (n,) id of the CAERO card (or built-in macro panel) each box belongs to
    source:    (n,) index of the half-model box whose motion each box follows (itself if not
               mirrored)
    mirrored:  (n,) True for image boxes (created by :meth:`mirror` or :meth:`mirror_xy`)
    xz_image:  (n,) True for images about the xz plane (:meth:`mirror`, and their xy images)
    xy_image:  (n,) True for images about the xy plane (:meth:`mirror_xy`)
    """

    corners: np.ndarray
    box_ids: np.ndarray
    caero_ids: np.ndarray
    source: np.ndarray = field(default=None)  # type: ignore[assignment]
    mirrored: np.ndarray = field(default=None)  # type: ignore[assignment]
    xz_image: np.ndarray = field(default=None)  # type: ignore[assignment]
    xy_image: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self):
        self.corners = np.asarray(self.corners, dtype=float).reshape(-1, 4, 3)
        n = len(self.corners)
        self.box_ids = np.asarray(self.box_ids, dtype=int).reshape(n)
        self.caero_ids = np.asarray(self.caero_ids, dtype=int).reshape(n)
        self.source = np.arange(n) if self.source is None else np.asarray(self.source, int)
        self.mirrored = (
            np.zeros(n, bool) if self.mirrored is None else np.asarray(self.mirrored, bool)
        )
        self.xy_image = (
            np.zeros(n, bool) if self.xy_image is None else np.asarray(self.xy_image, bool)
        )
        # an image not marked otherwise is an xz image (the only kind before xy images)
        self.xz_image = (
            self.mirrored & ~self.xy_image if self.xz_image is None
            else np.asarray(self.xz_image, bool)
        )
        if self.areas.min(initial=np.inf) <= 0.0:
            bad = int(np.argmin(self.areas))
            raise InputError(f"aero box {self.box_ids[bad]}: zero or negative area")

    # -- geometry -------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.corners)

    def _chord_point(self, fraction: float) -> np.ndarray:
        le = 0.5 * (self.corners[:, 0] + self.corners[:, 3])
        te = 0.5 * (self.corners[:, 1] + self.corners[:, 2])
        return le + fraction * (te - le)

    @property
    def doublet_points(self) -> np.ndarray:
        """Quarter-chord points at mid-span (doublet line / load point), (n, 3)."""
        return self._chord_point(0.25)

    @property
    def centers(self) -> np.ndarray:
        """Mid-chord points at mid-span, (n, 3)."""
        return self._chord_point(0.5)

    @property
    def control_points(self) -> np.ndarray:
        """Three-quarter-chord points at mid-span (normalwash / collocation points), (n, 3)."""
        return self._chord_point(0.75)

    @property
    def vortex_left(self) -> np.ndarray:
        """Left end of the quarter-chord line, (n, 3)."""
        c = self.corners
        return c[:, 0] + 0.25 * (c[:, 1] - c[:, 0])

    @property
    def vortex_right(self) -> np.ndarray:
        """Right end of the quarter-chord line, (n, 3)."""
        c = self.corners
        return c[:, 3] + 0.25 * (c[:, 2] - c[:, 3])

    def _diagonal_cross(self) -> np.ndarray:
        c = self.corners
        return np.cross(c[:, 2] - c[:, 0], c[:, 3] - c[:, 1])

    @property
    def normals(self) -> np.ndarray:
        """Unit normals (+z for a left-to-right box in the xy plane), (n, 3)."""
        d = self._diagonal_cross()
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    @property
    def areas(self) -> np.ndarray:
        return 0.5 * np.linalg.norm(self._diagonal_cross(), axis=1)

    @property
    def chords(self) -> np.ndarray:
        """Box chord at mid-span, (n,)."""
        return np.linalg.norm(self._chord_point(1.0) - self._chord_point(0.0), axis=1)

    def to_panelaero(self) -> dict:
        """PanelAero's ``aerogrid`` dictionary (fresh arrays: PanelAero scales x in place)."""
        return {
            "offset_j": self.control_points.copy(),
            "offset_k": self.centers.copy(),
            "offset_l": self.doublet_points.copy(),
            "offset_P1": self.vortex_left.copy(),
            "offset_P3": self.vortex_right.copy(),
            "N": self.normals.copy(),
            "A": self.areas.copy(),
            "l": self.chords.copy(),
            "n": self.n,
        }

    # -- construction -----------------------------------------------------------------------
    def mirror(self) -> AeroPanels:
        """Full-span model: the xz-plane image boxes (left half, tip to root) then these boxes.

        The image of a left-to-right box is again stored left to right (its left and right edges
        swap), so every normal keeps pointing up.
        """
        if np.any(self.mirrored):
            raise InputError("aero panels: already a full-span (mirrored) model")
        img = self.corners[:, [3, 2, 1, 0], :].copy()
        img[:, :, 1] *= -1.0
        order = np.argsort(-self.centers[:, 1], kind="stable")  # left tip first
        return AeroPanels(
            corners=np.concatenate([img[order], self.corners]),
            box_ids=np.concatenate([-self.box_ids[order], self.box_ids]),
            caero_ids=np.concatenate([self.caero_ids[order], self.caero_ids]),
            source=np.concatenate([order, np.arange(self.n)]),
            mirrored=np.concatenate([np.ones(self.n, bool), np.zeros(self.n, bool)]),
        )

    def mirror_xy(self) -> AeroPanels:
        """These boxes and their images about the xy plane (z -> -z), appended.

        The image of a box is stored with the same corner order: it stays left to right and a
        horizontal box keeps its +z normal (the computed normal of a mirrored box is minus the
        mirror of the normal). So the mirror image of a motion (ground effect) has h' = -h on
        the image box: ``box_motion(..., xy_sign=-1)``, Nastran's SYMXY = -1.
        """
        if np.any(self.xy_image):
            raise InputError("aero panels: already mirrored about the xy plane")
        size = float(np.abs(self.corners).max(initial=0.0)) or 1.0
        in_plane = np.all(np.abs(self.corners[:, :, 2]) <= 1e-9 * size, axis=1)
        if np.any(in_plane):
            first = np.argmax(in_plane & ~self.mirrored) if np.any(
                in_plane & ~self.mirrored) else np.argmax(in_plane)
            raise InputError(
                f"aero box {self.box_ids[first]}: lies in the xy plane of the aero "
                "system (z = 0), where it coincides with its SYMXY image: expected boxes off it"
            )
        img = self.corners.copy()
        img[:, :, 2] *= -1.0
        return AeroPanels(
            corners=np.concatenate([self.corners, img]),
            box_ids=np.concatenate([self.box_ids, -np.abs(self.box_ids)]),
            caero_ids=np.concatenate([self.caero_ids, self.caero_ids]),
            source=np.concatenate([self.source, self.source]),
            mirrored=np.concatenate([self.mirrored, np.ones(self.n, bool)]),
            xz_image=np.concatenate([self.xz_image, self.xz_image]),
            xy_image=np.concatenate([np.zeros(self.n, bool), np.ones(self.n, bool)]),
        )

    def box_motion(self, values: np.ndarray, antisymmetric: bool = False,
                   xy_sign: int = 1) -> np.ndarray:
        """Spread per-source-box values (..., n_source) onto these boxes (..., n).

        xz image boxes get +values (symmetric) or -values (``antisymmetric`` mode shapes); xy
        image boxes are multiplied by ``xy_sign`` (-1: the mirror image of the motion, ground
        effect, SYMXY = -1; +1: SYMXY = +1).
        """
        out = np.asarray(values)[..., self.source]
        if antisymmetric:
            out = np.where(self.xz_image, -out, out)
        if xy_sign == -1:
            out = np.where(self.xy_image, -out, out)
        elif xy_sign != 1:
            raise InputError(f"aero panels: xy_sign: expected -1 or 1, got {xy_sign!r}")
        return out

    @staticmethod
    def concatenate(parts: list[AeroPanels]) -> AeroPanels:
        if not parts:
            raise InputError("aero panels: no CAERO1 boxes")
        offsets = np.cumsum([0] + [p.n for p in parts[:-1]])
        return AeroPanels(
            corners=np.concatenate([p.corners for p in parts]),
            box_ids=np.concatenate([p.box_ids for p in parts]),
            caero_ids=np.concatenate([p.caero_ids for p in parts]),
            source=np.concatenate([p.source + o for p, o in zip(parts, offsets)]),
            mirrored=np.concatenate([p.mirrored for p in parts]),
            xz_image=np.concatenate([p.xz_image for p in parts]),
            xy_image=np.concatenate([p.xy_image for p in parts]),
        )


#: an AEFACT's end fractions within this of 0 and 1 are the panel's edges: a small-field
#: (8-character) AEFACT carries 7 significant digits, so 1.0 is written .9999999 when the list
#: is normalised by a pre-processor (pyNastran's fmondsp deck, CAERO1 107001)
FRACTION_TOL = 1e-6


def lattice(
    p1,
    p2,
    p3,
    p4,
    chord_fractions,
    span_fractions,
    first_box_id: int = 1,
    caero_id: int = 1,
) -> AeroPanels:
    """Boxes of a CAERO1 macro panel (bilinear in the corner points).

    p1, p4: leading-edge points of the inboard and outboard edges; p2, p3: the trailing-edge
    points of the same edges. Fractions run 0..1 (equal divisions or AEFACT lists). Boxes are
    numbered chordwise first, strip by strip from p1 towards p4 (Nastran's order).
    """
    p1, p2, p3, p4 = (np.asarray(p, dtype=float) for p in (p1, p2, p3, p4))
    xc = np.array(chord_fractions, dtype=float)  # copies: the ends are set below
    ys = np.array(span_fractions, dtype=float)
    for name, f in (("chord", xc), ("span", ys)):
        if (len(f) < 2 or np.any(np.diff(f) <= 0) or abs(f[0]) > FRACTION_TOL
                or abs(f[-1] - 1) > FRACTION_TOL):
            raise InputError(
                f"CAERO1 {caero_id}: {name} divisions: expected increasing fractions from 0 to 1, "
                f"got {np.round(f, 6).tolist()}"
            )
        f[0], f[-1] = 0.0, 1.0  # the ends as the edges they are (an AEFACT's .9999999)
    check_boxes(f"CAERO1 {caero_id}", (len(xc) - 1) * (len(ys) - 1))

    def point(s, c):  # s spanwise, c chordwise fraction
        le = p1 + s * (p4 - p1)
        te = p2 + s * (p3 - p2)
        return le + c * (te - le)

    corners = []
    for j in range(len(ys) - 1):
        for i in range(len(xc) - 1):
            corners.append(
                [
                    point(ys[j], xc[i]),
                    point(ys[j], xc[i + 1]),
                    point(ys[j + 1], xc[i + 1]),
                    point(ys[j + 1], xc[i]),
                ]
            )
    corners = np.asarray(corners)
    # Store left to right (inboard may be at larger y, e.g. a left wing defined root first).
    span_dir = (p4 - p1) / np.linalg.norm(p4 - p1)
    axis = 1 if abs(span_dir[1]) >= abs(span_dir[2]) else 2
    if span_dir[axis] < 0:
        corners = corners[:, [3, 2, 1, 0], :]
    n = len(corners)
    return AeroPanels(
        corners=corners,
        box_ids=first_box_id + np.arange(n),
        caero_ids=np.full(n, caero_id),
    )


def rectangular_wing(
    chord: float,
    semispan: float,
    n_chord: int,
    n_span: int,
    x_le: float = 0.0,
    full_span: bool = True,
    first_box_id: int = 1001,
) -> AeroPanels:
    """Flat rectangular wing in the xy plane, root at y = 0 (mirrored if ``full_span``)."""
    if chord <= 0 or semispan <= 0 or n_chord < 1 or n_span < 1:
        raise InputError(
            f"rectangular wing: expected positive chord/semispan and box counts, got "
            f"chord={chord}, semispan={semispan}, n_chord={n_chord}, n_span={n_span}"
        )
    half = lattice(
        (x_le, 0.0, 0.0),
        (x_le + chord, 0.0, 0.0),
        (x_le + chord, semispan, 0.0),
        (x_le, semispan, 0.0),
        np.linspace(0.0, 1.0, n_chord + 1),
        np.linspace(0.0, 1.0, n_span + 1),
        first_box_id=first_box_id,
        caero_id=first_box_id,
    )
    return half.mirror() if full_span else half


def goland_panels(n_chord: int = 8, n_span: int = 20, full_span: bool = True) -> AeroPanels:
    """Built-in Goland planform: chord 6 ft, semispan 20 ft, leading edge at x = 0 (ft)."""
    return rectangular_wing(GOLAND_CHORD_FT, GOLAND_SEMISPAN_FT, n_chord, n_span, 0.0, full_span)


def goland_reference() -> AeroReference:
    """Reference chord 6 ft (b = 3 ft), full span 40 ft, area 240 ft² of the Goland wing."""
    return AeroReference(
        chord=GOLAND_CHORD_FT,
        span=2 * GOLAND_SEMISPAN_FT,
        area=2 * GOLAND_SEMISPAN_FT * GOLAND_CHORD_FT,
        symxz=1,
    )


# -- Nastran cards ---------------------------------------------------------------------------
@dataclass(frozen=True)
class AeroFrame:
    """The aerodynamic coordinate system (AERO/AEROS ACSID): the flow runs along its +x axis.

    ``axes`` rows are its x, y, z unit vectors in basic, ``origin`` its origin in basic. The
    doublet-lattice method (PanelAero) assumes the flow along +x, so a deck's boxes, spline
    grids and grid displacements are expressed in this frame before the DLM sees them.
    """

    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))

    def points(self, xyz) -> np.ndarray:
        """Basic positions (..., 3) → aero-frame positions."""
        return (np.asarray(xyz, dtype=float) - self.origin) @ self.axes.T

    def vectors(self, v) -> np.ndarray:
        """Basic vector components (..., 3) → aero-frame components."""
        return np.asarray(v, dtype=float) @ self.axes.T


def read_aero_frame(model, path: str = "deck") -> AeroFrame:
    """ACSID of the AERO card (AEROS as a fallback); basic when blank or 0."""
    card = model.aero if model.aero is not None else model.aeros
    cid = int(getattr(card, "acsid", 0) or 0) if card is not None else 0
    if not cid:
        return AeroFrame()
    coord = model.coords.get(cid)
    if coord is None:
        raise InputError(f"{path}: {card.type}: field ACSID: coordinate system {cid} not found")
    if coord.type[-1] != "R":
        raise InputError(f"{path}: {card.type}: field ACSID: expected a rectangular system, got "
                         f"{coord.type} {cid}")
    return AeroFrame(np.asarray(coord.origin, dtype=float), np.asarray(coord.beta(), dtype=float))


def _to_basic(model, cid: int, xyz, where: str) -> np.ndarray:
    xyz = np.asarray(xyz, dtype=float)
    if not cid:
        return xyz
    coord = model.coords.get(cid)
    if coord is None:
        raise InputError(f"{where}: coordinate system {cid} not found")
    return coord.transform_node_to_global(xyz)


def _fractions(model, n_div: int, aefact_id: int, where: str, name: str) -> np.ndarray:
    if n_div and n_div > 0:
        return np.linspace(0.0, 1.0, n_div + 1)
    if not aefact_id:
        raise InputError(f"{where}: {name}: expected NSPAN/NCHORD > 0 or an AEFACT id")
    aefact = model.aefacts.get(aefact_id)
    if aefact is None:
        raise InputError(f"{where}: {name}: AEFACT {aefact_id} not found")
    return np.asarray(aefact.fractions, dtype=float)


def read_caero1(model, path: str = "deck", frame: AeroFrame | None = None) -> AeroPanels:
    """All CAERO1 boxes of a pyNastran model (coordinates already cross-referenced), in the
    aerodynamic frame ``frame`` (default: AERO/AEROS ACSID), where the chords X12, X43 run along
    +x (MSC QRG, CAERO1).

    Checks that every CAERO1 has its PAERO1 and that box ids do not overlap; other CAERO
    types are refused with a one-line error.
    """
    others = sorted({c.type for c in model.caeros.values() if c.type != "CAERO1"})
    if others:
        # CAERO2 bodies, CAERO3 Mach box, CAERO4/PAERO4 strip theory (Theodorsen), CAERO5 piston
        # theory: other aerodynamic theories, not implemented
        theory = {"CAERO2": "slender-body", "CAERO3": "Mach box", "CAERO4": "strip theory",
                  "CAERO5": "piston theory"}.get(others[0], "a non-DLM")
        raise InputError(f"{path}: {others[0]} ({theory} aerodynamics) is not supported: only "
                         f"CAERO1 doublet-lattice boxes are; model the lifting surfaces with "
                         f"CAERO1/PAERO1 instead")
    frame = read_aero_frame(model, path) if frame is None else frame
    parts = []
    for eid in sorted(model.caeros):
        c = model.caeros[eid]
        where = f"{path}: CAERO1 {eid}"
        if c.pid not in model.paeros:
            raise InputError(f"{where}: PAERO1 {c.pid} not found")
        if model.paeros[c.pid].type != "PAERO1":
            raise InputError(
                f"{where}: property {c.pid} is a {model.paeros[c.pid].type}, not PAERO1"
            )
        cp = c.cp if isinstance(c.cp, int) else c.cp.cid
        p1 = frame.points(_to_basic(model, cp, c.p1, where))
        p4 = frame.points(_to_basic(model, cp, c.p4, where))
        if c.x12 < 0 or c.x43 < 0 or (c.x12 == 0 and c.x43 == 0):
            raise InputError(
                f"{where}: X12/X43: expected non-negative chords, got {c.x12}, {c.x43}"
            )
        # Chords run along the x axis of the aerodynamic system (ACSID).
        p2 = p1 + np.array([c.x12, 0.0, 0.0])
        p3 = p4 + np.array([c.x43, 0.0, 0.0])
        xc = _fractions(model, c.nchord, c.lchord, where, "chordwise divisions")
        ys = _fractions(model, c.nspan, c.lspan, where, "spanwise divisions")
        parts.append(lattice(p1, p2, p3, p4, xc, ys, first_box_id=eid, caero_id=eid))
    panels = AeroPanels.concatenate(parts)
    ids, counts = np.unique(panels.box_ids, return_counts=True)
    if np.any(counts > 1):
        raise InputError(f"{path}: CAERO1: box id {ids[counts > 1][0]} is used by two CAERO1 cards")
    return panels


def read_aero_reference(model, path: str = "deck") -> AeroReference:
    """Reference chord, density and symmetry from the AERO card (AEROS as a fallback)."""
    card = model.aero if model.aero is not None else model.aeros
    if card is None:
        raise InputError(
            f"{path}: AERO: card not found (needed for the reference chord and density)"
        )
    if not card.cref or card.cref <= 0:
        raise InputError(
            f"{path}: {card.type}: REFC: expected a positive reference chord, got {card.cref}"
        )
    symxy = getattr(card, "sym_xy", 0) or 0
    if symxy not in (-1, 0, 1):
        raise InputError(f"{path}: {card.type}: SYMXY: expected -1 (ground effect), 0 or +1, "
                         f"got {card.sym_xy}")
    if (card.sym_xz or 0) not in (-1, 0, 1):
        raise InputError(f"{path}: {card.type}: SYMXZ: expected -1, 0 or +1, got {card.sym_xz}")
    if card.type == "AERO":
        return AeroReference(
            chord=float(card.cref),
            rho_ref=float(card.rho_ref) if card.rho_ref else 1.0,
            symxz=int(card.sym_xz or 0),
            velocity=float(card.velocity) if card.velocity else None,
            symxy=int(symxy),
        )
    return AeroReference(
        chord=float(card.cref),
        span=float(card.bref) if card.bref else None,
        area=float(card.sref) if card.sref else None,
        symxz=int(card.sym_xz or 0),
        symxy=int(symxy),
    )


def read_model(path, includes=()) -> object:
    """A pyNastran model of ``path`` with grids and coordinate systems cross-referenced;
    ``includes``: files of cards read as if INCLUDEd at the deck's end
    (:func:`torchrom.fe.bdf_read.with_includes`).

    Nothing else is cross-referenced, so that missing aero references are reported by torchrom's
    own checks as one-line errors naming the card and id.
    """
    import contextlib
    import io
    from pathlib import Path

    from pyNastran.bdf.bdf import read_bdf

    from ..checks import expect_text_file
    from ..fe.bdf_checks import card_error_message, check_complete, check_fields

    path = Path(path)
    expect_text_file(path, "a Nastran deck", "model.bdf")
    check_complete(path.read_text(errors="replace"), path.name)
    from ..fe.bdf_read import check_include_files, with_includes

    check_include_files(includes)
    try:
        # pyNastran prints some errors' details on stdout: the one line below says it
        with contextlib.redirect_stdout(io.StringIO()):
            if includes:
                text = with_includes(path.read_text(errors="replace"), includes)
                with contextlib.chdir(path.resolve().parent):
                    model = read_bdf(io.StringIO(text), xref=False, debug=None, validate=True)
            else:
                model = read_bdf(str(path), xref=False, debug=None, validate=True)
    except Exception as exc:  # noqa: BLE001 - pyNastran raises many types; one line to the user
        known = card_error_message(path.name, exc, _first_line(exc))
        raise InputError(known or f"{path}: cannot read the deck: {_first_line(exc)}") from None
    from ..fe.bdf_cards import apply_grdset

    apply_grdset(model)  # GRDSET CP before the grid positions are resolved
    try:
        model.cross_reference(
            xref=True,
            xref_nodes=True,
            xref_elements=False,
            xref_properties=False,
            xref_masses=False,
            xref_materials=False,
            xref_loads=False,
            xref_constraints=False,
            xref_aero=False,
            xref_sets=False,
            xref_optimization=False,
        )
    except Exception as exc:  # noqa: BLE001
        known = card_error_message(path.name, exc, _first_line(exc))
        raise InputError(known or f"{path}: GRID/coordinate systems: {_first_line(exc)}"
                         ) from None
    check_fields(model, path.name, aero=True)
    return model


def _first_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
