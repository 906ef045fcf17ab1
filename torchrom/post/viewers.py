"""A :class:`~torchrom.post.motions.Motion` as files the viewers open: VTU, XDMF, OP2.

- ``.vtu`` (ParaView, VisIt; meshio): the undeformed mesh with every frame as point data,
  ``displacement_<key>`` (translations, length unit) and ``rotation_<key>`` (rad), e.g.
  ``displacement_mode2`` or ``displacement_t07``; a complex mode adds ``displacement_real`` and
  ``displacement_imag``. ParaView's "Warp By Vector" draws any of them. float64.
- ``.xdmf`` (ParaView time series; meshio's XDMF writer, data inline as XML): one time step per
  frame, the step's time being the frame's value (mode number, phase in degrees, t in s), point
  data ``displacement`` and ``rotation``. meshio 5.3.5 cannot write line cells beside faces in
  one XDMF grid (its mixed topology writer fails on lines), so a mesh with faces keeps its faces
  there and its lines in the VTU and OP2 only. float64.
- ``.op2`` (pyNastran's OP2 writer; Nastran post-processors with the deck as geometry): modes
  as a real eigenvector table (OUGV1, eigenvalue ω², cycles Hz), the flutter mode as a complex
  eigenvector (s = σ + iω) followed by its phase frames as a transient table, an LCO period as a
  transient displacement table (times in s). pyNastran writes 32-bit OP2 only: the values are
  the float32 roundings of torchrom's. Components are in the basic frame (the frame
  ``MeshShapes`` keeps), which is the grids' output frame for a deck without CD frames.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import atomic_path
from .motions import Motion

#: output formats by file suffix
FORMATS = (".vtu", ".xdmf", ".op2")


def _cells(motion: Motion, lines: bool = True) -> list[tuple[str, np.ndarray]]:
    s = motion.shapes
    cells = [(name, a) for name, a in (("quad", s.quads), ("triangle", s.trias)) if len(a)]
    if lines and len(s.lines):
        cells.append(("line", s.lines))
    if not cells:  # a mesh of springs or solids only: its grids as vertices
        cells = [("vertex", np.arange(s.n_grid).reshape(-1, 1))]
    return cells


def write_vtu(path, motion: Motion) -> Path:
    """The VTU file of ``motion`` (module docstring), written atomically."""
    import meshio

    data = {}
    for key, u in zip(motion.keys, motion.displacements):
        data[f"displacement_{key}"] = u[:, :3]
        data[f"rotation_{key}"] = u[:, 3:]
    if motion.complex_shape is not None:
        data["displacement_real"] = motion.complex_shape.real[:, :3].copy()
        data["displacement_imag"] = motion.complex_shape.imag[:, :3].copy()
    mesh = meshio.Mesh(motion.shapes.xyz, _cells(motion), point_data=data)
    path = Path(path)
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
    return path


def write_xdmf(path, motion: Motion) -> Path:
    """The XDMF time series of ``motion`` (module docstring), written atomically."""
    import meshio

    cells = _cells(motion, lines=not (len(motion.shapes.quads) or len(motion.shapes.trias)))
    path = Path(path)
    with atomic_path(path) as tmp:
        with meshio.xdmf.TimeSeriesWriter(tmp, data_format="XML") as w:
            w.write_points_cells(motion.shapes.xyz, cells)
            steps = (np.arange(1, len(motion.keys) + 1) if motion.kind == "modes"
                     else motion.values)
            for t, u in zip(steps, motion.displacements):
                w.write_data(float(t), point_data={"displacement": u[:, :3],
                                                   "rotation": u[:, 3:]})
    return path


def _table(cls, node_gridtype, data, subcase, title, *case):
    """A pyNastran OUGV1 table of ``cls`` (``case``: its add-method's own arguments)."""
    add = {"RealEigenvectorArray": "add_modal_case",
           "ComplexEigenvectorArray": "add_complex_modes_case"}.get(cls.__name__,
                                                                    "add_transient_case")
    # an OP2 title is 128 ASCII bytes (γ, ° and the like become "?")
    title = title.encode("ascii", "replace").decode()[:128]
    obj = getattr(cls, add)("OUGV1", node_gridtype, data, subcase, *case, title=title)
    if add != "add_transient_case":
        obj.table_code, obj.tCode = 7, 7001  # Nastran's eigenvector table code (OUGV1)
    return obj


def write_op2(path, motion: Motion) -> Path:
    """The OP2 file of ``motion`` (module docstring), written atomically."""
    from pyNastran.op2.op2 import OP2
    from pyNastran.op2.tables.oug.oug_displacements import RealDisplacementArray
    from pyNastran.op2.tables.oug.oug_eigenvectors import (
        ComplexEigenvectorArray,
        RealEigenvectorArray,
    )

    s = motion.shapes
    if s.grid_ids.max(initial=0) >= 2**31:
        raise InputError(f"OP2: grid id {s.grid_ids.max()} beyond a 32-bit OP2's")
    ng = np.column_stack([s.grid_ids, np.ones(s.n_grid, dtype=np.int64)])  # type 1: GRID
    op2 = OP2(debug=None, log=None, mode="msc")
    title = motion.title
    F = len(motion.keys)
    if motion.kind == "modes":
        w = 2 * np.pi * np.nan_to_num(motion.values)
        op2.eigenvectors[1] = _table(RealEigenvectorArray, ng, motion.displacements, 1, title,
                                     np.arange(1, F + 1), w**2, np.nan_to_num(motion.values))
    else:
        if motion.complex_shape is not None:
            s_ = motion.eigenvalue or 0j
            op2.eigenvectors[1] = _table(ComplexEigenvectorArray, ng,
                                         motion.complex_shape[None], 1, title, np.array([1]),
                                         np.array([s_.real]), np.array([s_.imag]))
        sub = 2 if motion.complex_shape is not None else 1
        op2.displacements[sub] = _table(RealDisplacementArray, ng, motion.displacements, sub,
                                        title, motion.values)
    path = Path(path)
    with atomic_path(path) as tmp, warnings.catch_warnings():
        # pyNastran warns that it rounds float64 to the 32-bit OP2 (module docstring)
        warnings.simplefilter("ignore", UserWarning)
        op2.write_op2(str(tmp), post=-1, endian=b"<", nastran_format="msc")
    return path


WRITERS = {".vtu": write_vtu, ".xdmf": write_xdmf, ".op2": write_op2}


def write_motion(path, motion: Motion) -> Path:
    """``motion`` in the format of ``path``'s suffix (:data:`FORMATS`)."""
    path = Path(path)
    writer = WRITERS.get(path.suffix.lower())
    if writer is None:
        raise InputError(f"{path}: expected a file name ending in one of {', '.join(FORMATS)}")
    return writer(path, motion)
