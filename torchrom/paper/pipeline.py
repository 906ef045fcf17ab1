"""The built-in Goland pipeline: FE model -> identified ROM -> aerodynamics -> flutter, cached.

Stages (each a file in the cache folder, rebuilt only when the hash of its inputs changes):

1. ``goland.bdf``   the heavy Goland wing of :func:`torchrom.fe.goland`, the variant of
                    :attr:`GolandPipeline.variant` (default the updated wing; the key is the
                    hash of the deck's own text, so a change of the FE defaults is seen even
                    without a version change);
2. ``rom.npz``      the 9L12D ROM identified non-intrusively (:func:`torchrom.identify.identify`,
                    damping "decomposition" as in the paper, or "exact"), plus ``basis.npz``
                    (the basis Φ on the FE's free DOFs);
3. ``aero.npz``     DLM GAFs and the minimum-state RFA computed on exactly the ROM's first m
                    basis functions (the identification's Φ, expanded to the grids), with the
                    modes' values at the output points recorded for the consistency check of
                    :func:`torchrom.sim.aeroelastic.check_aero_matches_rom`;
4. ``flutter.json`` flutter of the baseline damping (α0, β0 of Eq. 46) by state-space
                    eigenvalues (Eqs. 49–50) and by p-k on the GAF table, the growing-response
                    frequencies of Table 3 and the modal frequencies against Table 2.

Glue over torchrom.fe, torchrom.identify and torchrom.aero.
"""

from __future__ import annotations

import hashlib
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..aero.build import (
    BASELINE_ALPHA,
    BASELINE_GAMMA,
    GOLAND_K_LIST,
    PAPER_FLUTTER_ALTITUDE_FT,
    PAPER_FLUTTER_FREQUENCY_HZ,
    PAPER_TABLE3,
    ModalData,
    _element_grid_mask,
    build_from_modes,
)
from ..aero.files import AeroData
from ..errors import InputError
from ..fe.goland import DEFAULT_VARIANT, GOLAND_VARIANTS
from ..identify.basis import TRANSVERSE_RULE, parse_combinations
from ..io import atomic_path, write_json_atomic
from ..reference import paper_reference
from ..rom import NonlinearROM
from ..sim.aeroelastic import mode_outputs
from ..study.models import ALTITUDE_RANGE_FT, AeroelasticModel, ModelProvider
from .cache import FileCache

#: the paper's Table 2 natural frequencies (Hz) and what it says of the first five modes
PAPER_TABLE2_HZ = paper_reference().table2_hz
PAPER_MODE_KINDS = paper_reference().table2_kinds
DAMPING_METHODS = ("decomposition", "exact")


@dataclass(frozen=True)
class GolandPipeline:
    """Options of the built-in Goland pipeline (paper Secs. III.A–C defaults).

    variant: the heavy Goland wing (:data:`torchrom.fe.goland.GOLAND_VARIANTS`, default
    "updated");
    damping: "decomposition" (paper) or "exact" (FE material tangent);
    n_linear, n_dual: basis size (9L12D); dual_amplitudes: static loads per dual combination;
    dual_combinations: the linear-mode pairs loaded for the dual modes (1-based pairs, a named
    set, or the default rule "transverse" chosen from the modes' kinds, see
    :mod:`torchrom.identify.basis`, "Combinations");
    mach, aero_modes, lags: aerodynamics (Mach 0.70, m = 9 modes, 13 lag states);
    boxes: DLM boxes per half wing (chordwise, spanwise); k_list: reduced frequencies;
    baseline_alpha, baseline_gamma: the FE model's Rayleigh damping (Eq. 46);
    altitude_range_ft: where the flutter point is searched.
    """

    variant: str = DEFAULT_VARIANT
    damping: str = "decomposition"
    n_linear: int = 9
    n_dual: int = 12
    dual_amplitudes: int = 20
    dual_combinations: tuple[tuple[int, int], ...] | str = TRANSVERSE_RULE
    mach: float = 0.7
    aero_modes: int = 9
    lags: int = 13
    boxes: tuple[int, int] = (8, 20)
    k_list: tuple[float, ...] = GOLAND_K_LIST
    baseline_alpha: float = BASELINE_ALPHA
    baseline_gamma: float = BASELINE_GAMMA
    altitude_range_ft: tuple[float, float] = ALTITUDE_RANGE_FT

    def __post_init__(self):
        if self.variant not in GOLAND_VARIANTS:
            raise InputError(f"goland pipeline: variant: expected one of {GOLAND_VARIANTS}, got "
                             f"{self.variant!r}")
        if isinstance(self.dual_combinations, str) and self.dual_combinations != TRANSVERSE_RULE:
            parse_combinations(self.dual_combinations, "goland pipeline: dual_combinations")
        if self.damping not in DAMPING_METHODS:
            raise InputError(f"goland pipeline: damping: expected one of {DAMPING_METHODS}, got "
                             f"{self.damping!r}")
        if not 1 <= self.aero_modes <= self.n_linear:
            raise InputError(f"goland pipeline: aero_modes: expected 1..n_linear = "
                             f"{self.n_linear}, got {self.aero_modes}")
        if len(self.boxes) != 2 or min(self.boxes) < 1:
            raise InputError(f"goland pipeline: boxes: expected two positive integers, got "
                             f"{self.boxes!r}")

    @classmethod
    def from_table(cls, table: dict[str, Any], where: str = "[model]") -> GolandPipeline:
        """From a TOML table (keys are the field names; lists for tuples)."""
        names = {f for f in cls.__dataclass_fields__}
        unknown = sorted(set(table) - names)
        if unknown:
            raise InputError(f"{where}: unknown key {unknown[0]!r}; expected one of "
                             f"{sorted(names)}")
        values = {k: tuple(tuple(x) if isinstance(x, list) else x for x in v)
                  if isinstance(v, list) else v for k, v in table.items()}
        try:
            return cls(**values)
        except TypeError as exc:
            raise InputError(f"{where}: bad value ({exc})") from None

    def as_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


