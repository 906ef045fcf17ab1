"""The ROM about the deformed wing against the FE's exact condensation at every speed at 5°:
the tip deflection and the first five natural frequencies of the tangent, from the JSON of
`torchrom flutter ROM AERO --aoa 5 ... --json` (its ``equilibria``) and the FE exact
condensation's sweep of experiments/pazy_aoa_rom.py (``cases[0].fe``, continued in speed at
its own equilibria), as the Markdown table of docs/guide/pazy-aoa.md:

    PYTHONPATH=$PWD python experiments/pazy_aoa_about_table.py flutter_about.json \\
        experiments/results/pazy_aoa_rom_skin5.json
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def rows(rom_json: dict, fe_json: dict, aoa: float = 5.0):
    """(speed, ROM tip %, FE tip %, ROM Hz (5,), FE Hz (5,)) at the speeds both hold."""
    eqs = {(e["aoa_deg"], e["velocity"]): e for e in rom_json["equilibria"] if e["converged"]}
    case = next(c for c in fe_json["cases"] if c["aoa_deg"] == aoa)
    fe = case["fe"]
    for v, tip, hz in zip(fe_json["speeds"], fe["tip_pct"], fe["natural_hz"]):
        e = eqs.get((aoa, v))
        if e is not None:
            yield v, e["tip_deflection_pct_semispan"], tip, np.asarray(e["natural_hz"][:5]), \
                np.asarray(hz[:5])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("rom_json")
    p.add_argument("fe_json")
    p.add_argument("--aoa", type=float, default=5.0)
    args = p.parse_args(argv)
    with open(args.rom_json) as f, open(args.fe_json) as g:
        data = list(rows(json.load(f), json.load(g), args.aoa))
    print("| speed (m/s) | tip ROM / FE (% semispan) | natural Hz, ROM | natural Hz, FE | "
          "largest frequency error |")
    print("|---:|---|---|---|---:|")
    for v, tr, tf, hr, hf in data:
        err = np.max(np.abs(hr - hf) / hf)
        print(f"| {v:g} | {tr:.2f} / {tf:.2f} | {', '.join(f'{x:.2f}' for x in hr)} | "
              f"{', '.join(f'{x:.2f}' for x in hf)} | {100 * err:.1f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
