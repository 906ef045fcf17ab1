"""torchrom: nonlinear reduced-order models with Kelvin–Voigt damping for post-flutter LCO studies.

Subpackages (imported on first use so that ``import torchrom`` stays fast):

- :mod:`torchrom.rom`      the :class:`NonlinearROM` object (tensors, forces, conventions, rom.npz)
- :mod:`torchrom.sim`      batched implicit Newmark integrator, LCO detection and metrics
- :mod:`torchrom.fe`       built-in geometrically nonlinear FE, BDF input/output, heavy Goland wing
- :mod:`torchrom.identify` non-intrusive ROM identification (stiffness and damping)
- :mod:`torchrom.aero`     atmosphere, doublet-lattice GAFs, RFA, flutter
- :mod:`torchrom.study`    case grids from TOML, chunked/resumable sweeps, result tables
- :mod:`torchrom.periodic` periodic orbits by harmonic balance, continuation, Floquet stability
- :mod:`torchrom.paper`    the paper's study (modes, flutter, LCO figures) end to end
"""

from __future__ import annotations

import importlib
from typing import Any

from ._version import __version__
from .errors import ConvergenceError, InputError, TorchromError

# every name here is a module of the package (tests/test_layering.py imports each)
_SUBMODULES = {"rom", "sim", "fe", "identify", "aero", "study", "periodic", "paper", "io", "cli"}

__all__ = [
    "__version__",
    "NonlinearROM",
    "TorchromError",
    "InputError",
    "ConvergenceError",
    *sorted(_SUBMODULES),
]


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    if name == "NonlinearROM":
        from .rom import NonlinearROM

        return NonlinearROM
    raise AttributeError(f"module 'torchrom' has no attribute {name!r}")