@dataclass
class PipelineResult:
    """What the pipeline produced: the aeroelastic model, the flutter summary, file paths,
    per-stage seconds (0 when reused) and the identification summary (None when reused)."""

    model: AeroelasticModel
    flutter: dict[str, Any]
    files: dict[str, Path]
    seconds: dict[str, float] = field(default_factory=dict)
    reused: list[str] = field(default_factory=list)
    identification: dict[str, Any] | None = None

    @property
    def rom(self) -> NonlinearROM:
        return self.model.rom

    @property
    def aero(self) -> AeroData:
        return self.model.aero


def _deck_text(fe) -> str:
    from ..fe import write_bdf

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "goland.bdf"
        write_bdf(fe, path)
        return path.read_text()


def goland_pipeline(options: GolandPipeline | None = None, folder=None, *, force: bool = False,
                    log: Callable[[str], None] = print) -> PipelineResult:
    """Run (or reuse from ``folder``) the Goland pipeline (see the module docstring). The
    folder is locked for the run (:mod:`torchrom.locks`): a second process building into it
    waits, then reuses what the first one built."""
    from ..locks import folder_lock

    with folder_lock(folder, "building the Goland model", wait=True, log=log):
        return _goland_pipeline(options or GolandPipeline(), folder, force, log)


def _goland_pipeline(opt: GolandPipeline, folder, force: bool, log) -> PipelineResult:
    from ..fe import goland

    cache = FileCache(folder, force=force)
    seconds: dict[str, float] = {}
    files: dict[str, Path] = {}

    t0 = time.perf_counter()
    fe = goland(variant=opt.variant)
    deck = _deck_text(fe)
    deck_hash = hashlib.sha256(deck.encode()).hexdigest()
    fe_key = FileCache.key({"stage": "fe", "deck_sha256": deck_hash})
    path = cache.get("goland.bdf", fe_key)
    if path is None:
        log("goland: heavy Goland wing FE model -> goland.bdf")

        def write_deck(p):
            with atomic_path(p) as tmp:
                tmp.write_text(deck)

        path = cache.put("goland.bdf", fe_key, write_deck)
    files["goland.bdf"] = path
    seconds["fe"] = time.perf_counter() - t0

    # -- identification -------------------------------------------------------------------------
    combinations = dual_combinations(fe, opt)
    id_inputs = {"stage": "rom", "fe": fe_key, "damping": opt.damping, "n_linear": opt.n_linear,
                 "n_dual": opt.n_dual, "dual_amplitudes": opt.dual_amplitudes,
                 "dual_combinations": [list(c) for c in combinations]}
    rom_key = FileCache.key(id_inputs)
    rom_path, basis_path = cache.get("rom.npz", rom_key), cache.get("basis.npz", rom_key)
    identification = None
    t0 = time.perf_counter()
    if rom_path is None or basis_path is None:
        log(f"identify: {opt.n_linear}L{opt.n_dual}D ROM, damping '{opt.damping}' (the FE model "
            f"does the work: dual modes, tangents)")
        rom, Phi, identification = _identify(fe, opt, combinations)
        rom_path = cache.put("rom.npz", rom_key, rom.save)
        basis_path = cache.put("basis.npz", rom_key, lambda p: _save_basis(p, Phi, rom))
    else:
        log(f"identify: reusing {rom_path}")
        rom = NonlinearROM.load(rom_path)
    files["rom.npz"], files["basis.npz"] = rom_path, basis_path
    seconds["identify"] = time.perf_counter() - t0

    # -- aerodynamics on the ROM's basis ----------------------------------------------------------
    aero_inputs = {"stage": "aero", "rom": rom_key, "mach": opt.mach, "modes": opt.aero_modes,
                   "lags": opt.lags, "boxes": list(opt.boxes), "k": list(opt.k_list)}
    aero_key = FileCache.key(aero_inputs)
    aero_path = cache.get("aero.npz", aero_key)
    t0 = time.perf_counter()
    if aero_path is None:
        log(f"aero: DLM GAFs on the ROM's first {opt.aero_modes} modes, Mach {opt.mach:g}, "
            f"{opt.boxes[0]}x{opt.boxes[1]} boxes per half wing, {len(opt.k_list)} reduced "
            f"frequencies; minimum-state RFA with {opt.lags} lags")
        aero = aero_on_basis(fe, np.load(basis_path)["Phi"], rom, opt)
        aero_path = cache.put("aero.npz", aero_key, lambda p: aero.save(p, force=True))
    else:
        log(f"aero: reusing {aero_path}")
        aero = AeroData.load(aero_path)
    files["aero.npz"] = aero_path
    seconds["aero"] = time.perf_counter() - t0

    model = AeroelasticModel(rom, aero, opt.baseline_alpha, opt.baseline_gamma,
                             altitude_range_ft=tuple(opt.altitude_range_ft))

    # -- flutter --------------------------------------------------------------------------------
    fe_modes = fe.modes(opt.aero_modes)
    kinds = [str(k) for k in fe_modes.kinds]
    contents = [{k: round(float(v), 4) for k, v in c.items()} for c in fe_modes.fractions]
    fl_inputs = {"stage": "flutter", "rom": rom_key, "aero": aero_key, "kinds": kinds,
                 "contents": contents,
                 "alpha": opt.baseline_alpha, "gamma": opt.baseline_gamma,
                 "range": list(opt.altitude_range_ft)}
    fl_key = FileCache.key(fl_inputs)
    summary = cache.get_json("flutter.json", fl_key)
    fl_path = cache.folder / "flutter.json"
    t0 = time.perf_counter()
    if summary is None:
        log("flutter: baseline damping, state space (Eqs. 49-50) and p-k; Table 3")
        summary = flutter_summary(model, kinds, contents)
        fl_path = cache.put("flutter.json", fl_key, lambda p: write_json_atomic(p, summary))
    else:
        log(f"flutter: reusing {fl_path}")
    files["flutter.json"] = fl_path
    seconds["flutter"] = time.perf_counter() - t0
    return PipelineResult(model, summary, files, seconds, list(cache.hits), identification)


