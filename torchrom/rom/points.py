"""Output points of a ROM named by the deck's grids: ``"G1001:T3"`` = grid 1001, component T3.

Components are those of the FE model's ``dof_index``: T1 T2 T3 (translations) and R1 R2 R3
(rotations) along the axes of the grid's displacement (CD) system, the basic frame when the
GRID card gives no CD. A ROM keeps, for each output point, the row of its basis at that DOF
(``rom.outputs[name]``, output = row · q) and the point it came from
(``rom.metadata["output_points"]``: name -> ``"G1001:T3"``), so that a sweep can name an output
by its ROM name, by its grid and component, or by a name of its own (``[points]`` of a sweep
configuration) for a grid and component the ROM has.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ..errors import InputError

#: DOF components of a grid (index + 1 is the Nastran component number)
COMPONENTS = ("T1", "T2", "T3", "R1", "R2", "R3")
#: name of the default output: the DOF that moves most in the first mode
DEFAULT_OUTPUT = "max_mode1"
#: metadata key of the ROM's output points (name -> "G<grid>:<component>")
METADATA_KEY = "output_points"

_SPEC = re.compile(r"^G(\d+):([TR][123])$")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")


def is_point_spec(text: str) -> bool:
    """Whether ``text`` looks like a point ("G" followed by digits and a colon)."""
    return isinstance(text, str) and re.match(r"^G\d*:", text.strip()) is not None


def parse_point(spec: str, where: str = "point") -> tuple[int, int]:
    """(grid id, component 1..6) of ``"G1001:T3"``; InputError naming ``where`` otherwise."""
    text = spec.strip() if isinstance(spec, str) else spec
    m = _SPEC.match(text) if isinstance(text, str) else None
    if m is None:
        if isinstance(text, str) and re.match(r"^G\d+:", text):
            raise InputError(f"{where}: unknown component in {spec!r}; expected one of "
                             f"{', '.join(COMPONENTS)} (e.g. 'G1001:T3')")
        raise InputError(f"{where}: expected a grid and component like 'G1001:T3' "
                         f"(components {', '.join(COMPONENTS)}), got {spec!r}")
    return int(m.group(1)), COMPONENTS.index(m.group(2)) + 1


def point_label(grid: int, component: int) -> str:
    """``"G<grid>:<component>"`` of a grid id and a component 1..6."""
    return f"G{int(grid)}:{COMPONENTS[int(component) - 1]}"


def parse_named_point(text: str, where: str = "--output") -> tuple[str, tuple[int, int]]:
    """(name, (grid, component)) of ``"NAME=G1001:T3"`` or ``"G1001:T3"`` (named after itself)."""
    name, sep, spec = text.partition("=")
    if not sep:
        name, spec = text.strip(), text
    name = name.strip()
    if sep and not _NAME.match(name):
        raise InputError(f"{where}: output name {name!r}: expected letters, digits and _ . - "
                         f"(starting with a letter), e.g. tip=G1001:T3")
    return name, parse_point(spec, f"{where} {text!r}")


def check_point_table(points: Mapping[str, object], where: str = "[points]"
                      ) -> dict[str, str]:
    """``[points]`` of a configuration (name -> "G1001:T3"), each spec checked and normalised."""
    out = {}
    for name, spec in points.items():
        if not _NAME.match(str(name)) or is_point_spec(str(name)):
            raise InputError(f"{where} {name}: expected a name of letters, digits and _ . - "
                             f"starting with a letter")
        out[str(name)] = point_label(*parse_point(spec, f"{where} {name}"))
    return out


def rom_points(rom) -> dict[str, str]:
    """The ROM's output points (name -> "G1001:T3"; empty for a ROM that records none)."""
    return dict(rom.metadata.get(METADATA_KEY) or {})


def describe_outputs(rom) -> str:
    """The ROM's outputs with their points, e.g. ``A_Tz (G1027:T3), max_mode1 (G1040:T3)``."""
    pts = rom_points(rom)
    names = [f"{k} ({pts[k]})" if pts.get(k, k) != k else k for k in sorted(rom.outputs)]
    return ", ".join(names) if names else "none"


def resolve_output(rom, name: str, points: Mapping[str, str] | None = None,
                   where: str = "output") -> str:
    """The ROM output that ``name`` means: a ``[points]`` name through its point (also when the
    ROM has an output of that name: the configuration's point is what it means), a ROM output
    name as is, or a point ``"G1001:T3"``. InputError naming it and listing the ROM's outputs
    (with how to add one) when the ROM has none there."""
    points = dict(points or {})
    if name in rom.outputs and name not in points:
        return name
    spec = points.get(name, name)
    if name not in points and not is_point_spec(name):
        raise InputError(missing_output_message(rom, name, where))
    label = point_label(*parse_point(spec, f"{where} {name!r}"))
    for out, pt in rom_points(rom).items():
        if pt == label and out in rom.outputs:
            return out
    raise InputError(missing_output_message(rom, name if name == label else
                                            f"{name} ({label})", where, label))


def missing_output_message(rom, name: str, where: str = "output",
                           label: str | None = None) -> str:
    """One line: ``name`` is not an output of the ROM, its outputs, and how to add one."""
    hint = label or "GRID:T3"
    return (f"{where} {name!r}: not an output of the ROM; it has {describe_outputs(rom)} and "
            f"q1..q{rom.n} (identify again with --output NAME={hint} to add a point of the deck)")


def largest_translation(Phi: np.ndarray, translational_dofs, mode: int = 0) -> int:
    """The translational DOF with the largest |Φ[dof, mode]|: where the mode moves most."""
    dofs = np.asarray(translational_dofs, dtype=int)
    if dofs.size == 0:
        dofs = np.arange(Phi.shape[0])
    return int(dofs[np.argmax(np.abs(np.asarray(Phi)[dofs, mode]))])
