"""Non-intrusive identification of nonlinear ROMs (DIGEST Secs. 4–6; issue 4).

Public API::

    from torchrom.identify import build_rom, identify, IdentifyOptions
    rom = build_rom(fe, n_linear=9, n_dual=12, damping="decomposition")   # or "exact"
    res = identify(fe, IdentifyOptions(...))     # ROM + basis, residuals, eigenvalues, counts

``fe`` is a ``torchrom.fe`` model or any :class:`FEBackend` (e.g. :class:`CallableBackend` over
user callables f(u), K_T(u), K_mat(u), M). Modules: :mod:`.backend` (protocol), :mod:`.basis`
(linear + dual modes), :mod:`.stiffness` (tangent method, STEP), :mod:`.damping` (exact,
decomposition), :mod:`.intrusive` (autograd reference), :mod:`.validate` and :mod:`.report`
(ROM vs FE), :mod:`.nastran` (file exchange).
"""

from .backend import CallableBackend, FEBackend, StaticSolution
from .basis import DualModeOptions
from .build import IdentificationResult, IdentifyOptions, build_rom, identify
from .damping import DecompositionOptions

__all__ = [
    "build_rom",
    "identify",
    "IdentifyOptions",
    "IdentificationResult",
    "DualModeOptions",
    "DecompositionOptions",
    "FEBackend",
    "CallableBackend",
    "StaticSolution",
]
