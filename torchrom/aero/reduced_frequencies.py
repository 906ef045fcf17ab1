"""Reduced frequencies of an aero file chosen to cover the flutter range of the modes, and the
RFA fitted and checked where they matter.

Why: a deck's MKAERO list is written for Nastran's p-k, which interpolates Q(k); an RFA fitted
over all of it has to follow Q to the largest k. bah_plane's list runs to k = 10 (the flutter
is at k = 0.10): the 13-lag minimum-state fit misses it by 26 % rms (worst entry 89 %) and the
state-space flutter lands at 224 m/s against the p-k's 419. Fitted up to k = 1 it misses by
7.8e-4 and both give 394 (docs/guide/bah.md).

The choice, from the modes' frequencies f_j (ω_j = 2π f_j, elastic modes 1..n), the reference
semichord b (k = ω b / V) and a speed range [V_lo, V_hi] (deck length unit per s):

1. speeds: ``--speeds LO HI`` as given; else the modes' range, V_lo = max(ω_1 b / K_FLUTTER_MAX,
   ω_n b / K_TABLE_MAX) (the lowest mode at k = 2, no mode beyond the table), V_hi =
   ω_n b / K_FLUTTER_MIN, widened to the deck's FLUTTER velocities; either way raised to
   ω_n b / max(table k) where the table stops below the modes' k (no extrapolated Q);
2. the table: k = 0, :data:`K_QUASI_STEADY`, the deck's MKAERO k at the nearest Mach, and
   :data:`POINTS_PER_DECADE` log-spaced k from ω_1 b / V_hi to ω_n b / V_lo (a grid point
   within a factor :data:`NEAR_FACTOR` of a listed k is left out);
3. a survey: p-k on that table (undamped modes, the deck's FLUTTER density, else sea level in
   the deck's units, else AERO RHOREF) over 61 speeds from V_lo to V_hi gives the lowest flutter
   onset V_f (:mod:`torchrom.aero.crossings`);
4. the reduced frequencies that matter: those of every elastic mode at the speeds from
   V_m = max(V_lo, :data:`SPEED_MARGIN` V_f) up (V_m = V_lo without flutter in the range):
   0 <= k <= k_m = ω_n b / V_m. The RFA is fitted on the table's k up to k_fit, the first
   tabulated k >= k_m, from k_fit / :data:`FIT_SPAN` up, with k = 0 and the quasi-steady k
   (the GAF table keeps every k: the p-k interpolates it); k_fit is recorded in the RFA
   (``fit_error["k_fit"]``) and the state space is searched where every mode's k is within it
   (:func:`torchrom.aero.flutter_speed.state_space_speed_range`);
5. the check: the fit's weighted RMS error at every tabulated k <= k_fit against
   :data:`RFA_ERROR_LIMIT`, and the state-space flutter speed at the survey's density against
   the survey's p-k within :data:`AGREEMENT`; a failure is a warning that says what to do.

With the user's ``--k`` the table is theirs and the RFA is fitted on all of it (as asked);
the survey still finds the k that matter and the check is made there.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import InputError
from .dlm import GAF
from .flutter import AeroTable, ModalStructure, rigid_body_modes

#: the lowest elastic mode's largest reduced frequency in the default speed range: wings
#: flutter far below it (bah_plane k = 0.10, the heavy Goland wing 0.05)
K_FLUTTER_MAX = 2.0
#: the highest elastic mode's smallest reduced frequency in the default speed range (its
#: speed V_hi = ω_n b / 0.01: every mode's k is below 0.01 above it, quasi-steady)
K_FLUTTER_MIN = 0.01
#: largest reduced frequency of the default table (no mode's k above it at V_lo; MKAERO k
#: above it are kept); beyond k ~ 0.5 b/Δx the DLM's boxes no longer resolve the wave
K_TABLE_MAX = 10.0
#: always tabulated: the quasi-steady slope Im Q(ik)/k of a free aircraft's rigid-body columns
#: (:func:`torchrom.aero.rfa.quasi_steady_slope`, error O(k²) = 1e-6) and the p-k's real roots
K_QUASI_STEADY = 1e-3
#: log-spaced reduced frequencies per decade in the default table
POINTS_PER_DECADE = 3
#: a grid k within this factor of a listed (MKAERO) k is not added
NEAR_FACTOR = 1.25
#: the reduced frequencies that matter are the modes' at speeds from this fraction of the
#: survey's flutter speed up: an LCO sweep starts near the flutter speed, a ROM with another
#: structural damping or dual modes flutters within a few % of it, and a lower air density
#: raises it (lower k); 0.8 keeps 20 % below it
SPEED_MARGIN = 0.8
#: largest weighted RMS error (relative) of the RFA at the reduced frequencies that matter:
#: bah_plane's 8-mode fits (docs/guide/bah.md) put the state-space flutter 0.26 % from the
#: p-k at 0.98 % rms, -2.7 % at 2.5 %, -3.1 % at 3.2 %: below 1 % the RFA does not move the
#: flutter speed beyond the 1 % that p-k and state space are asked to agree to
RFA_ERROR_LIMIT = 1e-2
#: largest relative difference between the p-k and state-space flutter speeds (same density)
AGREEMENT = 1e-2
#: the RFA is fitted on at least this many positive reduced frequencies
MIN_FIT_K = 4
#: the RFA is fitted on the tabulated k from k_fit / FIT_SPAN to k_fit (with k = 0 and the
#: lowest positive k): below it the GAFs are quasi-steady, Q(0) + ik Q'(0), which the exact
#: A0 and the quasi-steady point give, and more points there only pull the relative-weighted
#: fit away from the flutter's k (bah_plane at Mach 0 on k <= 1: 4.8e-3 rms with the k from
#: 0.001 to 0.02 in the fit, 1.6e-3 without; with them the 22 Hz mode's small aerodynamic
#: damping is missed by 0.008 in g and the state space flutters at 335 m/s at 12,192 m,
#: where the p-k gives 1,098)
FIT_SPAN = 20.0
#: speeds of the survey's p-k sweep
N_SURVEY_SPEEDS = 61


@dataclass
class Survey:
    """The default reduced frequencies, the survey that chose the RFA's fit range, and its
    check (velocities in the deck's length unit per s, densities in its units)."""

    k_table: list[float]
    speeds: tuple[float, float]
    speeds_source: str
    density: float
    density_source: str
    semichord: float
    frequencies_hz: list[float]
    flutter_speed: float | None = None  # the survey's p-k flutter onset
    k_matter: float = float("nan")  # highest reduced frequency that matters
    matter_speed: float = float("nan")  # the lowest speed that matters
    k_fit: float = float("nan")  # the RFA is fitted on the table's k <= k_fit
    k_check: float = float("nan")  # the first tabulated k >= k_matter
    rfa_error: float = float("nan")  # the RFA's weighted RMS error at k <= k_check
    state_space_speed: float | None = None  # the fitted RFA's flutter speed, same density
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.warnings

    def as_dict(self) -> dict:
        out = asdict(self)
        out["speeds"] = list(self.speeds)
        out.update(rfa_error_limit=RFA_ERROR_LIMIT, agreement=AGREEMENT,
                   speed_margin=SPEED_MARGIN, ok=self.ok)
        return {key: (None if isinstance(v, float) and not np.isfinite(v) else v)
                for key, v in out.items()}

    def describe(self, velocity_unit: str = "length/s") -> list[str]:
        """The choice in a few lines (what ``aero`` prints)."""
        lo, hi = self.speeds
        lines = [f"reduced frequencies: {len(self.k_table)} k from {min(self.k_table):g} to "
                 f"{max(self.k_table):.3g} covering the modes ({min(self.frequencies_hz):.4g}"
                 f"..{max(self.frequencies_hz):.4g} Hz, b = {self.semichord:g}) at "
                 f"{lo:.4g}..{hi:.4g} {velocity_unit} ({self.speeds_source})"]
        where = ("no flutter in the range" if self.flutter_speed is None else
                 f"p-k flutter at {self.flutter_speed:.4g} {velocity_unit}")
        lines.append(f"survey at density {self.density:.4g} ({self.density_source}): {where}; "
                     f"the k that matter: the modes' at {self.matter_speed:.4g} "
                     f"{velocity_unit} and above, k <= {self.k_matter:.3g}")
        lines.append(f"RFA fitted on k <= {self.k_fit:.3g}: weighted RMS error "
                     f"{self.rfa_error:.2e} at k <= {self.k_check:.3g} (limit "
                     f"{RFA_ERROR_LIMIT:g})"
                     + ("" if self.flutter_speed is None or self.state_space_speed is None else
                        f"; state-space flutter {self.state_space_speed:.4g} {velocity_unit} "
                        f"({100 * (self.state_space_speed / self.flutter_speed - 1):+.2f} % "
                        f"from the p-k)"))
        return lines


def default_speeds(frequencies_hz, semichord: float, flutter_velocities=()
                   ) -> tuple[tuple[float, float], str]:
    """The default speed range (module docstring, step 1) and where it came from."""
    w = _elastic_omega(frequencies_hz)
    lo = max(w[0] * semichord / K_FLUTTER_MAX, w[-1] * semichord / K_TABLE_MAX)
    hi = w[-1] * semichord / K_FLUTTER_MIN
    source = (f"the modes: the lowest at k <= {K_FLUTTER_MAX:g}, the highest at "
              f"k >= {K_FLUTTER_MIN:g}")
    v = np.abs(np.asarray(flutter_velocities, dtype=float))
    v = v[v > 0]
    if v.size and (v.min() < lo or v.max() > hi):
        lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
        source += ", widened to the deck's FLUTTER velocities"
    return (float(lo), float(hi)), source


def table_k(frequencies_hz, semichord: float, speeds, listed=()) -> list[float]:
    """The default reduced frequencies (module docstring, step 2), sorted, 0 first."""
    w = _elastic_omega(frequencies_hz)
    lo, hi = speeds
    k_lo = max(min(w[0] * semichord / hi, K_QUASI_STEADY), 1e-6)
    k_hi = min(max(w[-1] * semichord / lo, 10 * k_lo), K_TABLE_MAX)
    n = int(np.ceil(POINTS_PER_DECADE * np.log10(k_hi / k_lo))) + 1
    have = sorted({0.0, K_QUASI_STEADY, *(float(k) for k in listed)})
    positive = np.array([k for k in have if k > 0])
    grid = [k for k in np.geomspace(k_lo, k_hi, n)
            if not np.any((positive / NEAR_FACTOR < k) & (k < positive * NEAR_FACTOR))]
    return sorted({*have, *(float(k) for k in grid)})


def survey_flutter(frequencies_hz, table: AeroTable, density: float, speeds,
                   mach: float = 0.0) -> float | None:
    """The lowest p-k flutter onset (elastic, not a divergence; the default damping
    tolerance) of the undamped modes at ``density`` over ``speeds`` (None: none):
    :func:`~torchrom.aero.flutter_speed.flutter_speed_pk_at_density` on a mass-normalised
    structure."""
    from .flutter_speed import flutter_speed_pk_at_density

    res, _ = flutter_speed_pk_at_density(_structure(frequencies_hz), table, density, mach,
                                         N_SURVEY_SPEEDS, speeds=speeds)
    return res.velocity


def matter_range(frequencies_hz, semichord: float, speeds, flutter_speed: float | None
                 ) -> tuple[float, float]:
    """(V_m, k_m) of the module docstring, step 4."""
    w = _elastic_omega(frequencies_hz)
    v_m = speeds[0] if flutter_speed is None else max(speeds[0], SPEED_MARGIN * flutter_speed)
    return float(v_m), float(w[-1] * semichord / v_m)


def first_k_above(gaf: GAF, k: float) -> float:
    """The first tabulated reduced frequency >= k (the largest where none is), and at least
    the :data:`MIN_FIT_K`-th positive one (a fit on fewer k is not a fit)."""
    above = gaf.k[gaf.k >= k]
    first = float(above.min()) if above.size else float(gaf.k.max())
    positive = np.sort(gaf.k[gaf.k > 0])
    return max(first, float(positive[min(MIN_FIT_K, len(positive)) - 1]))


def fit_points(gaf: GAF, k_fit: float) -> GAF:
    """The GAF table the RFA is fitted on: k = 0, the lowest positive tabulated k (the
    quasi-steady slope) and the tabulated k from k_fit / :data:`FIT_SPAN` to k_fit (at least
    :data:`MIN_FIT_K` positive ones)."""
    positive = np.sort(gaf.k[(gaf.k > 0) & (gaf.k <= k_fit)])
    band = positive[positive >= k_fit / FIT_SPAN]
    if len(band) < MIN_FIT_K:
        band = positive[-MIN_FIT_K:]
    keep = np.isin(gaf.k, [0.0, *positive[:1], *band])
    return GAF(gaf.mach, gaf.semichord, gaf.k[keep], gaf.Q[keep], gaf.kernel)


def plan(frequencies_hz, semichord: float, density: float, density_source: str, *,
         listed_k=(), flutter_velocities=(), speeds=None, k_list=None) -> Survey:
    """The table of reduced frequencies and the survey's conditions (module docstring, steps
    1-2): ``k_list`` (the user's ``--k``, with 0) replaces the chosen table; ``speeds`` (the
    user's ``--speeds``) the default speed range."""
    if speeds is not None:
        span, source = (float(speeds[0]), float(speeds[1])), "--speeds"
    else:
        span, source = default_speeds(frequencies_hz, semichord, flutter_velocities)
    table = (sorted({0.0, *(float(k) for k in k_list)}) if k_list is not None
             else table_k(frequencies_hz, semichord, span, listed_k))
    # the survey stays where the table holds every mode's k (no extrapolated Q)
    covered = float(_elastic_omega(frequencies_hz)[-1]) * semichord / max(table)
    if covered > span[0]:
        span = (covered, max(span[1], 2 * covered))
        source += f"; from {covered:.4g}, where every mode's k is within the table"
    return Survey(table, span, source, float(density), density_source, float(semichord),
                  [float(f) for f in frequencies_hz])


def fit_and_check(survey: Survey, gaf: GAF, fit, *, cut: bool = True):
    """The RFA, ``fit(table)``, on the reduced frequencies that matter (module docstring,
    steps 3-5; ``cut=False``: on the whole table, as the user's ``--k`` asks), with
    ``survey`` completed and checked."""
    f = survey.frequencies_hz
    survey.flutter_speed = survey_flutter(f, AeroTable.from_gaf(gaf), survey.density,
                                          survey.speeds, gaf.mach)
    survey.matter_speed, survey.k_matter = matter_range(f, survey.semichord, survey.speeds,
                                                        survey.flutter_speed)
    survey.k_check = first_k_above(gaf, survey.k_matter)
    survey.k_fit = survey.k_check if cut else float(gaf.k.max())
    rfa = fit(fit_points(gaf, survey.k_fit) if cut else gaf)
    if cut:  # the state space is searched where the fit holds (state_space_speed_range)
        rfa.fit_error["k_fit"] = survey.k_fit
    check(survey, f, rfa, gaf)
    return rfa


def check(survey: Survey, structure_frequencies_hz, rfa, gaf: GAF) -> Survey:
    """The fitted RFA's error at the k that matter and its state-space flutter speed at the
    survey's density against the survey's p-k (module docstring, step 5); each failure a
    warning in ``survey.warnings`` that says what to do."""
    from .flutter_speed import flutter_speed_at_density, state_space_speed_range
    from .rfa import fit_error

    keep = gaf.k <= survey.k_check
    err = fit_error(gaf.Q[keep], rfa.evaluate(gaf.k[keep]), _point_weights(gaf.Q[keep]))
    survey.rfa_error = float(err["rms_relative"])
    if survey.rfa_error > RFA_ERROR_LIMIT:
        survey.warnings.append(
            f"the RFA misses the GAFs by {survey.rfa_error:.2e} rms at k <= "
            f"{survey.k_check:.3g} (limit {RFA_ERROR_LIMIT:g}): the state space (flutter "
            f"--method state-space, sweeps) is not reliable there; add lag states (--lags), "
            f"fit only the k that matter (no --k, or --k up to {survey.k_check:.3g}), or "
            f"raise the lowest speed that matters (--speeds LO HI)")
    structure, table = _structure(structure_frequencies_hz), AeroTable.from_gaf(gaf)
    lo = max(survey.speeds[0], state_space_speed_range(structure, rfa, table)[0])
    ss = flutter_speed_at_density(structure, rfa, table, survey.density, N_SURVEY_SPEEDS,
                                  speeds=(lo, survey.speeds[1]), mach=gaf.mach)
    survey.state_space_speed = ss.velocity
    pk = survey.flutter_speed
    if pk is not None and ss.velocity is not None and abs(ss.velocity / pk - 1) > AGREEMENT:
        survey.warnings.append(
            f"state-space flutter {ss.velocity:.4g} differs from the p-k's {pk:.4g} by "
            f"{100 * (ss.velocity / pk - 1):+.2f} % (more than {100 * AGREEMENT:g} %): the RFA "
            f"does not follow the GAFs there; add lag states (--lags) or give --k up to "
            f"k = {survey.k_matter:.3g}")
    elif (pk is None) != (ss.velocity is None):
        which = "p-k" if ss.velocity is None else "state space"
        survey.warnings.append(
            f"only the {which} finds flutter in {survey.speeds[0]:.4g}..{survey.speeds[1]:.4g} "
            f"at density {survey.density:.4g}: the RFA does not follow the GAFs; add lag "
            f"states (--lags) or give --k up to k = {survey.k_matter:.3g}")
    return survey


def deck_density(deck, system=None) -> tuple[float, str]:
    """The survey's air density: the largest of the deck's FLUTTER densities, else sea level
    (USSA-76) in the deck's unit system ``system`` (:class:`torchrom.units.UnitSystem`), else
    AERO RHOREF; with where it came from."""
    from .atmosphere import atmosphere

    rho = [float(np.max(c.densities)) for c in getattr(deck, "cases", []) if len(c.densities)]
    if rho:
        return max(rho), "the deck's FLUTTER densities"
    if system is not None:
        return float(atmosphere(0.0, system.name).density), f"sea level, {system.name}"
    return float(deck.reference.rho_ref), "AERO RHOREF"


def _point_weights(q: np.ndarray) -> np.ndarray:
    """The fit report's entry weights (1 / max_k |Q_ij|, floored at 1e-2 of the largest: the
    minimum-state fit's, :data:`torchrom.aero.build.RELATIVE_WEIGHT_FLOOR`)."""
    scale = np.abs(q).max(axis=0)
    return 1.0 / np.maximum(scale, 1e-2 * float(scale.max()))


def _elastic_omega(frequencies_hz) -> np.ndarray:
    """The elastic modes' circular frequencies (rad/s), ascending; InputError without any."""
    f = np.asarray(frequencies_hz, dtype=float)
    w = np.sort(2 * np.pi * f[~rigid_body_modes(f)])
    if w.size == 0 or not w[-1] > 0:
        raise InputError("aero: reduced frequencies: no elastic mode (every mode at 0 Hz); "
                         "give --k")
    return w


def _structure(frequencies_hz) -> ModalStructure:
    """Mass-normalised, undamped: M = I, K = diag ω² (rigid-body modes at 0)."""
    w = 2 * np.pi * np.asarray(frequencies_hz, dtype=float)
    return ModalStructure(np.eye(len(w)), np.diag(w**2))
