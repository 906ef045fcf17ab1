"""Model-updating targets and parameters: dataclasses and their TOML file (``--targets``).

Parsing by tomllib; validation hand-written (each error names the file, table and key). Format::

    [modes]
    n = 12                  # modes computed at each evaluation (default 2 × targets + 2)
    pairing = "mac"         # "mac" (default): pair once, then track the shapes by MAC;
                            # "kind": re-pair by kind and frequency order at every evaluation

    [reference]             # optional: reference shapes (modes of a deck on the same grids)
    deck = "reference.bdf"  # relative to the targets file

    [optimizer]             # optional
    max_evaluations = 200
    tolerance = 1e-10       # ftol = xtol = gtol of scipy.optimize.least_squares
    regularization = 0.0    # weight of ‖x − x0‖² (x: parameters scaled to [0, 1] by bounds)

    [[target]]
    frequency_hz = 1.69
    kind = "bending"        # bending | torsion | in-plane | axial | transverse | any (default)
    mode = 1                # optional: reference-deck mode (or initial-model mode) to pair with
    weight = 1.0
    name = "1st bending"    # optional

    [[parameter]]
    name = "nsm_le"
    card = "PROD"           # PSHELL | PSHEAR | PROD | PBAR | MAT1 | CONM2
    ids = [12]              # property / material / CONM2 element ids (all set to one value)
    field = "nsm"           # see FIELDS
    lower = 0.0
    upper = 5.0
    initial = 0.1           # optional (default: the deck's value, equal on all ids)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError
from ..io import check_referenced_path, read_toml
from .mac import TARGET_KINDS

#: Updatable card fields: card → field → (pyNastran attribute, index in it or None, whether the
#: field changes the stiffness). Mass fields (nsm, rho, mass, CONM2 offsets and inertias) only
#: change the mass matrix.
FIELDS: dict[str, dict[str, tuple[str, int | None, bool]]] = {
    "PSHELL": {"nsm": ("nsm", None, False), "t": ("t", None, True)},
    "PSHEAR": {"nsm": ("nsm", None, False), "t": ("t", None, True)},
    "PROD": {"nsm": ("nsm", None, False), "a": ("A", None, True), "j": ("j", None, True)},
    "PBAR": {"nsm": ("nsm", None, False), "a": ("A", None, True), "i1": ("i1", None, True),
             "i2": ("i2", None, True), "j": ("j", None, True)},
    "MAT1": {"rho": ("rho", None, False)},
    "CONM2": {"mass": ("mass", None, False), "x1": ("X", 0, False), "x2": ("X", 1, False),
              "x3": ("X", 2, False), "i11": ("I", 0, False), "i22": ("I", 2, False),
              "i33": ("I", 5, False)},
}
PAIRINGS = ("mac", "kind")
#: smallest optimizer tolerance (a few float64 epsilons: SciPy refuses less than one)
MIN_TOLERANCE = 1e-15
#: most model evaluations of one update (each is an eigen-solve of the model)
MAX_EVALUATIONS = 100_000
#: Fields that must stay positive (a dimension) or non-negative (a mass or density).
_POSITIVE = {"t", "a", "i1", "i2"}
_NON_NEGATIVE = {"nsm", "rho", "mass", "i11", "i22", "i33", "j"}


@dataclass(frozen=True)
class UpdateParameter:
    """One updated value, written to field ``field`` of every card ``card`` with an id in
    ``ids``; bounded by ``lower`` ≤ value ≤ ``upper``; ``initial`` None: the deck's value."""

    name: str
    card: str
    ids: tuple[int, ...]
    field: str
    lower: float
    upper: float
    initial: float | None = None

    @property
    def stiffness(self) -> bool:
        return FIELDS[self.card][self.field][2]


@dataclass(frozen=True)
class FrequencyTarget:
    """A target natural frequency (Hz) with its pairing rule (``kind``, or ``mode``: the
    1-based reference mode) and weight."""

    frequency_hz: float
    kind: str = "any"
    mode: int | None = None
    weight: float = 1.0
    name: str = ""


