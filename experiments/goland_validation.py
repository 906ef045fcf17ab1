"""Heavy Goland wing, 9L12D ROM vs FE: static responses at point A and free decay, for dual-mode
generation variants (issue 4 acceptance; paper Sec. III.E, Figs. 3–8).

For each variant: identify (stiffness by tangents, damping `exact`), then the static curves under
the uniform and the "step uniform" pressures up to a 25 % span tip deflection (errors of A_Tz,
A_Ty, A_Tx by tip-deflection band), optionally the step pressure about the box mid-line, and the
free decay (γ = 1e-3 s) from a 10 % and a 15 % span tip deflection. Prints Markdown tables;
``--out FILE`` writes them (and a JSON beside it).

    PYTHONPATH=$PWD python experiments/goland_validation.py [--variants default,mass,...]
        [--n-dual 12] [--box-step] [--decay] [--wing updated]
        [--out experiments/results/goland_validation.md]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from torchrom.fe import goland
from torchrom.identify import validate as v
from torchrom.identify.basis import (
    BENDING_TORSION_COMBINATIONS,
    TRANSVERSE_RULE,
    DualModeOptions,
    parse_combinations,
)
from torchrom.identify.build import IdentifyOptions, identify
from torchrom.identify.fe_backend import BuiltinFEBackend

VARIANTS = {
    "default": {},
    "mass-pod": {"pod_norm": "mass"},
    "unit-weights": {"snapshot_weights": "unit"},
    "linear-amplitudes": {"amplitude_control": "linear"},
    "paper-like": {"pod_norm": "mass", "snapshot_weights": "unit",
                   "amplitude_control": "linear"},
    "range-25": {"tip_range": (0.001, 0.25)},
    "combinations-1-3": {"combinations": BENDING_TORSION_COMBINATIONS},
    # the rule of the pipeline and of torchrom identify (from the wing's mode kinds)
    "transverse": {"combinations": TRANSVERSE_RULE},
}
BANDS = (5.0, 10.0, 15.0, 20.0, 25.0)


def static_rows(name, curve) -> list[str]:
    rows = []
    for k in ("A_Tz", "A_Ty", "A_Tx"):
        cells = []
        for hi in BANDS:
            e = curve.error_table(min_tip_pct=1.0, max_tip_pct=hi + 0.05)[k]
            cells.append("—" if np.isnan(e) else f"{100 * e:.2f}")
        rows.append(f"| {name} | {curve.shape} | {k} | " + " | ".join(cells)
                    + f" | {curve.tip_pct_span.max():.1f} |")
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", default="default")
    ap.add_argument("--n-dual", type=int, default=12)
    ap.add_argument("--box-step", action="store_true",
                    help="also the step pressure about the box mid-line x = 2 ft (up to 6 %)")
    ap.add_argument("--decay", action="store_true", help="free decays from 10 % and 15 % span")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--wing", choices=("calibrated", "updated"), default="calibrated",
                    help="heavy Goland wing variant (torchrom.fe.goland)")
    args = ap.parse_args(argv)
    fe = goland(variant=args.wing)
    head = ("| variant | load | output | " + " | ".join(f"≤{b:g} %" for b in BANDS)
            + " | max tip % |")
    lines = ["Largest |ROM − FE| / |FE| (%) at point A over the load levels with a tip deflection "
             "from 1 % of the span up to each band", "", head, "|" + "---|" * (len(BANDS) + 4)]
    record = {}
    decay_lines = ["", "| variant | initial tip % span | envelope error % | frequency error % |"
                   " FE Hz | ROM Hz |", "|---|---|---|---|---|---|"]
    for name in args.variants.split(","):
        t0 = time.perf_counter()
        options = dict(VARIANTS[name])
        if options.get("combinations") == TRANSVERSE_RULE:
            options["combinations"] = parse_combinations(TRANSVERSE_RULE,
                                                         kinds=fe.modes(9).kinds)
        dual = replace(DualModeOptions(), **options)
        res = identify(fe, IdentifyOptions(n_linear=9, n_dual=args.n_dual, damping="exact",
                                           dual=dual))
        t_id = time.perf_counter() - t0
        be = BuiltinFEBackend(fe)
        rec = {"identify_s": t_id, "counters": res.counters,
               "failed_dual_loads": sum(r["status"] != "ok" for r in res.basis.snapshots)}
        shapes = dict(be.load_shapes())
        curves = [v.static_validation(be, res.rom, res.basis.Phi, s, load) for s, load in
                  shapes.items()]
        if args.box_step:
            box = BuiltinFEBackend(fe, step_x=2.0).load_shapes()["step"]
            curves.append(v.static_validation(be, res.rom, res.basis.Phi, "step (x = 2 ft)", box,
                                              max_tip_fraction=0.06, n_levels=6))
        for c in curves:
            lines += static_rows(f"{name} ({args.n_dual} duals)", c)
            rec[c.shape] = {"tip_pct_span": c.tip_pct_span.tolist(),
                            **{f"fe_{k}": c.fe[k].tolist() for k in c.fe},
                            **{f"rom_{k}": c.rom[k].tolist() for k in c.rom}}
        print("\n".join(lines[-3 * len(curves):]), flush=True)
        if args.decay:
            for tip in (0.10, 0.15):
                dec = v.free_decay_validation(be, res.rom, res.basis.Phi, shapes["uniform"],
                                              tip_fraction=tip, gamma=1e-3, cycles=10)
                m = dec.metrics
                decay_lines.append(
                    f"| {name} | {100 * tip:g} | {100 * m['envelope_error']:.2f} | "
                    f"{100 * m['frequency_error']:.3f} | {m['frequency_fe_hz']:.4f} | "
                    f"{m['frequency_rom_hz']:.4f} |")
                rec[f"decay_{tip:g}"] = m
                print(decay_lines[-1], flush=True)
        record[name] = rec
    text = "\n".join(lines + (decay_lines if args.decay else [])) + "\n"
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
        args.out.with_suffix(".json").write_text(json.dumps(record, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
