"""Batched implicit time integration of many ROM cases with on-the-fly LCO detection.

- :class:`CaseSystem` (:mod:`.system`): the per-case batched system (structural ROM + per-case
  linear additions and lag states) — the contract the aeroelastic assembly builds.
- :class:`Newmark` (:mod:`.newmark`): Newmark / HHT-α / generalised-α with modified Newton or
  fixed-point iterations, lag-state condensation, no per-step host synchronisation; optional
  error-controlled per-case steps and amplitude jumps.
- :class:`LCOCriteria`, :class:`PeakTracker` (:mod:`.lco`): peak tracking and stop criteria.
- :mod:`.initial`: starts on the ROM's static manifold (dual coordinates at their static values).
- :mod:`.metrics`: amplitude, frequency, amplitude ratios; :class:`SimulationResult`.
"""

from .lco import STATUS_NAMES, LCOCriteria, PeakTracker
from .newmark import HistoryRequest, Newmark, output_matrix
from .result import History, SimulationResult
from .schemes import SchemeParameters
from .system import CaseSystem

__all__ = [
    "CaseSystem",
    "Newmark",
    "HistoryRequest",
    "LCOCriteria",
    "PeakTracker",
    "STATUS_NAMES",
    "SimulationResult",
    "History",
    "SchemeParameters",
    "output_matrix",
]
