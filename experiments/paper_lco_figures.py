"""Paper Figs. 10–13: the post-flutter LCO sweep of the heavy Goland wing and its figures.

    PYTHONPATH=. python experiments/paper_lco_figures.py [--out DIR] [--quick]

Runs ``configs/paper_lco.toml`` (the same as ``torchrom sweep configs/paper_lco.toml --out DIR``)
and draws Fig. 10 (LCO amplitude vs altitude), Fig. 11 (point A at 10,000 ft, γ = 1e-3 s, from
the histories), Fig. 12 (LCO frequency) and Fig. 13 (q1/q2, q1/q4) into DIR, as
``torchrom plot DIR/results.parquet --figure figN --out figN.png`` would.
"""

from __future__ import annotations

import pandas as pd
from paper_common import arguments_and_config

from torchrom.study import figures
from torchrom.study.sweep import run_sweep
from torchrom.study.table import write_histories, write_table


def main(argv=None) -> int:
    args, cfg = arguments_and_config(__doc__, "paper_lco.toml", argv)
    hist: list[pd.DataFrame] = []
    table, timing = run_sweep(cfg, on_history=hist.append,
                              progress=lambda done, total: print(f"\r{done}/{total} cases",
                                                                 end="", flush=True))
    print(f"\n{timing['case_steps']} case-steps, {timing['us_per_case_step']:.0f} us each")
    write_table(table, args.out, force=True)
    histories = pd.concat(hist, ignore_index=True)
    write_histories([histories], args.out / "histories.parquet")
    for name in ("fig10", "fig12", "fig13"):
        print(f"wrote {figures.TABLE_FIGURES[name](table, args.out / f'{name}.png', force=True)}")
    print(f"wrote {figures.fig11(table, histories, args.out / 'fig11.png', force=True)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
