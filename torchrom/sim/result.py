"""Results of a batched simulation: per-case statuses, LCO metrics, final states, histories."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class History:
    """A decimated time history of the outputs of one case: t (T,), y (T, O)."""

    t: np.ndarray
    y: np.ndarray
    names: list[str]

    def output(self, name: str) -> np.ndarray:
        return self.y[:, self.names.index(name)]


@dataclass
class SimulationResult:
    """Per-case results of :meth:`torchrom.sim.Newmark.run`, in the order of the input cases.

    Attributes:
        output_names: names of the tracked outputs (columns of ``amplitude``).
        status: (B,) 'lco', 'decay', 'diverged', 'unconverged' or 'failed'.
        steps: (B,) time steps taken; time: (B,) simulated time reached (s).
        amplitude: (B, O) half peak-to-peak amplitude of each output over the converged window
            of an LCO; 0 for a decay; NaN for every other status (diverged, unconverged, failed).
        frequency_hz: (B,) LCO frequency of the first decision output (NaN unless 'lco').
        last_amplitude, last_frequency_hz: the same measured on the last cycles whatever the
            status (the value when a case stopped; NaN where no cycle was seen).
        amplitude_change: (B,) relative change of that amplitude over its last cycle.
        solver_error: (B,) largest relative acceleration correction of the last nonlinear
            iteration (relative to the largest acceleration), over the check intervals.
        q, v: (B, n) final generalized displacements and velocities.
        xi: (B, na) final lag states (None where the run did not record them).
        histories: case index -> :class:`History` for the requested cases.
        wall_time_s: wall-clock time of the run; case_steps: Σ over cases of steps computed.
        extra: further per-case columns of a method (name -> (B,) array), e.g. the harmonic
            balance's stability (:mod:`torchrom.periodic.method`).
    """

    output_names: list[str]
    status: np.ndarray
    steps: np.ndarray
    time: np.ndarray
    amplitude: np.ndarray
    frequency_hz: np.ndarray
    amplitude_change: np.ndarray
    solver_error: np.ndarray
    q: np.ndarray
    v: np.ndarray
    last_amplitude: np.ndarray | None = None
    last_frequency_hz: np.ndarray | None = None
    histories: dict[int, History] = field(default_factory=dict)
    wall_time_s: float = 0.0
    case_steps: int = 0
    xi: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def batch_size(self) -> int:
        return len(self.status)

    def amplitude_of(self, name: str) -> np.ndarray:
        """(B,) amplitude of the output ``name``."""
        return self.amplitude[:, self.output_names.index(name)]

    def status_counts(self) -> dict[str, int]:
        names, counts = np.unique(self.status, return_counts=True)
        return {str(k): int(c) for k, c in zip(names, counts)}

    @property
    def us_per_case_step(self) -> float:
        return 1e6 * self.wall_time_s / max(self.case_steps, 1)
