"""Paper Table 3 and the simulator's flutter altitude: batched Newmark vs eigenvalues.

    PYTHONPATH=. python experiments/paper_table3.py [--out DIR] [--quick]

With both nonlinearities off (baseline damping α0, β0), the growth rate measured from simulated
responses started on the critical eigenvector changes sign at the eigenvalue flutter altitude,
and the frequency of the growing response from near-zero initial conditions is Table 3. Writes
``DIR/table3.csv`` and ``DIR/linear_check.json``.
"""

from __future__ import annotations

from paper_common import arguments_and_config

from torchrom.io import atomic_path, write_json_atomic
from torchrom.paper.linear import linear_checks
from torchrom.paper.study import LINEAR_T_END


def main(argv=None) -> int:
    args, cfg = arguments_and_config(__doc__, "paper_lco.toml", argv)
    model = cfg.build_model()
    check = linear_checks(model, t_end=LINEAR_T_END["quick" if args.quick else "full"])
    print(check.growth.to_string(index=False))
    print(check.table3.to_string(index=False))
    print(f"flutter altitude: simulator {check.flutter_altitude_sim:,.1f} ft, eigenvalues "
          f"{check.flutter_altitude_eig:,.1f} ft")
    with atomic_path(args.out / "table3.csv") as tmp:
        check.table3.to_csv(tmp, index=False)
    write_json_atomic(args.out / "linear_check.json", check.as_dict())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
