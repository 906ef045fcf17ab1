"""Periodic orbits (LCOs) directly: harmonic balance, Floquet stability and continuation.

A sibling of :mod:`torchrom.sim` over the same per-case system (:class:`~torchrom.sim.CaseSystem`)
and the same ROM force and tangent kernels (:mod:`torchrom.rom.kernels`):

- :mod:`.fourier`: coefficient layout, alias-free AFT sampling, transforms (``torch.fft``);
- :mod:`.balance`: the HB residual and analytic Jacobian of B cases (lag states eliminated per
  harmonic);
- :mod:`.newton`: batched Newton with a phase condition and one linear condition;
- :mod:`.solve`: LCOs from scratch (amplitude-staged cold start), neighbour chains, adaptive H;
- :mod:`.floquet`: Floquet multipliers and stability;
- :mod:`.fourier_certificate`: a bound on a Fourier orbit's distance to the continuous-time orbit;
- :mod:`.raise_harmonics`: rows that bound refuses re-solved at more harmonics;
- :mod:`.continuation`: branches from the Hopf (flutter) point, folds, branch points;
- :mod:`.sensitivity`: derivatives of an LCO's amplitude by the implicit-function theorem;
- :mod:`.method`: HB as a sweep method (the time integrator's call and result).
"""

from .continuation import Branches, BranchOptions, follow_branches, hopf_points
from .floquet import FloquetResult, floquet
from .method import HarmonicBalanceMethod
from .newton import NewtonOptions
from .solve import HBOptions, PeriodicOrbits, critical_modes, solve_orbits

__all__ = ["HBOptions", "PeriodicOrbits", "solve_orbits", "critical_modes", "NewtonOptions",
           "FloquetResult", "floquet", "BranchOptions", "Branches", "follow_branches",
           "hopf_points", "HarmonicBalanceMethod"]
