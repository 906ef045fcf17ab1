"""Resource bounds checked before any work starts, from the configuration and the options.

A run whose up-front estimate is over a bound is refused with one line that gives the estimate,
the bound and the way to run it anyway: ``--allow-large`` on the command line (every command
that checks a bound, :func:`set_allow_large`) or ``[run] allow_large = true`` in a
configuration. The bounds:

- :data:`MAX_CASES` cases in one configuration, counted before the grid is built (every case
  holds a parameter dict, a case id and a table row: 10⁷ cases are gigabytes before one step);
- :data:`MAX_WORK` case-steps × iterations of time marching (10¹¹ is hours on any machine);
- :data:`MEMORY_FRACTION` of the memory available (RAM, or the CUDA device's free memory) for
  the largest allocation estimated (the harmonic balance Jacobians B × (n(2H+1))², the
  integrator's B × n² matrices); an estimate above all of the available memory is refused even
  with ``--allow-large``: it cannot run;
- :data:`THREADS_PER_CORE` × cores intra-op threads or worker processes (more only wait on
  each other; not lifted by ``--allow-large``);
- :data:`MAX_ITERATIONS` fixed iterations per time step, :data:`MAX_HARMONICS` harmonics,
  :data:`MAX_MODES` modes of one eigen-solve, :data:`MAX_HB_EFFORT` stages and samples per
  harmonic balance case, :data:`MAX_BOXES` doublet-lattice boxes (and their AIC memory),
  :data:`MAX_LAGS` RFA lag states.
"""

from __future__ import annotations

from .errors import InputError

#: cases of one configuration
MAX_CASES = 1_000_000
#: case-steps × iterations per step of one time-marching sweep
MAX_WORK = 1e11
#: share of the available memory the largest estimated allocation may take
MEMORY_FRACTION = 0.5
#: threads per logical core
THREADS_PER_CORE = 4
#: fixed nonlinear iterations per time step (a converging step needs a handful)
MAX_ITERATIONS = 1000
#: harmonics of a periodic orbit (the paper's orbits converge with 5 to 13; each Newton step
#: costs (n(2H+1))³ per case)
MAX_HARMONICS = 100
#: harmonic balance effort per case: cold-start stages, samples per period of the metrics and
#: of the Floquet monodromy (defaults 40, 512 and 2^8..2^10 respectively)
MAX_HB_EFFORT = {"max_stages": 1000, "metric_points": 100_000, "floquet_steps": 100_000}
#: doublet-lattice boxes (the AIC matrix is boxes² complex per reduced frequency) and RFA lags
MAX_BOXES = 20_000
MAX_LAGS = 100
#: modes of one eigen-solve (a shift-invert Lanczos run costs about n² DOF-vectors)
MAX_MODES = 2000
#: how to run over a bound anyway (named in every refusal)
OVERRIDE = "pass --allow-large (or set [run] allow_large = true) to run it anyway"

_state = {"allow_large": False}


def set_allow_large(flag: bool) -> None:
    """Process-wide: run over the (soft) bounds (the command line's ``--allow-large``)."""
    _state["allow_large"] = bool(flag)


def allowed(override: bool = False) -> bool:
    """Whether the soft bounds are lifted (``--allow-large`` or a configuration's own key)."""
    return _state["allow_large"] or bool(override)


def format_bytes(nbytes: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes / 1e3:.3g} kB"


def available_memory(device=None) -> int:
    """Bytes free for a new allocation: a CUDA device's free memory, else the RAM available to
    this process (:func:`torchrom.limits.available_memory`: the machine's, at most what its
    cgroup's memory limit leaves)."""
    if device is not None and getattr(device, "type", str(device)) == "cuda":
        import torch

        return int(torch.cuda.mem_get_info(device)[0])
    from .limits import available_memory as ram_available

    return ram_available()


def check_count(where: str, what: str, count: float, bound: float, *,
                override: bool = False) -> None:
    """InputError (one line: estimate, bound, :data:`OVERRIDE`) when ``count`` > ``bound``."""
    if count > bound and not allowed(override):
        raise InputError(f"{where}: {what} = {_number(count)}, over the bound of "
                         f"{_number(bound)} (an "
                         f"estimate made before any work; a slip of a unit or an exponent?); "
                         f"{OVERRIDE}")


