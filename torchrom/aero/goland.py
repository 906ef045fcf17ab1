"""The heavy Goland wing at Mach 0.70: flutter by p-k and state space, store calibration,
panel-density convergence (paper Sec. III.C, Table 3; REFERENCE Sec. 6).

Study glue over :func:`torchrom.fe.goland` (structure), :mod:`.build` (DLM GAF on
the built-in planform, minimum-state RFA) and :mod:`.flutter` (matched-point solvers).
The store's chordwise position is the one calibration knob for the flutter altitude
(REFERENCE Sec. 6); once fixed it is the FE default and everything here is a prediction.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy

from ..errors import ConvergenceError
from .build import (
    BASELINE_ALPHA,
    BASELINE_GAMMA,
    GOLAND_K_LIST,
    PAPER_FLUTTER_ALTITUDE_FT,
    PAPER_FLUTTER_FREQUENCY_HZ,
    PAPER_TABLE3,
    ModalData,
    build_from_modes,
    modal_data,
)
from .dlm import compute_gaf
from .files import AeroData
from .flutter import (
    AeroTable,
    flutter_altitude_pk,
    flutter_altitude_state_space,
    growing_response_frequency,
    growing_response_frequency_pk,
)
from .panels import goland_panels

MACH = 0.7
N_MODES = 9
N_LAGS = 13
#: default aerodynamic mesh per half wing (chordwise, spanwise); see the convergence study
DEFAULT_BOXES = (8, 20)
ALT_RANGE = (0.0, 30000.0)


@dataclass
class GolandFlutter:
    """Flutter of the heavy Goland wing at one store position and mesh (ft, Hz)."""

    store_x: float
    boxes: tuple[int, int]
    frequencies_hz: list[float]
    pk_altitude: float | None
    pk_frequency_hz: float | None
    ss_altitude: float | None
    ss_frequency_hz: float | None
    rfa_error: dict
    table3: dict = field(default_factory=dict)  # altitude -> (state space Hz, p-k Hz, paper Hz)

    def as_dict(self) -> dict:
        return {
            "store_x": self.store_x,
            "boxes": list(self.boxes),
            "frequencies_hz": self.frequencies_hz,
            "pk": {"altitude": self.pk_altitude, "frequency_hz": self.pk_frequency_hz},
            "state_space": {"altitude": self.ss_altitude, "frequency_hz": self.ss_frequency_hz},
            "paper": {
                "altitude": PAPER_FLUTTER_ALTITUDE_FT,
                "frequency_hz": PAPER_FLUTTER_FREQUENCY_HZ,
            },
            "rfa_error": self.rfa_error,
            "table3": [
                {"altitude": a, "state_space_hz": s, "pk_hz": p, "paper_hz": q}
                for a, (s, p, q) in self.table3.items()
            ],
        }


def goland_modes(store_x: float | None = None, n_modes: int = N_MODES) -> ModalData:
    """Modes of the calibrated variant of the built-in heavy Goland FE model (density calibrated
    to mode 1 = 1.690 Hz; ``store_x`` its store position, None: the calibrated one)."""
    from ..fe import goland

    fe = goland(store_x=store_x, variant="calibrated")
    return modal_data(fe, n_modes)


def pk_flutter_altitude(
    modes: ModalData,
    boxes=DEFAULT_BOXES,
    alpha=BASELINE_ALPHA,
    gamma=BASELINE_GAMMA,
    kernel="quartic",
    alt_range=ALT_RANGE,
    k_list=GOLAND_K_LIST,
):
    """p-k flutter altitude and frequency on the tabulated DLM GAFs (no RFA)."""
    from .build import goland_reference, planform_box_motion

    panels = goland_panels(*boxes)
    gaf = compute_gaf(
        panels,
        planform_box_motion(modes, panels),
        MACH,
        k_list,
        goland_reference().semichord,
        kernel,
    )
    res = flutter_altitude_pk(
        modes.structure(alpha, gamma), AeroTable.from_gaf(gaf), MACH, alt_range
    )
    return res, gaf


def goland_flutter(
    store_x: float | None = None,
    boxes=DEFAULT_BOXES,
    n_lags: int = N_LAGS,
    alpha: float = BASELINE_ALPHA,
    gamma: float = BASELINE_GAMMA,
    kernel: str = "quartic",
    table3=tuple(PAPER_TABLE3),
    aero: AeroData | None = None,
    modes: ModalData | None = None,
) -> GolandFlutter:
    """Flutter altitude/frequency by p-k (GAF table) and state space (RFA), plus Table 3."""
    modes = goland_modes(store_x) if modes is None else modes
    if aero is None:
        aero = build_from_modes(
            modes, MACH, n_lags, GOLAND_K_LIST, goland_panels(*boxes), None, kernel
        )
    st = modes.structure(alpha, gamma)
    table = AeroTable.from_gaf(aero.gaf)
    pk = flutter_altitude_pk(st, table, MACH, ALT_RANGE)
    ss = flutter_altitude_state_space(st, aero.rfa, MACH, ALT_RANGE)
    rows = {}
    if table3:
        alts = np.asarray(table3, dtype=float)
        f_ss = growing_response_frequency(st, aero.rfa, MACH, alts)
        f_pk = growing_response_frequency_pk(st, table, MACH, alts, start_altitude=ALT_RANGE[1])
        rows = {
            float(a): (float(s), float(p), PAPER_TABLE3.get(float(a)))
            for a, s, p in zip(alts, f_ss, f_pk)
        }
    return GolandFlutter(
        store_x=float("nan") if store_x is None else float(store_x),
        boxes=tuple(boxes),
        frequencies_hz=modes.frequencies_hz.tolist(),
        pk_altitude=pk.altitude,
        pk_frequency_hz=pk.frequency_hz,
        ss_altitude=ss.altitude,
        ss_frequency_hz=ss.frequency_hz,
        rfa_error=aero.rfa.fit_error,
        table3=rows,
    )


def calibrate_store_x(
    target_altitude: float = PAPER_FLUTTER_ALTITUDE_FT,
    bracket=(2.0, 4.0),
    boxes=DEFAULT_BOXES,
    xtol: float = 1e-3,
    log=print,
) -> float:
    """Store chordwise position (ft from the LE) whose p-k flutter altitude is the target.

    Brent's method on h_flutter(store_x) - target; every evaluation rebuilds the FE model (its
    density is recalibrated to mode 1 = 1.690 Hz), the modes and the DLM GAFs. A store far
    forward is stable down to the bottom of the search range, far aft unstable at its top; both
    count as beyond the range's ends.
    """
    search = (-4000.0, 50000.0)

    def miss(x):
        res, _ = pk_flutter_altitude(goland_modes(x), boxes, alt_range=search)
        if res.altitude is not None:
            alt = res.altitude
        else:
            g = res.sweep.damping[-1]  # lowest altitude (highest dynamic pressure)
            stable = np.all(g[np.isfinite(g)] < 0)
            alt = search[0] - 1000.0 if stable else search[1] + 1000.0
        log(f"  store_x = {x:.4f} ft: p-k flutter altitude {alt:.1f} ft")
        return alt - target_altitude

    lo, hi = bracket
    try:
        return float(scipy.optimize.brentq(miss, lo, hi, xtol=xtol))
    except ValueError:
        raise ConvergenceError(
            f"store calibration: flutter altitude does not bracket "
            f"{target_altitude:g} ft for store_x in {lo:g}..{hi:g} ft"
        ) from None


def panel_convergence(
    modes: ModalData, meshes=((4, 10), (6, 15), (8, 20), (12, 30)), log=print
) -> list[dict]:
    """p-k flutter altitude and frequency for a sequence of aerodynamic meshes (per half wing)."""
    out = []
    for boxes in meshes:
        res, _ = pk_flutter_altitude(modes, boxes)
        rec = {
            "boxes": list(boxes),
            "n_boxes": 2 * boxes[0] * boxes[1],
            "altitude": res.altitude,
            "frequency_hz": res.frequency_hz,
        }
        log(
            f"  {boxes[0]:>2} x {boxes[1]:>2} boxes per half wing: flutter altitude "
            f"{res.altitude:.1f} ft, {res.frequency_hz:.4f} Hz"
        )
        out.append(rec)
    return out
