"""The Pazy wing's LCO about its static aeroelastic equilibrium at 5° (a `torchrom sweep` of
configs/pazy_aoa_lco.toml), beside UM/NAST's LCO band (its largest and smallest tip deflection
at each speed; tests/decks/aepw3_pazy_flutter_deformed/SOURCE.md): the tip's mean deflection
and the band mean ± amplitude, in % of the semispan.

    PYTHONPATH=$PWD python experiments/pazy_aoa_lco.py --table pazy_aoa_lco/results.parquet
        [--output max_mode1] [--figure docs/guide/pazy_aoa_lco.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

REFS = Path(__file__).resolve().parents[1] / "tests" / "decks" / "aepw3_pazy_flutter_deformed"
SEMISPAN = 0.55


def um_nast(follower: bool = False) -> np.ndarray:
    """(speed m/s, largest, smallest tip deflection % semispan) of UM/NAST's LCOs at 5°."""
    return np.loadtxt(REFS / f"UM_NAST_JFS2023_LCO_aoa5{'' if follower else '_nf'}.txt",
                      ndmin=2)


def rows(table, output: str):
    t = table.sort_values("speed")
    mean = 100 * t[f"mean_{output}"].to_numpy() / SEMISPAN
    amp = 100 * t[f"amplitude_{output}"].to_numpy() / SEMISPAN
    return t, mean, amp


def figure(table, output: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, mean, amp = rows(table, output)
    lco = t["status"].to_numpy() == "lco"
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    v = t["speed"].to_numpy()
    ax.plot(v, mean, "g-", label="torchrom ROM: mean")
    ax.fill_between(v[lco], (mean - amp)[lco], (mean + amp)[lco], color="g", alpha=0.3,
                    label="torchrom ROM: LCO (mean ± amplitude)")
    for follower, style in ((False, "k"), (True, "0.5")):
        ref = um_nast(follower)
        ax.fill_between(ref[:, 0], ref[:, 2], ref[:, 1], color=style, alpha=0.35,
                        label=f"UM/NAST LCO ({'follower' if follower else 'non-follower'} "
                              "aerodynamics)")
    ax.set(xlabel="speed (m/s)", ylabel="tip deflection (% semispan)",
           title="Pazy wing with skin, 5°: LCO about the static equilibrium")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    import pandas as pd

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--table", type=Path, required=True)
    p.add_argument("--output", default="max_mode1")
    p.add_argument("--figure", type=Path, default=None)
    args = p.parse_args(argv)
    table = pd.read_parquet(args.table)
    t, mean, amp = rows(table, args.output)
    print("| speed (m/s) | status | certified | mean (% semispan) | amplitude (% semispan) | "
          "frequency (Hz) |")
    print("|---:|---|---|---:|---:|---:|")
    for (_, r), m, a in zip(t.iterrows(), mean, amp):
        print(f"| {r['speed']:.2f} | {r['status']} | {bool(r.get('certified'))} | {m:.2f} | "
              f"{a:.3f} | {r['frequency_hz']:.2f} |")
    if args.figure:
        figure(table, args.output, args.figure)
        print(f"figure: {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
