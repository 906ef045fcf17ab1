"""The nonlinear reduced-order model: tensors, conventions, compact kernels, ``rom.npz``."""

from . import conventions
from .model import NonlinearROM
from .monomials import MonomialIndex, monomial_index
from .storage import FORMAT_VERSION, save_rom

load_rom = NonlinearROM.load

__all__ = [
    "NonlinearROM",
    "conventions",
    "monomial_index",
    "MonomialIndex",
    "save_rom",
    "load_rom",
    "FORMAT_VERSION",
]