def dual_combinations(fe, opt: GolandPipeline) -> tuple[tuple[int, int], ...]:
    """The dual-mode combinations of ``opt`` on ``fe`` (a rule resolved from the modes' kinds)."""
    if not isinstance(opt.dual_combinations, str):
        return tuple(tuple(c) for c in opt.dual_combinations)
    kinds = ([str(k) for k in fe.modes(opt.n_linear).kinds]
             if opt.dual_combinations == TRANSVERSE_RULE else None)
    return parse_combinations(opt.dual_combinations, "goland pipeline: dual_combinations", kinds)


def _identify(fe, opt: GolandPipeline, combinations):
    from ..identify import DualModeOptions, IdentifyOptions, identify
    from ..identify.build import as_backend

    options = IdentifyOptions(n_linear=opt.n_linear, n_dual=opt.n_dual, damping=opt.damping,
                              dual=DualModeOptions(n_amplitudes=opt.dual_amplitudes,
                                                   combinations=combinations))
    res = identify(fe, options)
    span = as_backend(fe).reference_length
    rom = res.rom.replace(metadata={**res.rom.metadata, "span": float(span)})
    return rom, res.basis.Phi, res.summary()


def _save_basis(path: Path, Phi: np.ndarray, rom: NonlinearROM) -> None:
    with atomic_path(path) as tmp:
        np.savez(tmp, Phi=Phi, kinds=np.array(rom.mode_kinds),
                 frequencies_hz=np.asarray(rom.frequencies_hz))


