"""Linear unsteady aerodynamics, RFA and flutter (paper Sec. III.C, Eqs. 49–50).

Modules (one concern each):

- :mod:`~torchrom.aero.atmosphere`  USSA-76 at geometric altitude (ambiance), ft and SI helpers
- :mod:`~torchrom.aero.panels`      CAERO1 boxes, built-in Goland planform, full-span mirroring
- :mod:`~torchrom.aero.splines`     infinite-plate (SPLINE1-like) and beam (SPLINE2-like) splines
- :mod:`~torchrom.aero.dlm`         doublet-lattice GAF Q(k) (torch kernel, or PanelAero)
- :mod:`~torchrom.aero.dlm_kernel`  vortex/doublet-lattice AICs in torch, batched over k
- :mod:`~torchrom.aero.rfa`         Roger and minimum-state rational function approximations
- :mod:`~torchrom.aero.theodorsen`  Theodorsen's function and the typical section
- :mod:`~torchrom.aero.flutter`     p-k, KE, state space, matched-point altitude, α(γ)
- :mod:`~torchrom.aero.crossings`   crossings labelled sustained/hump, solved between speeds
- :mod:`~torchrom.aero.flutter_speed`  flutter speed at a fixed density (Mach 0 aerodynamics)
- :mod:`~torchrom.aero.nastran_flutter`  SOL 145-style flutter of a Nastran deck
- :mod:`~torchrom.aero.files`       ``aero.npz``
- :mod:`~torchrom.aero.build`       FE model → AeroData, flutter altitude (Python API)
- :mod:`~torchrom.aero.plots`       V-g / V-f and root-locus figures (matplotlib)
"""

from .atmosphere import atmosphere, density, flight_condition, speed_of_sound
from .build import (
    BASELINE_ALPHA,
    BASELINE_GAMMA,
    GOLAND_K_LIST,
    build,
    build_from_modes,
    flutter_altitude,
    modal_data,
)
from .dlm import GAF, BoxMotion, compute_gaf
from .files import AeroData, load_aero, save_aero
from .flutter import (
    AeroTable,
    FlutterPoint,
    MatchedPointResult,
    ModalStructure,
    ModeSweep,
    alpha_for_gamma,
    flutter_altitude_pk,
    flutter_altitude_state_space,
    growing_response_frequency,
    ke_sweep,
    pk_sweep,
    state_space_matrix,
)
from .panels import AeroPanels, AeroReference, goland_panels, rectangular_wing
from .rfa import RFA, default_lag_roots, fit_minimum_state, fit_roger
from .splines import BeamSpline, PlateSpline
from .theodorsen import TypicalSection, theodorsen_function

__all__ = [
    "AeroData",
    "AeroPanels",
    "AeroReference",
    "AeroTable",
    "BASELINE_ALPHA",
    "BASELINE_GAMMA",
    "BeamSpline",
    "BoxMotion",
    "FlutterPoint",
    "GAF",
    "GOLAND_K_LIST",
    "MatchedPointResult",
    "ModalStructure",
    "ModeSweep",
    "PlateSpline",
    "RFA",
    "TypicalSection",
    "alpha_for_gamma",
    "atmosphere",
    "build",
    "build_from_modes",
    "compute_gaf",
    "default_lag_roots",
    "density",
    "fit_minimum_state",
    "fit_roger",
    "flight_condition",
    "flutter_altitude",
    "flutter_altitude_pk",
    "flutter_altitude_state_space",
    "goland_panels",
    "growing_response_frequency",
    "ke_sweep",
    "load_aero",
    "modal_data",
    "pk_sweep",
    "rectangular_wing",
    "save_aero",
    "speed_of_sound",
    "state_space_matrix",
    "theodorsen_function",
]
