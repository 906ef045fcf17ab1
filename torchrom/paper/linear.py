"""The batched simulator against the flutter eigenvalues: linear growth rates and Table 3.

With both nonlinearities off the assembled system (:mod:`torchrom.sim.aeroelastic`) is linear,
and Newmark's average-acceleration rule (the trapezoidal rule, for the lag states too) maps a
root s to z = (1 + s dt/2)/(1 − s dt/2), |z| > 1 exactly when Re s > 0: the simulated response
grows exactly where the eigenvalues say it does. Two checks are run in one batch:

- *flutter altitude*: cases at the eigenvalue flutter altitude ± offsets start on their critical
  eigenvector (output amplitude small), so the response is that single root; the growth rate σ
  measured from the simulated peaks (:func:`~torchrom.sim.aeroelastic.growth_rate`) is fitted by
  a quadratic in altitude, whose zero is the simulator's flutter altitude;
- *Table 3*: cases at the paper's altitudes start from near-zero initial conditions on mode 1
  (as the LCO runs do); the frequency of the growing response is measured over the last
  ``window`` of the run, once the growing root dominates the decaying ones.

Both use the baseline damping (α0, β0 of Eq. 46).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..aero.atmosphere import flight_condition
from ..aero.build import PAPER_TABLE3
from ..aero.flutter import critical_root
from ..sim import HistoryRequest, LCOCriteria, Newmark
from ..sim.aeroelastic import aeroelastic_system, critical_mode_state, growth_rate
from ..study.models import AeroelasticModel

#: altitude offsets (ft) around the eigenvalue flutter altitude of the growth-rate check
FLUTTER_OFFSETS_FT = (-400.0, -150.0, 150.0, 400.0)


@dataclass
class LinearCheck:
    """Results of :func:`linear_checks`.

    growth: per flutter-check case, altitude_ft, sigma_sim, sigma_eig (1/s), f_sim, f_eig (Hz);
    table3: per altitude, frequency of the growing response from the simulation and from the
        eigenvalues (Hz), with the paper's value;
    flutter_altitude_eig / flutter_altitude_sim: ft; steps: steps per case; seconds: wall time.
    """

    growth: pd.DataFrame
    table3: pd.DataFrame
    flutter_altitude_eig: float
    flutter_altitude_sim: float
    steps: int
    seconds: float

    @property
    def difference_ft(self) -> float:
        return self.flutter_altitude_sim - self.flutter_altitude_eig

    def as_dict(self) -> dict:
        return {"flutter_altitude_eig_ft": self.flutter_altitude_eig,
                "flutter_altitude_sim_ft": self.flutter_altitude_sim,
                "difference_ft": self.difference_ft, "steps_per_case": self.steps,
                "seconds": self.seconds, "growth": self.growth.to_dict(orient="records"),
                "table3": self.table3.to_dict(orient="records")}


def linear_checks(model: AeroelasticModel, *, t_end: float = 20.0, dt: float = 1e-3,
                  start_amplitude: float = 1e-3, near_zero_q1: float = 0.1,
                  window: float = 0.3, table3_altitudes=None) -> LinearCheck:
    """Run the growth-rate and Table 3 checks (see the module docstring) in one batch.

    ``start_amplitude``: point-A amplitude (ft) of the eigenvector starts; ``near_zero_q1``: the
    mode-1 coordinate of the near-zero starts; ``window``: fraction of the run (at its end) in
    which the Table 3 frequency is measured.
    """
    rom, alpha, gamma = model.rom, model.baseline_alpha, model.baseline_gamma
    h_f = float(model.baseline_flutter().altitude)
    alts3 = np.asarray(sorted(PAPER_TABLE3) if table3_altitudes is None else table3_altitudes,
                       dtype=float)
    alts_f = h_f + np.asarray(FLUTTER_OFFSETS_FT)
    alts = np.concatenate([alts_f, alts3])
    ae = aeroelastic_system(rom, model.aero, alts, alpha=alpha, gamma=gamma, stiffness_nl=0.0,
                            damping_nl=0.0, check=False)
    output = "A_Tz" if "A_Tz" in rom.outputs else next(iter(rom.outputs))
    nf = len(alts_f)
    q0, v0, xi0, roots = critical_mode_state(ae.system.select(list(range(nf))),
                                             rom.outputs[output], start_amplitude)
    n, na = rom.n, ae.system.n_lag
    B = len(alts)
    Q0, V0, XI0 = np.zeros((B, n)), np.zeros((B, n)), np.zeros((B, na))
    Q0[:nf], V0[:nf], XI0[:nf] = q0, v0, xi0
    Q0[nf:, 0] = near_zero_q1
    integ = Newmark(dt=dt)
    res = integ.run(ae.system, Q0, V0, XI0, t_end=t_end, outputs=[output],
                    lco=LCOCriteria(stop=False), history=HistoryRequest(tuple(range(B)), 1))
    st = model.structure(alpha, gamma)
    rows = []
    for i in range(nf):
        h = res.histories[i]
        sigma, f = growth_rate(h.t, h.y[:, 0])
        rows.append({"altitude_ft": alts[i], "sigma_sim": sigma, "sigma_eig": roots[i].real,
                     "f_sim": f, "f_eig": roots[i].imag / (2 * np.pi)})
    growth = pd.DataFrame(rows)
    coef = np.polyfit(growth["altitude_ft"] - h_f, growth["sigma_sim"], 2)
    zeros = np.roots(coef).real
    h_sim = float(h_f + zeros[np.argmin(np.abs(zeros))])
    rows = []
    for k, alt in enumerate(alts3):
        h = res.histories[nf + k]
        keep = h.t >= (1.0 - window) * t_end
        sigma, f = growth_rate(h.t[keep], h.y[keep, 0])
        fc = flight_condition(model.mach, float(alt))
        root = critical_root(st, model.aero.rfa, fc.velocity, fc.density)
        rows.append({"altitude_ft": alt, "frequency_sim_hz": f,
                     "frequency_eig_hz": root.imag / (2 * np.pi), "growth_sim": sigma,
                     "growth_eig": root.real, "paper_hz": PAPER_TABLE3.get(float(alt), np.nan)})
    return LinearCheck(growth, pd.DataFrame(rows), h_f, h_sim, int(res.steps.max()),
                       res.wall_time_s)