@dataclass(frozen=True)
class UpdateOptions:
    """``n_modes`` computed per evaluation (None: 2 × targets + 2); ``pairing`` "mac" (track
    the initially paired shapes by MAC) or "kind" (re-pair by kind and frequency order at every
    evaluation: the targets keep their order, e.g. a published table); optimiser limits;
    ``regularization`` weight of ‖x − x0‖² on the bound-scaled parameters; ``fd_step``:
    relative step of the central differences of the matrices (exact for the mass fields, which
    enter M affinely, or quadratically for CONM2 offsets)."""

    n_modes: int | None = None
    pairing: str = "mac"
    max_evaluations: int = 200
    tolerance: float = 1e-10
    regularization: float = 0.0
    fd_step: float = 1e-4


@dataclass(frozen=True)
class UpdateSpec:
    targets: tuple[FrequencyTarget, ...]
    parameters: tuple[UpdateParameter, ...]
    options: UpdateOptions = field(default_factory=UpdateOptions)
    reference_deck: Path | None = None


def _err(source, where: str, msg: str) -> InputError:
    return InputError(f"{source}: {where}: {msg}")


def _number(source, where, value, *, positive=False, integer=False):
    ok_type = int if integer else (int, float)
    if isinstance(value, bool) or not isinstance(value, ok_type) or not math.isfinite(value):
        raise _err(source, where, f"expected a {'whole ' if integer else ''}number, "
                                  f"got {value!r}")
    if positive and not value > 0:
        raise _err(source, where, f"expected a positive value, got {value!r}")
    return value


def _keys(source, where, table, allowed):
    if not isinstance(table, dict):
        raise _err(source, where, f"expected a table, got {table!r}")
    extra = sorted(set(table) - set(allowed))
    if extra:
        raise _err(source, where, f"unknown key(s) {', '.join(extra)}; expected "
                                  f"{', '.join(allowed)}")


def _target(source, i, t) -> FrequencyTarget:
    where = f"[[target]] {i + 1}"
    _keys(source, where, t, ("frequency_hz", "kind", "mode", "weight", "name"))
    if "frequency_hz" not in t:
        raise _err(source, where, "missing key frequency_hz")
    f = _number(source, f"{where}: frequency_hz", t["frequency_hz"], positive=True)
    kind = t.get("kind", "any")
    if kind not in TARGET_KINDS:
        raise _err(source, f"{where}: kind", f"expected one of {', '.join(TARGET_KINDS)}, "
                                             f"got {kind!r}")
    mode = t.get("mode")
    if mode is not None:
        mode = _number(source, f"{where}: mode", mode, positive=True, integer=True)
    w = _number(source, f"{where}: weight", t.get("weight", 1.0), positive=True)
    name = t.get("name", f"target {i + 1}")
    return FrequencyTarget(float(f), kind, mode, float(w), str(name))


def check_parameter(p: UpdateParameter, where: str = "parameter") -> None:
    """Check a parameter's card, field and bounds (InputError naming ``where``)."""
    if p.card not in FIELDS:
        raise InputError(f"{where}: card: expected one of {', '.join(FIELDS)}, got {p.card!r}")
    if p.field not in FIELDS[p.card]:
        raise InputError(f"{where}: field: {p.card} fields are {', '.join(FIELDS[p.card])}, "
                         f"got {p.field!r}")
    if not p.ids:
        raise InputError(f"{where}: ids: expected at least one {p.card} id")
    if not p.lower < p.upper:
        raise InputError(f"{where}: expected lower < upper, got {p.lower} and {p.upper}")
    if p.field in _POSITIVE and not p.lower > 0:
        raise InputError(f"{where}: lower: a {p.card} {p.field} must stay positive, "
                         f"got {p.lower}")
    if p.field in _NON_NEGATIVE and p.lower < 0:
        raise InputError(f"{where}: lower: a {p.card} {p.field} must stay non-negative, "
                         f"got {p.lower}")
    if p.initial is not None and not p.lower <= p.initial <= p.upper:
        raise InputError(f"{where}: initial: expected a value within [{p.lower}, {p.upper}], "
                         f"got {p.initial}")