def aero_on_basis(fe, Phi: np.ndarray, rom: NonlinearROM, opt: GolandPipeline) -> AeroData:
    """GAF + RFA computed on the ROM's first ``opt.aero_modes`` basis functions ``Phi[:, :m]``
    (free-DOF vectors of ``fe``), so the aerodynamic modes are the ROM's modes by construction."""
    from ..aero.panels import goland_panels

    m = opt.aero_modes
    shapes = np.asarray(Phi, dtype=float)[:, :m]
    grid_ids = np.asarray(fe.grid_ids)
    modes = ModalData(
        frequencies_hz=np.asarray(rom.frequencies_hz[:m], dtype=float),
        grid_ids=grid_ids,
        grid_xyz=np.asarray(fe.grid_xyz, dtype=float),
        displacements=np.asarray(fe.expand(shapes), dtype=float).reshape(m, -1, 6),
        element_grids=_element_grid_mask(fe, grid_ids),
    )
    aero = build_from_modes(modes, opt.mach, opt.lags, opt.k_list, goland_panels(*opt.boxes))
    aero.metadata.update({"source": "goland pipeline (ROM basis)", "boxes": list(opt.boxes),
                          "mode_outputs": mode_outputs(rom, m)})
    return aero


def flutter_summary(model: AeroelasticModel, mode_kinds=None, contents=None) -> dict[str, Any]:
    """Baseline flutter (state space and p-k), Table 3 and Table 2 comparisons (JSON-ready);
    ``mode_kinds``: the FE's classification of the modes (bending, torsion, in-plane, ...),
    ``contents``: each mode's content shares ({kind: share}, :func:`torchrom.fe.kinds.classify`).
    """
    from ..aero.flutter import (
        AeroTable,
        flutter_altitude_pk,
        growing_response_frequency,
        growing_response_frequency_pk,
    )

    st = model.structure(model.baseline_alpha, model.baseline_gamma)
    ss = model.baseline_flutter()
    pk = flutter_altitude_pk(st, AeroTable.from_gaf(model.aero.gaf), model.mach,
                             model.altitude_range_ft)
    alts = sorted(PAPER_TABLE3)
    f_ss = growing_response_frequency(st, model.aero.rfa, model.mach, alts)
    f_pk = growing_response_frequency_pk(st, AeroTable.from_gaf(model.aero.gaf), model.mach,
                                         alts, start_altitude=max(model.altitude_range_ft))
    freqs = [float(f) for f in np.asarray(model.rom.frequencies_hz)[:len(PAPER_TABLE2_HZ)]]
    return {
        "mach": model.mach,
        "baseline_alpha": model.baseline_alpha,
        "baseline_gamma": model.baseline_gamma,
        "state_space": ss.as_dict(),
        "pk": pk.as_dict(),
        "paper": {"altitude": PAPER_FLUTTER_ALTITUDE_FT,
                  "frequency_hz": PAPER_FLUTTER_FREQUENCY_HZ},
        "table3": [{"altitude_ft": a, "state_space_hz": float(fs), "pk_hz": float(fp),
                    "paper_hz": PAPER_TABLE3[a]} for a, fs, fp in zip(alts, f_ss, f_pk)],
        "table2": [{"mode": i + 1, "frequency_hz": f, "paper_hz": p,
                    "diff_pct": 100.0 * (f - p) / p,
                    "kind": None if mode_kinds is None or i >= len(mode_kinds) else mode_kinds[i],
                    "content": None if contents is None or i >= len(contents) else contents[i],
                    "paper_kind": PAPER_MODE_KINDS[i] if i < len(PAPER_MODE_KINDS) else None}
                   for i, (f, p) in enumerate(zip(freqs, PAPER_TABLE2_HZ))],
        "rfa_fit_error": model.aero.rfa.fit_error,
    }


# -- the built-in model of sweep configurations ([model] builtin = "goland") --------------------
def _check_goland_table(table: dict[str, Any]) -> GolandPipeline:
    return GolandPipeline.from_table(table)


def _build_goland(table: dict[str, Any], folder: Path) -> AeroelasticModel:
    return goland_pipeline(GolandPipeline.from_table(table), folder).model


#: registered as the ``goland`` entry point of ``torchrom.models`` (pyproject.toml)
GOLAND_MODEL = ModelProvider(check=_check_goland_table, build=_build_goland)
