"""``torchrom goland``: write the heavy Goland wing deck and compare its modes with Table 2.

``--variant updated`` (default) or ``calibrated`` (:data:`torchrom.fe.goland.GOLAND_VARIANTS`).

JSON (``--json FILE``): a list of records, one per mode, with keys ``mode``, ``frequency_hz``
(Hz), ``kind`` (bending/torsion/in-plane/axial), ``paper_hz`` (Table 2, Hz), ``diff_pct``
(100 (model − paper)/paper) and ``content_bending``/``content_torsion``/``content_in-plane``/
``content_axial`` (fractions of the displacement content, summing to 1).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    add_force_option,
    add_json_option,
    check_outputs,
    finite_float,
    maybe_write_json,
    positive_float,
    positive_int,
)

NAME = "goland"
HELP = "write the heavy Goland wing BDF (goland.bdf) and print its modes against Table 2"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--variant", choices=("calibrated", "updated"), default="updated",
                        help="'updated' (default: non-structural mass groups updated to "
                             "Table 2, torchrom/data/goland_update.toml) or 'calibrated' "
                             "(uniform density for mode 1, store position for the flutter "
                             "altitude; the options below apply to it)")
    parser.add_argument("--mass-groups", action="store_true",
                        help="calibrated variant: declare the non-structural mass groups of "
                             "torchrom/data/goland_update.toml (massless until updated)")
    parser.add_argument("--out", type=Path, default=Path("."),
                        help="output directory for goland.bdf (default: current directory)")
    # the default is resolved in run(): importing torchrom.fe here would slow down --help
    parser.add_argument("--store-x", type=finite_float, default=None,
                        help="chordwise store position, ft from the leading edge (default: the "
                             "calibrated torchrom.fe.goland.DEFAULT_STORE_X)")
    parser.add_argument("--density", type=positive_float, default=None,
                        help="uniform density, slug/ft^3 (default: calibrated, mode 1 = 1.690 Hz)")
    parser.add_argument("--skins", choices=("bending", "membrane"), default="bending",
                        help="CQUAD4 skins with plate bending (default) or membrane only")
    parser.add_argument("--webs", choices=("cshear", "cquad4", "cquad4-membrane"),
                        default="cquad4-membrane",
                        help="shear-panel modelling (default membrane-only CQUAD4)")
    parser.add_argument("--coupled-mass", action="store_true",
                        help="consistent mass (PARAM COUPMASS 1) instead of lumped")
    parser.add_argument("--n", type=positive_int, default=9, help="number of modes (default 9)")
    add_json_option(parser)
    add_force_option(parser)


def run(args: argparse.Namespace) -> int:
    from ..fe import goland, goland_stiffness, write_bdf
    from ..fe.goland import table2_records
    from ..fe.report import mode_table

    out = Path(args.out) / "goland.bdf"
    check_outputs(args, [out])
    if args.variant == "updated":
        print("building the heavy Goland wing, updated variant")
        fe = goland(variant="updated", store_x=args.store_x, density=args.density,
                    skins=args.skins, webs=args.webs, coupled_mass=args.coupled_mass,
                    mass_groups=args.mass_groups, n_modes=args.n)
    else:
        from ..fe.goland import DEFAULT_STORE_X

        store_x = DEFAULT_STORE_X if args.store_x is None else args.store_x
        print(f"building the heavy Goland wing (store_x = {store_x:g} ft, skins {args.skins}, "
              f"webs {args.webs}, {'consistent' if args.coupled_mass else 'lumped'} mass"
              + (", mass groups" if args.mass_groups else "") + ")")
        fe = goland(store_x=store_x, density=args.density, skins=args.skins, webs=args.webs,
                    coupled_mass=args.coupled_mass, n_modes=args.n,
                    mass_groups=args.mass_groups, variant="calibrated")
    from ..fe.update import total_mass

    rho = fe.mesh.rods.rho[0]
    stiff = goland_stiffness(fe)
    print(f"{fe.n_dof} free DOFs; density {rho:.10g} slug/ft^3; total mass "
          f"{total_mass(fe):.6g} slug; EI {stiff['EI']:.4g} lbf ft^2; "
          f"GJ {stiff['GJ']:.4g} lbf ft^2; elastic axis x = {stiff['elastic_axis_x']:.3f} ft")
    write_bdf(fe, out, force=args.force)
    print(f"wrote {out}")
    modes = fe.modes(args.n)
    records = table2_records(modes)
    print(mode_table(records))
    maybe_write_json(args, records)
    return 0
