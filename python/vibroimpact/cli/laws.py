"""``vibroimpact laws``: every contact law on the same impact, side by side."""

from __future__ import annotations

import argparse
import json

from vibroimpact.cli.impact import LawNames
from vibroimpact.contact import FORCE_LAWS, GEOMETRY_KINDS, Geometry
from vibroimpact.errors import ModelError
from vibroimpact.laws_compare import COMPARE_FIELDS, compare_laws, comparison_laws


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "laws",
        help="compare every contact law on one impact",
        description=(
            "A body of mass M strikes a rigid wall at speed V0 once per contact law, every law "
            "with the same stiffness K (given, or computed from a geometry), exponent n and "
            "restitution ce. Prints each law's effective restitution, peak indentation "
            "delta_max, peak force force_max and contact duration (with --json: an object "
            "keyed by law name with the fields of 'vibroimpact impact --json'). Kelvin-Voigt "
            "and the tabulated law get equivalent parameters (see vibroimpact.laws_compare)."
        ),
    )
    p.add_argument("--restitution", type=float, required=True, help="restitution ce, 0 < ce <= 1")
    p.add_argument("--velocity", type=float, required=True, help="approach speed V0, m/s")
    p.add_argument("--mass", type=float, required=True, help="mass M of the body, kg")
    k = p.add_mutually_exclusive_group(required=True)
    k.add_argument("--stiffness", type=float, help="contact stiffness K, N/m^n")
    k.add_argument("--geometry", choices=GEOMETRY_KINDS,
                   help="compute K from this geometry and the materials below")
    p.add_argument("--radius1", type=float, help="radius of body 1 (ball, pin or punch), m")
    p.add_argument("--radius2", type=float, help="radius of body 2 (socket, sphere or hole), m")
    p.add_argument("--length", type=float, help="contact length (cylinder-in-hole), m")
    p.add_argument("--load", type=float,
                   help="reference force of the linearisation (cylinder-in-hole), N")
    p.add_argument("--youngs-modulus", type=float, help="Young's modulus of body 1, Pa")
    p.add_argument("--poisson", type=float, help="Poisson's ratio of body 1")
    p.add_argument("--youngs-modulus2", type=float,
                   help="Young's modulus of body 2 (default: body 1's), Pa")
    p.add_argument("--poisson2", type=float, help="Poisson's ratio of body 2 (default: body 1's)")
    p.add_argument("--exponent", type=float, default=None,
                   help="exponent n (default: 1.5, or the geometry's)")
    p.add_argument("--laws", nargs="+", choices=LawNames(FORCE_LAWS), metavar="LAW",
                   help="only these laws (default: all)")
    p.add_argument("--json", action="store_true", help="print a JSON object keyed by law")
    p.add_argument("--plot", metavar="FIGURE",
                   help="also draw the force-indentation loops and velocity-indentation "
                        "curves of the laws to FIGURE (.png, .svg or .pdf)")
    p.set_defaults(handler=main)


def _geometry(args: argparse.Namespace) -> Geometry:
    for name in ("radius1", "youngs_modulus", "poisson"):
        if getattr(args, name) is None:
            flag = "--" + name.replace("_", "-")
            raise ModelError(f"{flag}: missing; expected a value with --geometry {args.geometry}")
    return Geometry(
        args.geometry, radius1=args.radius1, radius2=args.radius2,
        youngs_modulus=args.youngs_modulus, poisson=args.poisson,
        youngs_modulus2=args.youngs_modulus2, poisson2=args.poisson2,
        length=args.length, load=args.load,
    )


def main(args: argparse.Namespace) -> int:
    stiffness = _geometry(args) if args.geometry else args.stiffness
    results = compare_laws(args.restitution, args.mass, args.velocity, stiffness,
                           args.exponent, args.laws)
    if args.plot:
        from vibroimpact.plotting.laws import plot_laws

        laws = comparison_laws(args.restitution, args.mass, args.velocity, stiffness,
                               args.exponent, args.laws)
        plot_laws(laws, args.mass, args.velocity, path=args.plot)
    if args.json:
        print(json.dumps({name: {k: row[k] for k in COMPARE_FIELDS}
                          for name, row in results.items()}))
        return 0
    k = stiffness.stiffness() if isinstance(stiffness, Geometry) else stiffness
    print(f"one impact per law: m = {args.mass} kg, v0 = {args.velocity} m/s, "
          f"ce = {args.restitution}, K = {k:.6g}")
    print(f"{'law':22s} {'e_eff':>8s} {'delta_max [m]':>14s} {'force_max [N]':>14s} "
          f"{'duration [s]':>13s}")
    for name, row in results.items():
        print(f"{name:22s} {row['restitution_effective']:8.4f} {row['delta_max']:14.6e} "
              f"{row['force_max']:14.6e} {row['duration']:13.6e}")
    if args.plot:
        print(f"figure: {args.plot}")
    return 0
