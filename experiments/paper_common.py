"""Command-line arguments shared by the paper experiment scripts (``--out``, ``--quick``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from torchrom.study.config import SweepConfig, load_sweep_config

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def arguments_and_config(doc: str, config: str, argv=None) -> tuple[argparse.Namespace,
                                                                   SweepConfig]:
    """Parse ``--out DIR`` (default experiments/results/paper) and ``--quick``; load the
    configuration ``configs/<config>`` (its quick variant with ``--quick``)."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("experiments/results/paper"))
    ap.add_argument("--quick", action="store_true", help="the configuration's quick variant")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    return args, load_sweep_config(CONFIGS / config, "quick" if args.quick else None)
