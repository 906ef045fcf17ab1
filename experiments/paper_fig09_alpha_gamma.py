"""Paper Fig. 9: α(γ) that keeps the flutter altitude of the heavy Goland wing (Mach 0.70).

    PYTHONPATH=. python experiments/paper_fig09_alpha_gamma.py [--out DIR] [--quick]

Reads the γ grid of ``configs/paper_fig09.toml`` (the built-in Goland pipeline, cached in
``[model] cache`` / the cache root, ``torchrom cache info``), writes ``DIR/alpha_gamma.csv``
and ``DIR/fig09.png``; the same figure from the table:
``torchrom plot DIR/alpha_gamma.csv --figure fig9 --out fig9.png``.
"""

from __future__ import annotations

from paper_common import arguments_and_config

from torchrom.io import atomic_path
from torchrom.study import figures
from torchrom.study.models import alpha_gamma_table


def main(argv=None) -> int:
    args, cfg = arguments_and_config(__doc__, "paper_fig09.toml", argv)
    model = cfg.build_model()
    table = alpha_gamma_table(model, [c.get("gamma", 0.0) for c in cfg.cases])
    print(table[["gamma", "alpha", "flutter_frequency_hz"]].to_string(index=False))
    with atomic_path(args.out / "alpha_gamma.csv") as tmp:
        table.to_csv(tmp, index=False)
    print(f"wrote {figures.fig9(table, args.out / 'fig09.png', force=True)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