def _number(x: float) -> str:
    return f"{int(x)}" if float(x).is_integer() and abs(x) < 1e6 else f"{x:.3g}"


def check_boxes(where: str, boxes: int, *, override: bool = False) -> None:
    """The doublet-lattice bounds: :data:`MAX_BOXES` boxes, and the AIC matrices (boxes²
    complex, about eight such arrays while a reduced frequency is computed) in memory."""
    check_memory(where, f"the doublet-lattice matrices of {boxes} boxes", 8.0 * 16 * boxes**2,
                 override=override)
    check_count(where, "boxes", boxes, MAX_BOXES, override=override)


def check_memory(where: str, what: str, nbytes: float, *, device=None,
                 override: bool = False) -> None:
    """InputError when the estimated allocation ``nbytes`` is over :data:`MEMORY_FRACTION` of
    the available memory (unless allowed) or over all of it (always)."""
    free = available_memory(device)
    if nbytes > free:
        raise InputError(f"{where}: {what} needs about {format_bytes(nbytes)}, more than the "
                         f"{format_bytes(free)} available; reduce it")
    if nbytes > MEMORY_FRACTION * free and not allowed(override):
        raise InputError(f"{where}: {what} needs about {format_bytes(nbytes)}, over "
                         f"{MEMORY_FRACTION:.0%} of the {format_bytes(free)} available; "
                         f"{OVERRIDE}")


def check_threads(where: str, threads, *, override: bool = False) -> None:
    """InputError when an integer thread (or worker process) count exceeds
    :data:`THREADS_PER_CORE` × cores: more only wait on each other, and thousands exhaust the
    process's memory for stacks, so ``--allow-large`` does not lift this bound (``override``
    is accepted for a uniform call). Cores: those this process may use (affinity, cgroup CPU
    quota; :func:`torchrom.limits.usable_cpus`)."""
    from .limits import usable_cpus

    cores = usable_cpus()
    bound = THREADS_PER_CORE * cores
    if isinstance(threads, int) and not isinstance(threads, bool) and threads > bound:
        raise InputError(f"{where}: {threads} threads, more than {THREADS_PER_CORE} per core "
                         f"({cores} cores here, at most {bound}): more only wait on each other")


def hb_bytes(n: int, harmonics: int, batch: int, itemsize: int = 8) -> float:
    """Bytes of harmonic balance at H harmonics: ``batch`` Newton Jacobians of the n(2H+1) + 1
    unknowns (Fourier coefficients and the frequency; × 3 for the factorisation and the
    tangent on the time grid), plus the Fourier matrices E, dE, P of the truncation residual,
    which samples harmonics up to 3H at 4·3H + 1 points (:mod:`torchrom.periodic.fourier`)."""
    unknowns = n * (2 * harmonics + 1) + 1
    fourier = 3.0 * (12 * harmonics + 1) * (6 * harmonics + 1)
    return (3.0 * batch * unknowns**2 + fourier) * itemsize


def integrator_bytes(n: int, batch: int, itemsize: int = 8) -> float:
    """Bytes of the time integrator's per-case matrices: about ten B × n × n tensors (mass,
    damping, stiffness, iteration matrix and its inverse, tangents)."""
    return 10.0 * batch * n * n * itemsize


def check_harmonic_balance(where: str, n: int, harmonics: int, batch: int, *, device=None,
                           itemsize: int = 8, override: bool = False) -> None:
    """The bounds of a harmonic balance run at up to ``harmonics`` harmonics: the count
    (:data:`MAX_HARMONICS`) and the memory (:func:`hb_bytes`)."""
    check_memory(where, f"harmonic balance with H = {harmonics}, {n} modes, {batch} case(s) "
                 f"at once", hb_bytes(n, harmonics, batch, itemsize), device=device,
                 override=override)
    check_count(where, "harmonics", harmonics, MAX_HARMONICS, override=override)


def check_harmonic_balance_effort(where: str, values: dict, *, override: bool = False) -> None:
    """The per-case effort settings of harmonic balance (:data:`MAX_HB_EFFORT`, e.g.
    ``metric_points = 1e9`` would allocate and loop for hours)."""
    for key, bound in MAX_HB_EFFORT.items():
        if key in values:
            check_count(f"{where} {key}", key, values[key], bound, override=override)
