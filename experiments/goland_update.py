"""Heavy Goland wing updated to Table 2 and the paper's flutter altitude (REFERENCE Sec. 6).

For a store chordwise position ``store_x`` the declared non-structural mass groups are fitted to
Table 2 by ``torchrom update`` (targets and parameters: torchrom/data/goland_update.toml);
Brent's method then moves ``store_x`` until the p-k flutter altitude at Mach 0.70 (8 x 20 DLM
boxes, 9 modes) is the paper's 11,275 ft. Writes goland_update.json / .md in ``--out`` (default
experiments/results) with the updated parameters, Table 2, the flutter point, the wing mass
and the box's GJ against the classic Goland wing's.

    PYTHONPATH=$PWD python experiments/goland_update.py [--bracket 2.2 2.5] [--store-x X]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from torchrom.aero.build import PAPER_FLUTTER_ALTITUDE_FT, PAPER_FLUTTER_FREQUENCY_HZ, modal_data
from torchrom.aero.goland import goland_flutter, pk_flutter_altitude
from torchrom.fe.bdf_read import from_pynastran
from torchrom.fe.goland import (
    STORE_MASS,
    GolandOptions,
    goland_bdf,
    goland_stiffness,
)
from torchrom.fe.update import update_model
from torchrom.fe.update_config import load_update_spec
from torchrom.io import write_json_atomic, write_text_atomic

SPEC = Path(__file__).resolve().parents[1] / "torchrom" / "data" / "goland_update.toml"
CLASSIC_GJ = 2.39e6


def updated_at(store_x: float):
    """(updated FE model, UpdateResult) for a store position (ft from the leading edge)."""
    spec = load_update_spec(SPEC)
    bdf = goland_bdf(store_x, spec.parameters[0].initial, GolandOptions(mass_groups=True))
    fe = from_pynastran(bdf, source="goland", name="heavy Goland wing (updated)")
    return update_model(fe, spec)


def flutter(fe):
    res, _ = pk_flutter_altitude(modal_data(fe, 9), alt_range=(-4000.0, 50000.0))
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("experiments/results"))
    ap.add_argument("--bracket", type=float, nargs=2, default=(2.2, 2.5))
    ap.add_argument("--xtol", type=float, default=2e-3)
    ap.add_argument("--store-x", type=float, default=None,
                    help="skip the search: update at this store position only")
    args = ap.parse_args(argv)
    t0 = time.time()
    log = []

    def miss(x):
        fe, res = updated_at(x)
        fl = flutter(fe)
        alt = fl.altitude if fl.altitude is not None else np.nan
        s = res.summary()
        log.append({"store_x": x, "pk_altitude": fl.altitude, "pk_frequency_hz": fl.frequency_hz,
                    **s})
        print(f"store_x {x:.4f} ft: Table 2 max |diff| {s['max_abs_diff_pct']:.2f} %, p-k "
              f"flutter {alt:.0f} ft at {fl.frequency_hz or np.nan:.4f} Hz "
              f"({time.time() - t0:.0f} s)", flush=True)
        return alt - PAPER_FLUTTER_ALTITUDE_FT

    store_x = (float(brentq(miss, *args.bracket, xtol=args.xtol)) if args.store_x is None
               else args.store_x)
    fe, res = updated_at(store_x)
    fl = flutter(fe)
    full = goland_flutter(modes=modal_data(fe, 9))  # p-k, state space (13-lag RFA), Table 3
    stiff = goland_stiffness(fe)
    wing_mass = res.total_mass_final - STORE_MASS
    out = {"store_x": store_x, "update": res.as_dict(), "search": log,
           "flutter": {"pk_altitude_ft": fl.altitude, "pk_frequency_hz": fl.frequency_hz,
                       "paper_altitude_ft": PAPER_FLUTTER_ALTITUDE_FT,
                       "paper_frequency_hz": PAPER_FLUTTER_FREQUENCY_HZ,
                       "goland_flutter": full.as_dict()},
           "wing_mass_slug": wing_mass, "wing_mass_per_span_slug_ft": wing_mass / 20.0,
           "stiffness": stiff, "classic_goland_GJ": CLASSIC_GJ,
           "seconds": time.time() - t0,
           "updated_parameters": {k: p["final"] for k, p in res.parameters.items()}}
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.out / "goland_update.json", out)
    lines = ["# Heavy Goland wing updated to Table 2 and the flutter altitude", "",
             f"store_x = {store_x:.4f} ft; wing mass {wing_mass:.1f} slug "
             f"({wing_mass / 20:.2f} slug/ft) + store {STORE_MASS} slug; box GJ "
             f"{stiff['GJ']:.3g} lbf ft² (classic Goland {CLASSIC_GJ:.3g}), EI {stiff['EI']:.3g}",
             "", "| mode | Table 2 Hz | updated Hz | diff % | kind |", "|---|---|---|---|---|"]
    for t in res.targets:
        lines.append(f"| {t['mode']} | {t['target_hz']:.3f} | {t['final_hz']:.3f} | "
                     f"{t['final_diff_pct']:+.2f} | {t['kind']} |")
    lines += ["", f"p-k flutter at Mach 0.70: {fl.altitude:.0f} ft "
              f"({100 * (fl.altitude / PAPER_FLUTTER_ALTITUDE_FT - 1):+.2f} %), "
              f"{fl.frequency_hz:.4f} Hz "
              f"({100 * (fl.frequency_hz / PAPER_FLUTTER_FREQUENCY_HZ - 1):+.2f} %); state "
              f"space (13-lag RFA) {full.ss_altitude:.0f} ft, {full.ss_frequency_hz:.4f} Hz", "",
              "| Table 3 altitude ft | paper Hz | state space Hz | diff % | p-k Hz |",
              "|---|---|---|---|---|"]
    for alt, (f_ss, f_pk, paper) in full.table3.items():
        lines.append(f"| {alt:.0f} | {paper:.3f} | {f_ss:.4f} | {100 * (f_ss / paper - 1):+.2f} | "
                     f"{f_pk:.4f} |")
    lines += ["",
              "| parameter | card | field | value | bounds |", "|---|---|---|---|---|"]
    for name, p in res.parameters.items():
        lines.append(f"| {name} | {p['card']} | {p['field']} | {p['final']:.6g} | "
                     f"[{p['lower']:g}, {p['upper']:g}] |")
    write_text_atomic(args.out / "goland_update.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
