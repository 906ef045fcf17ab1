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

:func:`goland_pipelines` builds the pipelines of several damping methods (the study's and its
exact-damping check's) into their folders at once: one FE identification for the ROMs not
cached (the basis and stiffness do not depend on the damping) and one aerodynamics computation.

Glue over torchrom.fe, torchrom.identify and torchrom.aero.
"""

from __future__ import annotations

import hashlib
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
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
    opt = options or GolandPipeline()
    return goland_pipelines(opt, {opt.damping: folder}, force=force, log=log)[opt.damping]


def goland_pipelines(options: GolandPipeline, folders: dict[str, Any], *, force: bool = False,
                     log: Callable[[str], None] = print) -> dict[str, PipelineResult]:
    """The pipeline of ``options`` with each damping method of ``folders`` ({"decomposition":
    folder, "exact": folder}), each into (or reused from) its own folder, as
    :func:`goland_pipeline` would build it alone — with the FE work shared: the ROMs that are
    not cached come from one identification (:func:`torchrom.identify.build.
    identify_each_damping`: the same basis and stiffness bit for bit) and the aerodynamics,
    which depend on the basis only, are computed once. Every folder is locked for the run."""
    from contextlib import ExitStack

    from ..locks import folder_lock

    for method in folders:
        if method not in DAMPING_METHODS:
            raise InputError(f"goland pipeline: damping: expected one of {DAMPING_METHODS}, "
                             f"got {method!r}")
    with ExitStack() as stack:
        for folder in folders.values():
            stack.enter_context(folder_lock(folder, "building the Goland model", wait=True,
                                            log=log))
        return _goland_pipelines(options, folders, force, log)


def _goland_pipelines(base: GolandPipeline, folders: dict[str, Any], force: bool, log
                      ) -> dict[str, PipelineResult]:
    from ..fe import goland

    opts = {m: replace(base, damping=m) for m in folders}
    caches = {m: FileCache(folder, force=force) for m, folder in folders.items()}
    seconds: dict[str, dict[str, float]] = {m: {} for m in folders}
    files: dict[str, dict[str, Path]] = {m: {} for m in folders}

    t0 = time.perf_counter()
    fe = goland(variant=base.variant)
    deck = _deck_text(fe)
    deck_hash = hashlib.sha256(deck.encode()).hexdigest()
    fe_key = FileCache.key({"stage": "fe", "deck_sha256": deck_hash})

    def write_deck(p):
        with atomic_path(p) as tmp:
            tmp.write_text(deck)

    for m, cache in caches.items():
        path = cache.get("goland.bdf", fe_key)
        if path is None:
            where = "goland.bdf" if len(folders) == 1 else cache.folder / "goland.bdf"
            log(f"goland: heavy Goland wing FE model -> {where}")
            path = cache.put("goland.bdf", fe_key, write_deck)
        files[m]["goland.bdf"] = path
    fe_seconds = time.perf_counter() - t0

    # -- identification (one FE pass for every ROM not cached) ----------------------------------
    combinations = dual_combinations(fe, base)
    rom_keys = {m: FileCache.key({"stage": "rom", "fe": fe_key, "damping": m,
                                  "n_linear": base.n_linear, "n_dual": base.n_dual,
                                  "dual_amplitudes": base.dual_amplitudes,
                                  "dual_combinations": [list(c) for c in combinations]})
                for m in folders}
    roms: dict[str, NonlinearROM] = {}
    identification: dict[str, dict[str, Any] | None] = {m: None for m in folders}
    Phi = None
    t0 = time.perf_counter()
    missing = []
    for m, cache in caches.items():
        rom_path, basis_path = (cache.get("rom.npz", rom_keys[m]),
                                cache.get("basis.npz", rom_keys[m]))
        if rom_path is None or basis_path is None:
            missing.append(m)
        else:
            log(f"identify: reusing {rom_path}")
            roms[m] = NonlinearROM.load(rom_path)
            files[m]["rom.npz"], files[m]["basis.npz"] = rom_path, basis_path
    if missing:
        log(f"identify: {base.n_linear}L{base.n_dual}D ROM, damping "
            f"{' and '.join(repr(m) for m in missing)} (the FE model does the work: dual modes, "
            f"tangents)")
        for m, (rom, Phi, summary) in _identify(fe, base, combinations, missing).items():
            cache = caches[m]
            roms[m], identification[m] = rom, summary
            files[m]["rom.npz"] = cache.put("rom.npz", rom_keys[m], rom.save)
            files[m]["basis.npz"] = cache.put(
                "basis.npz", rom_keys[m], lambda p, Phi=Phi, rom=rom: _save_basis(p, Phi, rom))
    id_seconds = time.perf_counter() - t0

    # -- aerodynamics on the ROM's basis (the basis does not depend on the damping) ------------
    aero_keys = {m: FileCache.key({"stage": "aero", "rom": rom_keys[m], "mach": base.mach,
                                   "modes": base.aero_modes, "lags": base.lags,
                                   "boxes": list(base.boxes), "k": list(base.k_list)})
                 for m in folders}
    aeros: dict[str, AeroData] = {}
    t0 = time.perf_counter()
    shared = None
    for m, cache in caches.items():
        aero_path = cache.get("aero.npz", aero_keys[m])
        if aero_path is None:
            if shared is None:
                log(f"aero: DLM GAFs on the ROM's first {base.aero_modes} modes, Mach "
                    f"{base.mach:g}, {base.boxes[0]}x{base.boxes[1]} boxes per half wing, "
                    f"{len(base.k_list)} reduced frequencies; minimum-state RFA with "
                    f"{base.lags} lags")
                shared = aero_on_basis(fe, np.load(files[m]["basis.npz"])["Phi"], roms[m],
                                       base)
            aero_path = cache.put("aero.npz", aero_keys[m],
                                  lambda p, a=shared: a.save(p, force=True))
            aeros[m] = AeroData.load(aero_path) if len(folders) > 1 else shared
        else:
            log(f"aero: reusing {aero_path}")
            aeros[m] = AeroData.load(aero_path)
        files[m]["aero.npz"] = aero_path
    aero_seconds = time.perf_counter() - t0

    # -- flutter (per damping) ------------------------------------------------------------------
    fe_modes = fe.modes(base.aero_modes)
    kinds = [str(k) for k in fe_modes.kinds]
    contents = [{k: round(float(v), 4) for k, v in c.items()} for c in fe_modes.fractions]
    results = {}
    for m, cache in caches.items():
        opt = opts[m]
        model = AeroelasticModel(roms[m], aeros[m], opt.baseline_alpha, opt.baseline_gamma,
                                 altitude_range=tuple(opt.altitude_range_ft),
                                 altitude_unit="ft")
        fl_key = FileCache.key({"stage": "flutter", "rom": rom_keys[m], "aero": aero_keys[m],
                                "kinds": kinds, "contents": contents,
                                "alpha": opt.baseline_alpha, "gamma": opt.baseline_gamma,
                                "range": list(opt.altitude_range_ft)})
        summary = cache.get_json("flutter.json", fl_key)
        fl_path = cache.folder / "flutter.json"
        t0 = time.perf_counter()
        if summary is None:
            log("flutter: baseline damping, state space (Eqs. 49-50) and p-k; Table 3")
            summary = flutter_summary(model, kinds, contents)
            fl_path = cache.put("flutter.json", fl_key,
                                lambda p, s=summary: write_json_atomic(p, s))
        else:
            log(f"flutter: reusing {fl_path}")
        files[m]["flutter.json"] = fl_path
        # the shared stages' time is counted once, with the first damping method's
        first = m == next(iter(folders))
        seconds[m] = {"fe": fe_seconds if first else 0.0,
                      "identify": id_seconds if first else 0.0,
                      "aero": aero_seconds if first else 0.0,
                      "flutter": time.perf_counter() - t0}
        results[m] = PipelineResult(model, summary, files[m], seconds[m], list(cache.hits),
                                    identification[m])
    return results


def dual_combinations(fe, opt: GolandPipeline) -> tuple[tuple[int, int], ...]:
    """The dual-mode combinations of ``opt`` on ``fe`` (a rule resolved from the modes' kinds)."""
    if not isinstance(opt.dual_combinations, str):
        return tuple(tuple(c) for c in opt.dual_combinations)
    kinds = ([str(k) for k in fe.modes(opt.n_linear).kinds]
             if opt.dual_combinations == TRANSVERSE_RULE else None)
    return parse_combinations(opt.dual_combinations, "goland pipeline: dual_combinations", kinds)


def _identify(fe, opt: GolandPipeline, combinations, methods
              ) -> dict[str, tuple[NonlinearROM, np.ndarray, dict[str, Any]]]:
    """(ROM, basis Φ, summary) of each damping method in ``methods``, from one FE
    identification."""
    from ..identify import DualModeOptions, IdentifyOptions
    from ..identify.build import as_backend, identify_each_damping

    options = IdentifyOptions(n_linear=opt.n_linear, n_dual=opt.n_dual, damping=methods[0],
                              dual=DualModeOptions(n_amplitudes=opt.dual_amplitudes,
                                                   combinations=combinations))
    span = as_backend(fe).reference_length
    out = {}
    for m, res in identify_each_damping(fe, options, methods).items():
        rom = res.rom.replace(metadata={**res.rom.metadata, "span": float(span)})
        out[m] = (rom, res.basis.Phi, res.summary())
    return out


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
                             model.altitude_range, altitude_unit=model.altitude_unit)
    alts = sorted(PAPER_TABLE3)
    f_ss = growing_response_frequency(st, model.aero.rfa, model.mach, alts)
    f_pk = growing_response_frequency_pk(st, AeroTable.from_gaf(model.aero.gaf), model.mach,
                                         alts, start_altitude=max(model.altitude_range))
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
