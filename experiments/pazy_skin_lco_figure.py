"""The skinned Pazy wing's LCO vs speed (``torchrom sweep configs/pazy_skin_lco.toml``) beside
the flutter onsets it starts from: the ROM's (``torchrom flutter``), the GFEM's SOL 145 (its
f06) and Riso & Cesnik's UM/NAST beam model (72.4 m/s at 0°, AePW-3
``07_Flutter_Deformed/nonlinear_flutter_UM_NAST_onset_w_skin.txt``). Tip amplitude in % of
the semispan (0.55 m); each row marked by its certificate.

    PYTHONPATH=$PWD python experiments/pazy_skin_lco_figure.py pazy_lco/results.parquet \\
        [--newmark nm/results.parquet] --out docs/guide/pazy_skin_lco.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

SEMISPAN = 0.55  # m
#: flutter onsets at 1.225 kg/m³, 0° (m/s): the f06 of the deck, and UM/NAST's
F06_ONSET = 67.30
UM_NAST_ONSET = 72.40


def main(argv=None) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("table", type=Path, help="the HB sweep's results.parquet")
    p.add_argument("--newmark", type=Path, default=None, help="a Newmark sweep's results")
    p.add_argument("--rom-onset", type=float, default=68.17, help="the ROM's flutter speed")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    hb = pd.read_parquet(args.table).sort_values("speed")
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ok = (hb["status"] == "lco") & hb["certified"].astype(bool)
    pct = 100 * hb["amplitude"] / SEMISPAN
    ax.plot([args.rom_onset, *hb["speed"][ok]], [0.0, *pct[ok]], "o-", color="C0",
            label="torchrom ROM, harmonic balance (certified rows; 0 at its flutter speed)")
    if args.newmark is not None:
        nm = pd.read_parquet(args.newmark)
        nm = nm[(nm["status"] == "lco") & nm["certified"].astype(bool)]
        ax.plot(nm["speed"], 100 * nm["amplitude"] / SEMISPAN, "x", color="C3", ms=9,
                label="same ROM, Newmark 0.2 ms (certified rows)")
    # the labels at three heights: the ROM's and the f06's onsets are 0.9 m/s apart
    for v, text, style, y in ((args.rom_onset, "ROM flutter", ":", 0.80),
                              (F06_ONSET, "GFEM SOL 145 (f06)", "--", 0.97),
                              (UM_NAST_ONSET, "UM/NAST beam onset", "-.", 0.97)):
        ax.axvline(v, color="0.4", ls=style, lw=1)
        ax.annotate(f"{text}\n{v:.2f} m/s", (v, y), xycoords=("data", "axes fraction"),
                    ha="right" if v < F06_ONSET + 0.5 else "left", va="top", fontsize=8,
                    xytext=(-3 if v < F06_ONSET + 0.5 else 3, 0), textcoords="offset points")
    ax.set_xlabel("speed (m/s), 1.225 kg/m³, 0° angle of attack")
    ax.set_ylabel("tip LCO amplitude (% of the semispan)")
    ax.set_title("Pazy wing with skin: deck → ROM → LCO")
    ax.set_xlim(64, max(90.0, float(hb["speed"].max()) + 2))
    ax.set_ylim(0, 1.25 * float(pct[ok].max()))
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
