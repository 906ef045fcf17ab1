"""What ``torchrom flutter ROM.npz AERO.npz`` says beside its flutter lines: the aero file's
RFA check, the modes the aerodynamics do not load, the divergences, and whether p-k and the
state space agree (and why not where they do not).

p-k iterates the tabulated GAFs Q(k); the state space uses their RFA. At a zero-damping
crossing both solve the same equations, so they differ only by the RFA's error at the
crossing's reduced frequencies, or where the state-space search starts above a p-k crossing
(the RFA is fitted where the modes' k matter: below ω_n b / k_fit it is extrapolated).
"""

from __future__ import annotations

import numpy as np

# AGREEMENT: the largest relative difference of the p-k and state-space flutter speeds (1 %);
# RFA_ERROR_LIMIT: the RFA's largest weighted RMS error (1e-2), both stated there
from ..aero.reduced_frequencies import AGREEMENT, RFA_ERROR_LIMIT


def rfa_lines(aero) -> list[str]:
    """The RFA's fit and check as the aero file records them: one line, plus a warning line
    per failed check (:mod:`torchrom.aero.reduced_frequencies`)."""
    err = aero.rfa.fit_error or {}
    survey = aero.metadata.get("reduced_frequencies")
    k_fit = err.get("k_fit", float(np.max(aero.gaf.k)))
    line = (f"  RFA: {aero.rfa.kind}, fitted on k <= {k_fit:.3g}, weighted RMS error "
            f"{err.get('rms_relative', float('nan')):.2e}")
    out = []
    if survey and survey.get("rfa_error") is not None:
        line += (f"; at the k that matter (k <= {survey['k_check']:.3g}): "
                 f"{survey['rfa_error']:.2e} (limit {RFA_ERROR_LIMIT:g})")
        out = [f"  warning: aero file: {w}" for w in survey.get("warnings", [])]
    elif err.get("rms_relative", 0.0) > RFA_ERROR_LIMIT:
        # no survey in the file (the built-in Goland wing, an older file): the agreement of
        # p-k and state space at the flutter point says whether the error matters there
        out = [f"  note: the RFA's error over its whole table is above {RFA_ERROR_LIMIT:g}; "
               f"whether it matters at the flutter's reduced frequencies, the agreement of "
               f"p-k and state space says (torchrom aero on a deck checks it where the k "
               f"matter)"]
    return [line, *out]


def quiet_lines(result, speed_unit: str, where: str = "") -> list[str]:
    """The p-k branches not loaded by the aerodynamics and the divergence of one result
    (:class:`torchrom.aero.flutter_speed.FlutterSpeed`)."""
    out = []
    if result.not_loaded:
        modes = ", ".join(str(j + 1) for j in result.not_loaded)
        out.append(f"  {result.method}{where}: mode(s) {modes} not loaded by the "
                   f"aerodynamics (|g| <= {result.g_tolerance:g} at every speed): no flutter row")
    for j, v, k in getattr(result, "extrapolated_crossings", []):
        out.append(f"  {result.method}{where}: mode {j + 1}'s damping crosses zero at {v:.4g} "
                   f"{speed_unit} at k = {k:.3g}, beyond the GAF table: extrapolated "
                   f"aerodynamics, not flutter")
    if result.divergence_velocity is not None:
        mode = "" if result.divergence_mode is None else f" (mode {result.divergence_mode + 1})"
        out.append(f"  {result.method}{where}: divergence{mode} at "
                   f"{result.divergence_velocity:.2f} {speed_unit}: a real root crosses zero "
                   f"(static, not flutter)")
    return out


def disagreement(pk, ss, structure, rfa, speed_unit: str, where: str = "") -> str | None:
    """A warning line where the p-k and state-space flutter speeds (same density) differ by
    more than :data:`AGREEMENT`, or only one finds flutter, saying why; None where they
    agree."""
    if pk.velocity is None and ss.velocity is None:
        return None
    if pk.velocity is not None and ss.velocity is not None and \
            abs(ss.velocity / pk.velocity - 1) <= AGREEMENT:
        return None
    w_max = 2 * np.pi * float(np.max(structure.natural_frequencies_hz()))
    k_fit = (rfa.fit_error or {}).get("k_fit")
    lo = ss.speed_range[0] if ss.speed_range else None
    if pk.velocity is not None and ss.velocity is not None:
        what = (f"p-k {pk.velocity:.2f} and state space {ss.velocity:.2f} {speed_unit} differ "
                f"by {100 * (ss.velocity / pk.velocity - 1):+.2f} % (more than "
                f"{100 * AGREEMENT:g} %)")
    elif pk.velocity is not None:
        what = f"only p-k finds flutter ({pk.velocity:.2f} {speed_unit})"
    else:
        what = f"only the state space finds flutter ({ss.velocity:.2f} {speed_unit})"
    if pk.velocity is not None and lo is not None and pk.velocity < lo:
        why = (f"the state space is searched from {lo:.4g} {speed_unit}, where every mode's k "
               f"is within the RFA's fit (k <= {k_fit:.3g}); below it the RFA is extrapolated")
    else:
        v = ss.velocity if ss.velocity is not None else pk.velocity
        k_at = w_max * rfa.semichord / v
        why = (f"the RFA does not follow the GAFs at the crossing (the modes reach k = "
               f"{k_at:.3g} there; RFA error {(rfa.fit_error or {}).get('rms_relative', 0):.2e}"
               f" rms)")
    return (f"  warning{where}: {what}: {why}; build the aero file with torchrom aero's "
            f"default reduced frequencies (no --k), or more --lags")


def matched_disagreement(pk, ss) -> str | None:
    """A warning line where the matched-point flutter dynamic pressures of p-k and the state
    space (:class:`torchrom.aero.flutter.MatchedPointResult`) differ by more than
    2 :data:`AGREEMENT` (q ∝ V²: 1 % in speed at one density), or only one finds flutter."""
    if pk.altitude is None and ss.altitude is None:
        return None
    if pk.altitude is not None and ss.altitude is not None:
        q_pk, q_ss = (0.5 * r.density * r.velocity**2 for r in (pk, ss))
        if abs(q_ss / q_pk - 1) <= 2 * AGREEMENT:
            return None
        what = (f"p-k and state-space flutter dynamic pressures differ by "
                f"{100 * (q_ss / q_pk - 1):+.2f} % (more than {200 * AGREEMENT:g} %)")
    else:
        what = f"only {'p-k' if ss.altitude is None else 'the state space'} finds flutter"
    return (f"  warning: {what}: the RFA does not follow the GAFs at the flutter's reduced "
            f"frequencies; build the aero file with torchrom aero's default reduced "
            f"frequencies (no --k), or more --lags")
