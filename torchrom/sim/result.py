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
        centre: (B, O) the middle of each output's band, (largest + smallest) / 2 over the
            window of ``amplitude``, for an LCO; the output at the final state for a decay;
            NaN otherwise (None where the run did not measure it).
        amplitude_change: (B,) relative change of that amplitude over its last cycle.
        solver_error: (B,) largest relative acceleration correction of the last nonlinear
            iteration (relative to the largest acceleration), over the check intervals.
        q, v: (B, n) final generalized displacements and velocities.
        xi: (B, na) final lag states (None where the run did not record them).
        histories: case index -> :class:`History` for the requested cases.
        wall_time_s: wall-clock time of the run; case_steps: Σ over cases of steps computed.
        extra: further per-case columns of a method (name -> (B,) array), e.g. the harmonic
            balance's stability (:mod:`torchrom.periodic.method`).
        orbits: harmonic balance only: the Fourier coefficients (B, 2H+1, n) of every case's
            orbit (zero beyond its own H, ``extra["harmonics"]``) and the angular frequencies
            (B,) in rad/s — what a time integration started on the orbit needs
            (:func:`torchrom.periodic.solve.orbit_state`); None for time marching.
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
    centre: np.ndarray | None = None
    orbits: tuple[np.ndarray, np.ndarray] | None = None

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


def gather_results(parts: list[tuple[np.ndarray, SimulationResult]], batch: int
                   ) -> SimulationResult:
    """One result of ``batch`` cases from runs of some of them: ``parts`` lists (indices of the
    run's cases in the whole batch, its result); every case must be covered exactly once."""
    if not parts:
        raise ValueError("gather_results: no parts")
    first = parts[0][1]
    seen = np.zeros(batch, dtype=int)

    def empty(a: np.ndarray) -> np.ndarray:
        shape = (batch, *a.shape[1:])
        if a.dtype.kind in "fc":
            return np.full(shape, np.nan, dtype=a.dtype)
        if a.dtype.kind in "UO":  # statuses: the parts' string lengths differ
            return np.full(shape, "", dtype=object)
        return np.zeros(shape, dtype=a.dtype)

    arrays = ("status", "steps", "time", "amplitude", "frequency_hz", "amplitude_change",
              "solver_error", "q", "v", "xi", "centre")
    out = {k: empty(getattr(first, k)) for k in arrays if getattr(first, k) is not None}
    histories: dict[int, History] = {}
    wall, steps = 0.0, 0
    for idx, res in parts:
        idx = np.asarray(idx, dtype=np.int64)
        seen[idx] += 1
        for k in out:
            out[k][idx] = getattr(res, k)
        histories.update({int(idx[c]): h for c, h in res.histories.items()})
        wall += res.wall_time_s
        steps += res.case_steps
    if not (seen == 1).all():
        raise ValueError("gather_results: the parts must cover every case exactly once")
    return SimulationResult(output_names=first.output_names, histories=dict(sorted(
        histories.items())), wall_time_s=wall, case_steps=steps,
        **{k: v for k, v in out.items()}, **({} if "xi" in out else {"xi": None}))
