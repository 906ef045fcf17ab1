"""A certificate for every LCO, whatever method found it: one shooting evaluation from its orbit.

For each LCO row of a :class:`~torchrom.sim.SimulationResult` (harmonic balance orbits, or the
final state of a time integration) the discrete periodic orbit of the Newmark map at the
certificate's step h (:mod:`.shooting`) is evaluated once from the method's orbit:

- ``orbit_error``: the relative change of the decision output's amplitude that the Newton
  correction makes — how far the reported orbit is from the exact discrete orbit;
- ``dt_error``: the discretisation error of the discrete orbit's amplitude by Richardson on
  two steps, |A(2h) − A(h)| / (3 A(h)) (Newmark is second order), A(2h) from one shooting
  evaluation at 2h;
- ``stable``, ``critical_multiplier``, ``trivial_multiplier_error``: from the monodromy
  (the stability of record);
- ``certified``: ``orbit_error`` ≤ ``tol``. Otherwise the orbit is finished by shooting
  (``finish``; the row then reports the discrete orbit, ``finished`` True) or its status
  becomes ``lco_uncertified`` with its numbers kept. An orbit whose start leaves the
  stability unknown (trivial multiplier not resolved) is finished too.

The true amplitude lies within (orbit_error + dt_error) × amplitude of the reported one, to
first order. Written here: the certificate composes this project's own solvers.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import torch

from ..checks import integer, real
from ..errors import InputError
from ..sim.result import SimulationResult
from ..sim.system import CaseSystem
from .shooting import OrbitStart, ShootingOptions, shoot, start_from_fourier

#: status of an LCO whose certificate failed and that shooting could not finish
UNCERTIFIED = "lco_uncertified"
#: the certificate's columns (every row of a certified table has them)
COLUMNS = ("certified", "orbit_error", "dt_error", "stable", "critical_multiplier",
           "trivial_multiplier_error", "finished", "shooting_iterations")


@dataclass(frozen=True)
class Certificate:
    """How LCO rows are certified (module docstring).

    Attributes:
        enabled: certify at all (False: the columns are NaN, statuses unchanged).
        tol: largest ``orbit_error`` (relative amplitude) of a certified LCO.
        finish: finish an uncertified orbit by shooting (else ``lco_uncertified``).
        richardson: compute ``dt_error`` (one more evaluation at 2h, half the steps).
        dt: the step of the discrete orbit (s); None: the run's integrator step.
        max_iterations: Newton iterations of a finish (the Goland γ = 0 orbits of harmonic
            balance at H ≤ 9, 1.5–3.5 % off, need more than 12).
    """

    enabled: bool = True
    tol: float = 1e-3
    finish: bool = True
    richardson: bool = True
    dt: float | None = None
    max_iterations: int = 20

    def __post_init__(self):
        for name in ("enabled", "finish", "richardson"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"certificate.{name}: expected true or false, got "
                                 f"{getattr(self, name)!r}")
        real("certificate.tol", self.tol, positive=True)
        if self.dt is not None:
            real("certificate.dt", self.dt, positive=True)
        integer("certificate.max_iterations", self.max_iterations, minimum=1)

    def options(self, dt: float, iterations: int) -> ShootingOptions:
        return ShootingOptions(dt=dt, max_iterations=iterations)


def _starts(system: CaseSystem, result: SimulationResult, idx: np.ndarray, row
            ) -> OrbitStart:
    """The method's orbits of the cases ``idx`` of ``result`` as shooting starts (``system``:
    those cases alone)."""
    if result.orbits is not None:
        X, w = result.orbits
        return start_from_fourier(system, torch.as_tensor(X[idx]), torch.as_tensor(w[idx]), row)
    na = system.n_lag
    xi = (np.zeros((len(idx), na)) if result.xi is None else result.xi[idx])
    f = np.asarray(result.frequency_hz, dtype=float)[idx]
    return OrbitStart(torch.as_tensor(result.q[idx], dtype=torch.float64),
                      torch.as_tensor(result.v[idx], dtype=torch.float64),
                      torch.as_tensor(xi, dtype=torch.float64).reshape(len(idx), na),
                      torch.as_tensor(1.0 / f, dtype=torch.float64))


def certify(system: CaseSystem, result: SimulationResult, rows, decision: int,
            certificate: Certificate, dt: float) -> SimulationResult:
    """``result`` with the certificate's columns (:data:`COLUMNS`) and, where an orbit was
    finished by shooting or failed its certificate, the new amplitudes, frequencies and
    statuses. ``rows`` (O, n): the result's output rows; ``decision``: the index among them
    of the output whose amplitude certifies (the LCO criteria's decision output); ``dt``: the
    run's step (used unless the certificate names its own)."""
    B = result.batch_size
    C = np.asarray(rows, dtype=float).reshape(-1, system.n)
    c = C[int(decision)]
    cols = {"certified": np.full(B, None, dtype=object), "orbit_error": np.full(B, np.nan),
            "dt_error": np.full(B, np.nan), "stable": np.full(B, None, dtype=object),
            "critical_multiplier": np.full(B, np.nan),
            "trivial_multiplier_error": np.full(B, np.nan),
            "finished": np.full(B, None, dtype=object),
            "shooting_iterations": np.zeros(B, dtype=np.int64)}
    previous = result.extra.get("stable")
    if previous is not None:  # a method's own verdict (decays: the linear root's)
        cols["stable"] = np.asarray(previous, dtype=object).copy()
    status = np.asarray(result.status, dtype=object).copy()
    amp = np.array(result.amplitude, dtype=float, copy=True)
    freq = np.array(result.frequency_hz, dtype=float, copy=True)
    idx = np.flatnonzero(status == "lco")
    if not certificate.enabled or idx.size == 0:
        return dataclasses.replace(result, extra={**result.extra, **cols})
    h = float(certificate.dt if certificate.dt is not None else dt)
    if not (h > 0 and math.isfinite(h)):
        raise InputError(f"certificate.dt: expected a positive step, got {h}")
    sub = system.select(torch.as_tensor(idx)).to(dtype=torch.float64)
    start = _starts(sub, result, idx, c)
    # one evaluation for every orbit (its certificate); Newton to the end only for the failures
    r = shoot(sub, start, c, rows=C, options=certificate.options(h, 0))
    # the discrete orbit's amplitude to second order in the start's distance, against the
    # amplitude the method reported (a transient's last cycle is not the cycle that follows)
    a_h = r.start_amplitude * (1 + r.first_amplitude_correction)
    err = np.abs(amp[idx, decision] / a_h - 1.0)
    direct = err <= certificate.tol
    orbit_error = err.copy()
    finished = np.zeros(idx.size, dtype=bool)
    iterations = np.zeros(idx.size, dtype=np.int64)
    stable, critical, trivial = r.stable.copy(), r.critical_multiplier, r.trivial_error
    state = (r.q, r.v, r.xi, r.period)
    # finished: the orbits that failed their certificate, and those whose stability the
    # start's monodromy leaves unknown (a start off a weakly attracting orbit moves the
    # trivial multiplier): the converged orbit's monodromy resolves it
    redo = ~direct | np.array([s is None for s in r.stable])
    if certificate.finish and redo.any():
        f = np.flatnonzero(redo)
        tf = torch.as_tensor(f)
        rf = shoot(sub.select(tf), OrbitStart(start.q[tf], start.v[tf], start.xi[tf],
                                              start.period[tf]), c, rows=C,
                   options=certificate.options(h, certificate.max_iterations))
        ok = rf.converged
        finished[f[ok]] = True
        g, tg = f[ok], torch.as_tensor(np.flatnonzero(ok))
        orbit_error[g] = np.abs(rf.amplitude_correction[ok])
        a_h[g] = rf.amplitude[ok, decision]
        iterations[f] = rf.iterations
        stable[g], critical[g], trivial[g] = rf.stable[ok], rf.critical_multiplier[ok], \
            rf.trivial_error[ok]
        amp[idx[g]] = rf.amplitude[ok]
        freq[idx[g]] = rf.frequency_hz[ok]
        tgi = torch.as_tensor(g)
        state = tuple(t.clone() for t in state)
        for dst, src in zip(state, (rf.q, rf.v, rf.xi, rf.period)):
            dst[tgi] = src[tg]
    certified = direct | finished
    # Richardson: the certified orbit (the method's, or the discrete one it was finished to)
    # evaluated once at 2h (half the steps of one evaluation at h)
    dt_error = np.full(idx.size, np.nan)
    if certificate.richardson and certified.any():
        cert = np.flatnonzero(certified)
        tc = torch.as_tensor(cert)
        coarse = shoot(sub.select(tc), OrbitStart(*(t[tc] for t in state)), c,
                       options=certificate.options(2 * h, 0))
        a_2h = coarse.start_amplitude * (1 + coarse.first_amplitude_correction)
        dt_error[cert] = np.abs(a_2h / a_h[cert] - 1.0) / 3.0
    cols["certified"][idx] = certified
    cols["orbit_error"][idx] = orbit_error
    cols["dt_error"][idx] = dt_error
    cols["stable"][idx] = stable
    cols["critical_multiplier"][idx] = critical
    cols["trivial_multiplier_error"][idx] = trivial
    cols["finished"][idx] = finished
    cols["shooting_iterations"][idx] = iterations
    status[idx[~certified]] = UNCERTIFIED
    return dataclasses.replace(result, status=status, amplitude=amp, frequency_hz=freq,
                               extra={**result.extra, **cols})
