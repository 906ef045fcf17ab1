"""Why, at γ = 1e-3 s, the LCO with the stiffness nonlinearity is twice the one without.

The paper (Sec. IV, Fig. 10) finds that for γ = 1e-3 s "the stiffness nonlinearity matters
little" (curves "γ = 1e-3" and "γ = 1e-3 only" close); ours gives 13.1 vs 6.4 % of span at
4,000 ft, for every admissible damping decomposition. This experiment runs
:func:`torchrom.paper.stiffness_cause.stiffness_cause` (harmonic balance orbits, matched α) on
both heavy Goland wing variants at every altitude of the paper's sweep: the stiffness
nonlinearity switched off in parts (K3, K2, the couplings through the dual modes), the cycle
mean power of every term of Eq. 54, and the nonlinear-to-linear damping ratio of the cycle with
the dual coordinates as solved, zero, and following the bending quasi-statically.

    PYTHONPATH=$PWD python experiments/stiffness_nl_at_large_gamma.py --work paper \
        --out experiments/results/stiffness_nl_at_large_gamma.md

``--work``: a folder for the two variants' model caches (``torchrom paper``'s output folder
reuses its ``model`` and ``model_calibrated``; otherwise both are built first).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from torchrom.paper.pipeline import goland_pipeline
from torchrom.paper.report import stiffness_cause_lines
from torchrom.paper.stiffness_cause import stiffness_cause
from torchrom.paper.study import FULL_PIPELINE, config_path
from torchrom.study.config import load_sweep_config, with_method

ALTITUDES = (4000.0, 6000.0, 8000.0, 10000.0, 11000.0)
VARIANTS = {"updated": "model", "calibrated": "model_calibrated"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="paper", help="folder of the model caches")
    ap.add_argument("--out", default="experiments/results/stiffness_nl_at_large_gamma.md")
    ap.add_argument("--render-only", action="store_true",
                    help="rewrite the Markdown from the JSON beside --out (no computation)")
    args = ap.parse_args()
    out = Path(args.out)
    if args.render_only:
        out.write_text(render(json.loads(out.with_suffix(".json").read_text())))
        print(f"wrote {out}")
        return
    hb = with_method(load_sweep_config(config_path("paper_lco.toml")), "hb").hb.options
    results = {}
    for variant, folder in VARIANTS.items():
        model = goland_pipeline(dataclasses.replace(FULL_PIPELINE, variant=variant),
                                Path(args.work) / folder).model
        results[variant] = stiffness_cause(model, hb, altitudes=ALTITUDES)
        for r in results[variant]["rows"]:
            print(variant, r["switch"], r["altitude_ft"], r["status"],
                  r.get("amplitude_pct_span"), flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(results, indent=1, default=float))
    out.write_text(render(results))
    print(f"wrote {out}")


def render(results: dict) -> str:
    lines = ["# The stiffness nonlinearity at γ = 1e-3 s (paper: 'matters little')", "",
             "Written by `experiments/stiffness_nl_at_large_gamma.py` (see its docstring); the "
             "same measures at 4,000 ft are in `torchrom paper`'s report.", "",
             "Summary at the lowest altitude, on both wings (the wing variants differ in mass "
             "distribution, store position and mode shapes; ROM recipe, damping identification "
             "and aerodynamics are the same):", "",
             "| wing | amplitude with / without stiffness NL (% of span) | γ D̄3's share of the "
             "dissipation without stiffness NL | damping ratio, dual coordinates zero → "
             "quasi-static (same cycle) |", "|---|---|---|---|"]
    for variant, res in results.items():
        low = min(r["altitude_ft"] for r in res["rows"])
        at = {r["switch"]: r for r in res["rows"] if r["altitude_ft"] == low}
        both, none = at["both nonlinearities"], at["no stiffness nonlinearity"]
        total = sum(v for k, v in none["terms"].items() if "conservative" not in k)
        f = none["following"]
        lines.append(f"| {variant} | {both['amplitude_pct_span']:.2f} / "
                     f"{none['amplitude_pct_span']:.2f} ({low:,.0f} ft) | "
                     f"{100 * none['terms']['γ D̄3(q, q)'] / total:.0f} % | "
                     f"{f['dual coordinates zero']:+.2f} → "
                     f"{f['dual coordinates quasi-static']:+.3f} |")
    lines += ["", "The same mechanism on both wings: the cause is not the reconstruction of the "
              "paper's wing but the Kelvin–Voigt damping of a ROM whose dual modes carry the "
              "membrane stretching, with the stiffness nonlinearity switched off as a whole.",
              ""]
    for variant, res in results.items():
        lines += [f"## The {variant} wing", ""] + stiffness_cause_lines(res, heading=False)
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
