"""Beam section properties of PBAR, PBARL, PBEAM and PBEAML as the linear beam element uses them.

Delegated to pyNastran: the area and the two area moments of the PBARL/PBEAML sections it
computes (``PBARL.Area()``, ``I1()``, ``I2()``, ``I12()``: ROD, TUBE, BAR, BOX, L). Written
here: I, T and CHAN (pyNastran 1.4 does not compute their moments) as unions of
rectangles (:func:`rectangles`), and the torsion constant J of every section, because pyNastran
returns the polar moment I1 + I2 for solid rectangles and nothing for several sections, while
Nastran uses the St Venant torsion constant:

- ROD (r): J = π r⁴ / 2; TUBE (r_o, r_i): J = π (r_o⁴ − r_i⁴) / 2 (exact);
- BAR (b, h): J = a c³ [1/3 − 0.21 (c/a)(1 − c⁴/(12 a⁴))], a = max(b, h), c = min(b, h)
  (Roark, Table 10.7 case 4; 0.5 % of the series solution);
- BOX (w, h, t_side, t_top): Bredt's thin-walled closed section J = 4 A_m² / ∮ ds/t on the
  wall mid-line;
- I, T, L, CHAN (thin-walled open): J = Σ b_i t_i³ / 3 over the flanges and the web (mid-line
  lengths).

A tapered PBEAM (stations X/XB with different A, I1, I2, I12, J, NSM; blank intermediate values
are pyNastran's linear interpolation of the neighbours, a blank end B is end A) or PBEAML
(section properties of each station's dimensions) gives a :class:`~torchrom.fe.mesh.Taper`:
each property linear between stations, and NSI(A)/NSI(B) linear along the element
(:mod:`torchrom.fe.elements.bar` integrates them). PBEAM N1(A), N2(A), N1(B), N2(B), the
(y, z) of the neutral axis relative to the shear centre in the element system (MSC QRG PBEAM;
B defaults to A), are :attr:`Section.na` (:func:`torchrom.fe.elements.bar.neutral_axis_links`
applies them). PBEAM fields that would change the answer and are not modelled are refused:
shear relief S1/S2, and the offset M1/M2 of a non-structural mass. Shear flexibility:
PBAR/PBEAM K1, K2 as given (PBAR blank: none; PBEAM default 1.0); library sections:
:func:`library_shear_factors`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .mesh import Taper


@dataclass(frozen=True)
class Section:
    """Prismatic section: area, I1 (plane 1), I2 (plane 2), I12, J, non-structural mass, and
    the shear area factors K1, K2 (0: no shear flexibility)."""

    A: float
    I1: float
    I2: float
    I12: float
    J: float
    nsm: float
    mid: int
    k1: float = 0.0
    k2: float = 0.0
    #: along a tapered PBEAM/PBEAML (or one with NSI); None: prismatic
    taper: Taper | None = None
    #: PBEAM neutral axis (N1A, N2A, N1B, N2B): its (y, z) relative to the shear centre at
    #: ends A and B, element system (length units)
    na: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)


#: Shear area factors Nastran gives library sections, found by matching MSC Nastran's f06:
#: ROD 0.9 (pyNastran's beam_modes deck, CBAR and CBEAM, all 10 modes to 1e-6) and BAR 5/6
#: (ExportNastranKM's test_case, 10 modes to 1e-5); TUBE 0.5, the thin-walled tube's (with
#: BOX below, pyNastran's fmondsp glider: 12 elastic modes from up to +2.2 % to within 0.11 %);
#: T and BOX: :func:`library_shear_factors`; other sections: not known here, so their shear
#: flexibility is left out, with a note.
LIBRARY_SHEAR_FACTOR = {"ROD": 0.9, "BAR": 5.0 / 6.0, "TUBE": 0.5}
#: PBARL/PBEAML section types with properties: pyNastran computes A, I1, I2, I12 of the first
#: five (its PBARL refuses the others), :func:`_open_section` those of I, T and CHAN
PYNASTRAN_SECTIONS = ("ROD", "TUBE", "BAR", "BOX", "L")
LIBRARY_SECTIONS = PYNASTRAN_SECTIONS + ("I", "T", "CHAN")


def library_shear_factors(kind: str, dim) -> tuple[float, float]:
    """K1, K2 of a library section: :data:`LIBRARY_SHEAR_FACTOR`; for T (DIM1 flange width,
    DIM2 height, DIM3 flange and DIM4 web thickness) the web's and the flange's share of the
    area, K1 = (DIM2 − DIM3) DIM4 / A, K2 = DIM1 DIM3 / A: NX Nastran's own PBAR equivalents of
    two T sections (0.46429/0.53571, 0.44444/0.55556) in the f06 of MSC's folding-wing example
    (pyNastran, aero/examples/nlfltr/case3/fict_mass.f06; NX 2007); for BOX (DIM1 width W along
    z, DIM2 height H along y, DIM3 top/bottom and DIM4 side thickness) likewise the walls along
    each shear between the others, K1 = 2 (H − 2 DIM3) DIM4 / A, K2 = 2 (W − 2 DIM4) DIM3 / A
    (MSC 2005 on pyNastran's fmondsp glider, a BOX wing, rudder and elevator: with TUBE's 0.5
    its 12 elastic modes within 0.11 %, two of them within 3e-4 %); 0, 0 (no shear
    flexibility) where not known."""
    if kind == "T":
        b, h, tf, tw = (float(x) for x in dim[:4])
        web, flange = (h - tf) * tw, b * tf
        return web / (web + flange), flange / (web + flange)
    if kind == "BOX":
        w, h, t_tb, t_side = (float(x) for x in dim[:4])
        area = w * h - (w - 2 * t_side) * (h - 2 * t_tb)
        return 2 * (h - 2 * t_tb) * t_side / area, 2 * (w - 2 * t_side) * t_tb / area
    k = LIBRARY_SHEAR_FACTOR.get(kind, 0.0)
    return k, k


def torsion_constant(kind: str, dim) -> float:
    """St Venant torsion constant of a PBARL/PBEAML section (see the module docstring)."""
    d = [float(x) for x in dim]
    if kind == "ROD":
        return np.pi * d[0] ** 4 / 2.0
    if kind == "TUBE":
        return np.pi * (d[0] ** 4 - d[1] ** 4) / 2.0
    if kind == "BAR":
        a, c = max(d[0], d[1]), min(d[0], d[1])
        return a * c**3 * (1.0 / 3.0 - 0.21 * (c / a) * (1.0 - c**4 / (12.0 * a**4)))
    if kind == "BOX":  # width (z), height (y), top/bottom wall t, side wall t
        w, h, t_tb, t_side = d[:4]
        wm, hm = w - t_side, h - t_tb  # mid-line rectangle
        return 4.0 * (wm * hm) ** 2 / (2.0 * wm / t_tb + 2.0 * hm / t_side)
    if kind == "I":  # depth, bottom flange width, top flange width, web t, bottom t, top t
        depth, b1, b2, tw, tf1, tf2 = d[:6]
        web = depth - 0.5 * (tf1 + tf2)
        return (b1 * tf1**3 + b2 * tf2**3 + web * tw**3) / 3.0
    if kind == "T":  # flange width, depth, flange t, web t
        b, depth, tf, tw = d[:4]
        return (b * tf**3 + (depth - 0.5 * tf) * tw**3) / 3.0
    if kind == "L":  # width, height, t (horizontal leg), t (vertical leg)
        b, h, t1, t2 = d[:4]
        return ((b - 0.5 * t2) * t1**3 + (h - 0.5 * t1) * t2**3) / 3.0
    if kind == "CHAN":  # width, depth, web t, flange t
        b, depth, tw, tf = d[:4]
        return (2.0 * (b - 0.5 * tw) * tf**3 + (depth - tf) * tw**3) / 3.0
    raise InputError(f"section {kind}: torsion constant not available (supported: "
                     f"{', '.join(LIBRARY_SECTIONS)})")


def rectangles(parts) -> tuple[float, float, float, float]:
    """A, I1, I2, I12 about the centroid of a union of rectangles (y_c, z_c, height along y,
    width along z): I1 = Σ (w h³/12 + a (y − ȳ)²) (plane 1, bending about z), I2 likewise about
    y, I12 = Σ a (y − ȳ)(z − z̄) (parallel-axis theorem)."""
    p = np.asarray(parts, dtype=float).reshape(-1, 4)
    y, z, h, w = p.T
    a = h * w
    A = a.sum()
    yc, zc = (a * y).sum() / A, (a * z).sum() / A
    I1 = (w * h**3 / 12.0 + a * (y - yc) ** 2).sum()
    I2 = (h * w**3 / 12.0 + a * (z - zc) ** 2).sum()
    I12 = (a * (y - yc) * (z - zc)).sum()
    return float(A), float(I1), float(I2), float(I12)


def _open_section(kind: str, d) -> tuple[float, float, float, float]:
    """I, T, CHAN of the MSC section library (dimension order of the MSC QRG, PBARL)."""
    if kind == "I":  # depth, bottom flange width, top flange width, web t, bottom t, top t
        depth, b1, b2, tw, tf1, tf2 = d[:6]
        web = depth - tf1 - tf2
        return rectangles([(tf1 / 2, 0.0, tf1, b1), (depth - tf2 / 2, 0.0, tf2, b2),
                           (tf1 + web / 2, 0.0, web, tw)])
    if kind == "T":  # flange width, depth, flange t, web t
        b, depth, tf, tw = d[:4]
        return rectangles([(depth - tf / 2, 0.0, tf, b), ((depth - tf) / 2, 0.0, depth - tf, tw)])
    # CHAN: flange width, depth, web t, flange t
    b, depth, tw, tf = d[:4]
    fl = b - tw
    return rectangles([(depth / 2, tw / 2, depth, tw), (tf / 2, tw + fl / 2, tf, fl),
                       (depth - tf / 2, tw + fl / 2, tf, fl)])


def _library(prop, kind: str, dim, owner: str) -> tuple[float, float, float, float]:
    """A, I1, I2, I12 of a library section (pyNastran's PBARL, or :func:`_open_section`)."""
    from pyNastran.bdf.cards.properties.bars import PBARL

    if kind not in LIBRARY_SECTIONS:
        raise InputError(f"{owner}: section {kind}: not supported (supported: "
                         f"{', '.join(LIBRARY_SECTIONS)})")
    if kind not in PYNASTRAN_SECTIONS:
        return _open_section(kind, [float(x) for x in dim])
    try:
        bar = PBARL(prop.pid, prop.mid, kind, list(dim))
        return float(bar.Area()), float(bar.I1()), float(bar.I2()), float(bar.I12() or 0.0)
    except (ValueError, TypeError, AssertionError) as exc:  # dimensions pyNastran refuses
        raise InputError(f"{owner}: section {kind} {list(dim)}: {exc}") from None


def section(prop, owner: str) -> Section:
    """The prismatic section of a PBAR, PBARL, PBEAM or PBEAML card."""
    t = prop.type
    if t == "PBAR":
        # PBAR K1, K2 blank: infinite shear stiffness (MSC QRG, PBAR)
        return Section(float(prop.A or 0.0), float(prop.i1 or 0.0), float(prop.i2 or 0.0),
                       float(prop.i12 or 0.0), float(prop.j or 0.0), float(prop.nsm or 0.0),
                       prop.mid, float(prop.k1 or 0.0), float(prop.k2 or 0.0))
    if t == "PBARL":
        A, I1, I2, I12 = _library(prop, prop.beam_type, prop.dim, owner)
        J = torsion_constant(prop.beam_type, prop.dim)
        k1, k2 = library_shear_factors(prop.beam_type, prop.dim)
        return Section(A, I1, I2, I12, J, float(prop.nsm or 0.0), prop.mid, k1, k2)
    if t == "PBEAML":
        dims = [list(d) for d in prop.dim]
        stations = [_library(prop, prop.beam_type, d, owner) for d in dims]
        J = [torsion_constant(prop.beam_type, d) for d in dims]
        nsm = np.asarray(prop.nsm if prop.nsm is not None else [0.0], float).reshape(-1)
        nsm = np.resize(nsm, len(dims)) if len(nsm) else np.zeros(len(dims))
        A, I1, I2, I12 = (np.array(v) for v in zip(*stations))
        k1, k2 = library_shear_factors(prop.beam_type, dims[0])
        taper = _taper(owner, prop.xxb, A, I1, I2, I12, np.array(J), nsm, 0.0, 0.0)
        return Section(float(A[0]), float(I1[0]), float(I2[0]), float(I12[0]), float(J[0]),
                       float(nsm[0]), prop.mid, k1, k2, taper)
    if t == "PBEAM":
        _refuse_pbeam_fields(prop, owner)
        vals = {name: np.asarray(getattr(prop, name), float).reshape(-1)
                for name in ("A", "i1", "i2", "i12", "j", "nsm")}
        taper = _taper(owner, prop.xxb, vals["A"], vals["i1"], vals["i2"], vals["i12"],
                       vals["j"], vals["nsm"], float(prop.nsia or 0.0),
                       float(prop.nsib if prop.nsib is not None else prop.nsia or 0.0))
        # PBEAM K1, K2: shear stiffness factors, default 1.0 (MSC QRG, PBEAM)
        k1 = 1.0 if prop.k1 is None else float(prop.k1)
        k2 = 1.0 if prop.k2 is None else float(prop.k2)
        a = {name: float(v[0]) if len(v) else 0.0 for name, v in vals.items()}
        return Section(a["A"], a["i1"], a["i2"], a["i12"], a["j"], a["nsm"], prop.mid, k1, k2,
                       taper, neutral_axis(prop))
    raise InputError(f"{owner}: expected PBAR, PBARL, PBEAM or PBEAML, got {t}")


def neutral_axis(prop) -> tuple[float, float, float, float]:
    """PBEAM N1(A), N2(A), N1(B), N2(B) (blank B: A's, MSC QRG PBEAM)."""
    a = [float(getattr(prop, n) or 0.0) for n in ("n1a", "n2a")]
    b = [float(a[k] if getattr(prop, n) is None else getattr(prop, n))
         for k, n in enumerate(("n1b", "n2b"))]
    return a[0], a[1], b[0], b[1]


def _refuse_pbeam_fields(prop, owner: str) -> None:
    """PBEAM fields that change the element but are not modelled: one-line refusals."""
    values = [float(getattr(prop, n) or 0.0) for n in ("s1", "s2")]
    if any(values):
        raise InputError(f"{owner}: fields S1, S2: shear relief coefficients S1/S2 are not "
                         f"supported (expected 0, got {values})")
    offsets = [float(getattr(prop, n) or 0.0) for n in ("m1a", "m2a", "m1b", "m2b")]
    if any(offsets) and np.any(np.asarray(prop.nsm, float)):
        raise InputError(f"{owner}: fields M1A-M2B: an offset non-structural mass is not "
                         f"supported (expected 0, got {offsets})")


def _taper(owner, xxb, A, I1, I2, I12, J, nsm, nsia, nsib) -> Taper | None:
    """The stations of a PBEAM/PBEAML as a Taper, or None if all stations are alike and NSI is
    uniform (the prismatic element)."""
    x = np.asarray(xxb, float).reshape(-1)
    props = [np.asarray(v, float).reshape(-1) for v in (A, I1, I2, I12, J, nsm)]
    if len(x) != len(props[0]) or len(x) < 1 or x[0] != 0.0:
        raise InputError(f"{owner}: field X/XB: expected stations from end A (0) to end B (1), "
                         f"got {list(x)}")
    if len(x) == 1:
        x, props = np.array([0.0, 1.0]), [np.repeat(p, 2) for p in props]
    if x[-1] != 1.0 or np.any(np.diff(x) <= 0.0):
        raise InputError(f"{owner}: field X/XB: expected increasing stations ending at end B "
                         f"(1.0), got {list(x)}")
    A, I1, I2, I12, J, nsm = props
    nsi = nsia + (nsib - nsia) * x
    taper = Taper(x, A, I1, I2, I12, J, nsm, nsi)
    if not taper.varies and np.allclose(nsm, nsm[0], rtol=1e-12, atol=0.0) and nsia == nsib == 0:
        return None
    if taper.varies and not (np.all(A > 0) and np.all(I1 * I2 > I12**2) and np.all(I1 > 0)
                             and (np.all(J > 0) or not np.any(J))):
        raise InputError(f"{owner}: tapered: expected A > 0, I1 > 0, I1 I2 > I12² and J > 0 "
                         f"(or J = 0 throughout) at each station {list(x)}, got A = {list(A)}, "
                         f"I1 = {list(I1)}, I2 = {list(I2)}, I12 = {list(I12)}, J = {list(J)}")
    return taper
