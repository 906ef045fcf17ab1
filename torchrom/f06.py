"""Nastran's own answers from an F06 file: REAL EIGENVALUES and FLUTTER SUMMARY tables.

Written here: pyNastran 1.4 has no F06 reader for eigenvalue tables, and its flutter parser
(``pyNastran.f06.parse_flutter``) builds plotting objects with unit conversions and stops at
the first unexpected line; these tables have a fixed, documented layout (MSC Nastran Reference
Manual, "Real Eigenvalue Summary" and "Flutter Summary"), so a small line parser serves.

- :func:`read_real_eigenvalues`: every REAL EIGENVALUES table (mode number, eigenvalue ω²,
  radians, cycles, generalised mass and stiffness), in file order; the page breaks inside a
  table are skipped.
- :func:`read_flutter_summary`: every FLUTTER SUMMARY table (one per SUBCASE, POINT = mode,
  Mach and density ratio; PK/KE: 7 columns, PKNL: 9 with density and Mach per row), pages of the
  same point merged.
(The flutter points of these tables are found by
:func:`torchrom.aero.nastran_flutter.f06_flutter_points`.)
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError

_NUM = r"[-+]?\d*\.?\d+(?:[EeDd][-+]?\d+)?"
_ROW = re.compile(rf"^\s*(\d+)\s+(\d+)\s+({_NUM})\s+({_NUM})\s+({_NUM})\s+({_NUM})\s+({_NUM})\s*$")


@dataclass
class EigenTable:
    """One REAL EIGENVALUES table: ``title`` (the line under the heading, e.g. "(BEFORE
    AUGMENTATION OF RESIDUAL VECTORS)"), ``mode`` numbers, ``eigenvalue`` ω² (rad²/s²),
    ``cycles`` (Hz), ``generalized_mass``."""

    title: str
    mode: np.ndarray
    eigenvalue: np.ndarray
    cycles: np.ndarray
    generalized_mass: np.ndarray


@dataclass
class FlutterTable:
    """One FLUTTER SUMMARY point (a mode's branch) at one Mach number and density ratio
    (PKNL: per row). Columns as printed by Nastran: ``kfreq``, ``velocity``, ``damping`` (g),
    ``frequency`` (Hz), ``density``, ``mach``, ``eigenvalue`` (complex, 1/s)."""

    point: int
    method: str
    mach: float | None
    density_ratio: float | None
    kfreq: np.ndarray
    velocity: np.ndarray
    damping: np.ndarray
    frequency: np.ndarray
    density: np.ndarray | None = None
    machs: np.ndarray | None = None
    eigenvalue: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    #: the SUBCASE of the page header (1 where the page names none)
    subcase: int = 1


def _lines(path) -> list[str]:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such f06 file")
    return path.read_text(errors="replace").splitlines()


def _float(text: str) -> float:
    return float(text.replace("D", "E").replace("d", "e"))


def read_real_eigenvalues(path) -> list[EigenTable]:
    """Every REAL EIGENVALUES table of an f06, in file order."""
    lines = _lines(path)
    tables = []
    i = 0
    while i < len(lines):
        if "R E A L   E I G E N V A L U E S" not in lines[i]:
            i += 1
            continue
        title = lines[i + 1].strip() if i + 1 < len(lines) and "(" in lines[i + 1] else ""
        rows: list[tuple] = []
        i += 1
        # rows until the next heading that is not a page break of this table
        while i < len(lines):
            line = lines[i]
            m = _ROW.match(line)
            if m:
                rows.append(tuple(_float(g) for g in m.groups()))
            elif ("R E A L   E I G E N" in line or "FLUTTER  SUMMARY" in line
                  or "E I G E N V E C T O R" in line or "USER INFORMATION" in line
                  or "C O M P L E X" in line) and rows:
                break
            i += 1
        if rows:
            a = np.array(rows)
            tables.append(EigenTable(title, a[:, 0].astype(int), a[:, 2], a[:, 4], a[:, 5]))
    return tables


_POINT = re.compile(r"POINT\s*=\s*(\d+)(.*)METHOD\s*=\s*(\w+)")
_MACH = re.compile(rf"MACH NUMBER\s*=\s*({_NUM})")
_DENS = re.compile(rf"DENSITY RATIO\s*=\s*({_NUM})")
_SUBCASE = re.compile(r"\bSUBCASE\s+(\d+)\s*$")


def _subcase(lines: list[str], i: int, default: int) -> int:
    """The SUBCASE named by the page header above line ``i`` (its LABEL line, the one or two
    lines before FLUTTER  SUMMARY), else ``default``."""
    for line in lines[max(i - 2, 0):i]:
        m = _SUBCASE.search(line.rstrip())
        if m:
            return int(m.group(1))
    return default


def read_flutter_summary(path) -> list[FlutterTable]:
    """Every FLUTTER SUMMARY point of an f06 (pages of the same subcase, point and condition
    merged)."""
    lines = _lines(path)
    groups: dict[tuple, list[list[float]]] = {}
    order: list[tuple] = []
    subcase = 1
    i = 0
    while i < len(lines):
        if "FLUTTER  SUMMARY" not in lines[i]:
            i += 1
            continue
        j = i + 1
        while j < len(lines) and j < i + 4 and not _POINT.search(lines[j]):
            j += 1
        m = _POINT.search(lines[j]) if j < len(lines) else None
        if m is None:
            i += 1
            continue
        subcase = _subcase(lines, i, subcase)
        point, rest, method = int(m.group(1)), m.group(2), m.group(3).upper()
        mm, dd = _MACH.search(rest), _DENS.search(rest)
        mach = _float(mm.group(1)) if mm else None
        ratio = _float(dd.group(1)) if dd else None
        ncol = 9 if method == "PKNL" else 7
        key = (subcase, point, method, mach, ratio)
        if key not in groups:
            groups[key] = []
            order.append(key)
        i = j + 1
        while i < len(lines) and "FLUTTER  SUMMARY" not in lines[i]:
            parts = lines[i].split()
            if len(parts) == ncol:
                try:
                    groups[key].append([_float(p) for p in parts])
                except ValueError:
                    pass
            elif parts and parts[0] in ("1", "0") and "PAGE" in lines[i]:
                pass
            i += 1
    tables = []
    for key in order:
        subcase, point, method, mach, ratio = key
        a = np.array(groups[key]).reshape(-1, 9 if method == "PKNL" else 7)
        if method == "PKNL":
            tables.append(FlutterTable(point, method, mach, ratio, a[:, 0], a[:, 4], a[:, 5],
                                       a[:, 6], a[:, 2], a[:, 3], a[:, 7] + 1j * a[:, 8],
                                       subcase))
        else:
            tables.append(FlutterTable(point, method, mach, ratio, a[:, 0], a[:, 2], a[:, 3],
                                       a[:, 4], None, None, a[:, 5] + 1j * a[:, 6], subcase))
    return tables
