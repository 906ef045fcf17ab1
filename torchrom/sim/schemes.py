"""Parameters of the one-step implicit schemes: Newmark, HHT-α and generalised-α.

All three are the generalised-α family of Chung & Hulbert (J. Appl. Mech. 60, 1993): the
equations of motion are imposed at intermediate times,

    M a_{n+1-αm} + C v_{n+1-αf} + K q_{n+1-αf} + f(q, v)_{n+1-αf} = F,
    x_{n+1-α} = (1-α) x_{n+1} + α x_n,

with the Newmark updates q_{n+1} = q_n + dt v_n + dt² [(½-β) a_n + β a_{n+1}],
v_{n+1} = v_n + dt [(1-γ) a_n + γ a_{n+1}]. First-order (lag) states use the same αm, αf, γ
(ξ̇ in place of a, ξ in place of v), which keeps the whole coupled system second-order accurate
when γ = ½ - αm + αf.

- ``newmark``: average acceleration (trapezoidal rule), β = ¼, γ = ½, αm = αf = 0 — the paper's
  scheme; unconditionally stable, no numerical dissipation, period error (ω dt)²/12.
- ``hht``: αm = 0, αf = (1-ρ∞)/(1+ρ∞) ∈ [0, ⅓] (ρ∞ ∈ [½, 1]), γ = ½ + αf, β = ¼ (1+αf)².
- ``generalized_alpha``: αm = (2ρ∞-1)/(ρ∞+1), αf = ρ∞/(ρ∞+1), γ = ½ - αm + αf, β = ¼ (1-αm+αf)².

ρ∞ is the spectral radius at infinite frequency (1: no numerical dissipation).
The formulas are the published ones.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError

SCHEMES = ("newmark", "hht", "generalized_alpha")


@dataclass(frozen=True)
class SchemeParameters:
    beta: float
    gamma: float
    alpha_m: float
    alpha_f: float

    @classmethod
    def from_name(cls, scheme: str, rho_inf: float = 1.0) -> SchemeParameters:
        if scheme == "newmark":
            return cls(0.25, 0.5, 0.0, 0.0)
        if not 0.0 <= rho_inf <= 1.0:
            raise InputError(f"integrator.rho_inf: expected a value in [0, 1], got {rho_inf}")
        if scheme == "hht":
            if rho_inf < 0.5:
                raise InputError(f"integrator.rho_inf: HHT-α needs ρ∞ in [0.5, 1], got {rho_inf}")
            af = (1.0 - rho_inf) / (1.0 + rho_inf)
            return cls(0.25 * (1.0 + af) ** 2, 0.5 + af, 0.0, af)
        if scheme == "generalized_alpha":
            am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
            af = rho_inf / (rho_inf + 1.0)
            return cls(0.25 * (1.0 - am + af) ** 2, 0.5 - am + af, am, af)
        raise InputError(f"integrator.scheme: expected one of {', '.join(SCHEMES)}, got {scheme!r}")

    @property
    def is_newmark(self) -> bool:
        """True when the equations are imposed at t_{n+1} (no history force needed)."""
        return self.alpha_m == 0.0 and self.alpha_f == 0.0
