"""``rom.npz``: the file form of a :class:`NonlinearROM` (DESIGN "Files", contract).

Arrays: M, K1, K2, K3, D1, D2, D3 (damping at γ = 1), ``mode_kinds`` (strings),
``frequencies_hz``, ``output_names`` + ``output_matrix`` (rows of the basis giving physical
outputs), ``metadata_json`` and ``format_version``; and, for a ROM identified from a deck, its
basis on the deck's grids (``shape_*``: :class:`~torchrom.rom.shapes.MeshShapes`; files written
before have none and still load); for a ROM about a deformed state, ``reference_q``,
``reference_force`` and ``reference_condition_json`` (:mod:`.reference`). Written
atomically with numpy; loading checks the version, the keys, the shapes, symmetries and
finiteness (through the constructor) and names the file and what is wrong.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import atomic_path
from . import reference
from .shapes import MeshShapes

FORMAT = "torchrom-rom"
FORMAT_VERSION = 1
_REQUIRED = ("format", "format_version", "M", "K1", "K2", "K3", "D1", "D2", "D3")


def save_rom(rom, path) -> Path:
    path = Path(path)
    names, C = rom.output_matrix()
    arrays = {name: getattr(rom, name).numpy() for name in rom.TENSORS}
    arrays.update(
        format=np.array(FORMAT),
        format_version=np.array(FORMAT_VERSION),
        mode_kinds=np.array(rom.mode_kinds, dtype=str),
        frequencies_hz=np.asarray(rom.frequencies_hz, dtype=float),
        output_names=np.array(names, dtype=str),
        output_matrix=np.asarray(C, dtype=float).reshape(len(names), rom.n),
        metadata_json=np.array(json.dumps(rom.metadata, default=str)),
    )
    if rom.shapes is not None:
        arrays.update(rom.shapes.to_arrays())
    arrays.update(reference.to_arrays(getattr(rom, "reference", None)))
    with atomic_path(path) as tmp:
        np.savez(tmp, **arrays)
    return path


def load_rom(path, cls):
    """The ROM stored in ``path``, built by ``cls`` (:meth:`NonlinearROM.load` passes itself:
    this module never imports the model, so the two have no import circle)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such ROM file")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError(f"{path}: not a readable rom.npz file ({exc})") from None
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise InputError(f"{path}: not a torchrom rom.npz: missing arrays {missing}")
    if str(data["format"]) != FORMAT:
        raise InputError(f"{path}: format is {str(data['format'])!r}, expected {FORMAT!r}")
    version = int(data["format_version"])
    if version > FORMAT_VERSION:
        raise InputError(
            f"{path}: format_version {version} is newer than this torchrom reads "
            f"({FORMAT_VERSION}); upgrade torchrom"
        )
    names = [str(s) for s in data.get("output_names", np.array([], dtype=str)).tolist()]
    C = data.get("output_matrix", np.zeros((0, data["M"].shape[0])))
    if len(names) != C.shape[0]:
        raise InputError(f"{path}: output_names has {len(names)} names but output_matrix has "
                         f"{C.shape[0]} rows")
    try:
        metadata = json.loads(str(data.get("metadata_json", "{}")))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: metadata_json is not valid JSON ({exc})") from None
    shapes = MeshShapes.from_arrays(data, str(path))
    try:
        return cls(
            *(data[name] for name in cls.TENSORS),
            mode_kinds=[str(s) for s in data["mode_kinds"].tolist()] if "mode_kinds" in data
            else None,
            frequencies_hz=data.get("frequencies_hz"),
            outputs=dict(zip(names, C)),
            metadata=metadata,
            shapes=shapes,
            reference=reference.from_arrays(data, str(path)),
        )
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
