"""The paper's published values, read from the package's ``data/paper_reference.toml``.

Everything the paper states as a number that torchrom compares with (Table 2 frequencies and
mode kinds, the baseline Rayleigh damping of Eq. 46, the flutter point at Mach 0.70, Table 3,
the γ levels of Figs. 10–13) lives in that one file; code that compares or draws these values
gets them from :func:`paper_reference` instead of typing them in (read with tomllib).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib


@dataclass(frozen=True)
class PaperReference:
    """Paper values (units in the names: Hz, ft, 1/s, s)."""

    source: str
    table2_hz: tuple[float, ...]
    table2_kinds: tuple[str, ...]
    alpha0_per_s: float
    beta0_s: float
    mach: float
    flutter_altitude_ft: float
    flutter_frequency_hz: float
    table3_hz: dict[float, float]
    gammas_s: tuple[float, ...]
    steps_to_converge: tuple[int, int]
    fig9_points: tuple[tuple[float, float], ...]
    fig9_source: str
    fig9_note: str


@lru_cache(maxsize=1)
def paper_reference() -> PaperReference:
    """The values of ``torchrom/data/paper_reference.toml``."""
    text = resources.files("torchrom").joinpath("data", "paper_reference.toml").read_text()
    d = tomllib.loads(text)
    t3 = d["table3"]
    return PaperReference(
        source=d["source"],
        table2_hz=tuple(float(f) for f in d["table2"]["frequencies_hz"]),
        table2_kinds=tuple(d["table2"]["kinds"]),
        alpha0_per_s=float(d["damping"]["alpha0_per_s"]),
        beta0_s=float(d["damping"]["beta0_s"]),
        mach=float(d["flutter"]["mach"]),
        flutter_altitude_ft=float(d["flutter"]["altitude_ft"]),
        flutter_frequency_hz=float(d["flutter"]["frequency_hz"]),
        table3_hz={float(a): float(f) for a, f in zip(t3["altitudes_ft"], t3["frequencies_hz"])},
        gammas_s=tuple(float(g) for g in d["lco"]["gammas_s"]),
        steps_to_converge=tuple(int(n) for n in d["lco"]["steps_to_converge"]),
        fig9_points=tuple((float(g), float(a)) for g, a in zip(d["fig9"]["gammas_s"],
                                                               d["fig9"]["alphas_per_s"])),
        fig9_source=d["fig9"]["source"],
        fig9_note=d["fig9"]["note"],
    )