def _parameter(source, i, p) -> UpdateParameter:
    where = f"[[parameter]] {i + 1}"
    _keys(source, where, p, ("name", "card", "ids", "field", "lower", "upper", "initial"))
    for key in ("card", "ids", "field", "lower", "upper"):
        if key not in p:
            raise _err(source, where, f"missing key {key}")
    ids = p["ids"] if isinstance(p["ids"], list) else [p["ids"]]
    ids = tuple(int(_number(source, f"{where}: ids", v, positive=True, integer=True))
                for v in ids)
    lower = float(_number(source, f"{where}: lower", p["lower"]))
    upper = float(_number(source, f"{where}: upper", p["upper"]))
    initial = p.get("initial")
    if initial is not None:
        initial = float(_number(source, f"{where}: initial", initial))
    par = UpdateParameter(str(p.get("name", f"parameter {i + 1}")), str(p["card"]).upper(), ids,
                          str(p["field"]).lower(), lower, upper, initial)
    check_parameter(par, f"{source}: {where} ({par.name})")
    return par


def load_update_spec(path) -> UpdateSpec:
    """Read and validate a targets file (InputError naming the key on any problem)."""
    source, raw = read_toml(path, "targets file")
    _keys(source, "top level", raw, ("target", "parameter", "modes", "optimizer", "reference"))
    targets = raw.get("target", [])
    params = raw.get("parameter", [])
    if not isinstance(targets, list) or not targets:
        raise _err(source, "[[target]]", "expected at least one target")
    if not isinstance(params, list) or not params:
        raise _err(source, "[[parameter]]", "expected at least one parameter")
    targets = tuple(_target(source, i, t) for i, t in enumerate(targets))
    modes_named = [t.mode for t in targets if t.mode is not None]
    same = sorted({m for m in modes_named if modes_named.count(m) > 1})
    if same:
        which = [i + 1 for i, t in enumerate(targets) if t.mode == same[0]]
        raise _err(source, "[[target]]", f"targets {' and '.join(map(str, which))} both name "
                                         f"mode {same[0]}; each mode can match one target only")
    params = tuple(_parameter(source, i, p) for i, p in enumerate(params))
    names = [p.name for p in params]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise _err(source, "[[parameter]]", f"duplicate name(s) {', '.join(dup)}")
    modes = raw.get("modes", {})
    _keys(source, "[modes]", modes, ("n", "pairing"))
    pairing = modes.get("pairing", "mac")
    if pairing not in PAIRINGS:
        raise _err(source, "[modes]: pairing", f"expected one of {', '.join(PAIRINGS)}, got "
                                               f"{pairing!r}")
    opt = raw.get("optimizer", {})
    _keys(source, "[optimizer]", opt, ("max_evaluations", "tolerance", "regularization",
                                       "fd_step"))
    n = modes.get("n")
    if n is not None:
        n = int(_number(source, "[modes]: n", n, positive=True, integer=True))
        if n < len(targets):
            raise _err(source, "[modes]: n", f"expected at least the {len(targets)} targets, "
                                             f"got {n}")
    options = UpdateOptions(
        n_modes=n,
        pairing=pairing,
        max_evaluations=int(_number(source, "[optimizer]: max_evaluations",
                                    opt.get("max_evaluations", 200), positive=True,
                                    integer=True)),
        tolerance=float(_number(source, "[optimizer]: tolerance", opt.get("tolerance", 1e-10),
                                positive=True)),
        regularization=float(_number(source, "[optimizer]: regularization",
                                     opt.get("regularization", 0.0))),
        fd_step=float(_number(source, "[optimizer]: fd_step", opt.get("fd_step", 1e-4),
                              positive=True)),
    )
    if options.regularization < 0:
        raise _err(source, "[optimizer]: regularization", "expected a value ≥ 0")
    if not MIN_TOLERANCE <= options.tolerance < 1:
        raise _err(source, "[optimizer]: tolerance", f"expected a value in [{MIN_TOLERANCE:g}, 1)"
                                                     f" (float64 resolves no less), got "
                                                     f"{options.tolerance:g}")
    from ..bounds import check_count

    check_count(f"{source}: [optimizer] max_evaluations", "evaluations (eigen-solves)",
                options.max_evaluations, MAX_EVALUATIONS)
    ref = raw.get("reference", {})
    _keys(source, "[reference]", ref, ("deck",))
    deck = None
    if "deck" in ref:
        if not isinstance(ref["deck"], str):
            raise _err(source, "[reference]: deck", f"expected a file name, got {ref['deck']!r}")
        deck = check_referenced_path(ref["deck"], source, "[reference] deck")
    return UpdateSpec(targets, params, options, deck)
