"""``vibroimpact impact``: one central impact of a body on a rigid wall."""

from __future__ import annotations

import argparse
import json

from vibroimpact.contact import (
    FORCE_LAWS,
    REMOVED_LAWS,
    catalog_default,
    kelvin_voigt_damping,
    law_from_name,
)
from vibroimpact.errors import ModelError
from vibroimpact.impact import single_impact

UNITS = {
    "delta_max": "m",
    "force_max": "N",
    "duration": "s",
    "v_out": "m/s",
    "restitution_effective": "",
}


class LawNames(tuple[str, ...]):
    """The force-law names of ``--law``/``--laws`` (shown in help and usage). A removed name
    (:data:`~vibroimpact.contact.REMOVED_LAWS`) also passes argparse's check, so that the
    command refuses it with the reason in one line instead of a usage message."""

    def __contains__(self, name: object) -> bool:
        return name in REMOVED_LAWS or tuple.__contains__(self, name)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "impact",
        help="one central impact of a body on a rigid wall",
        description=(
            "A body of mass M touches a rigid wall at t = 0 moving toward it at speed V0 and "
            "is followed until it separates. Prints the peak indentation delta_max, the peak "
            "force force_max, the contact duration, the separation speed v_out and the "
            "effective restitution v_out/V0."
        ),
    )
    p.add_argument("--law", required=True, choices=LawNames(sorted(FORCE_LAWS)),
                   help="contact law")
    p.add_argument("--stiffness", type=float, required=True, help="contact stiffness K, N/m^n")
    p.add_argument("--exponent", type=float, default=None,
                   help=f"exponent n (default {catalog_default('hertz', 'exponent'):g})")
    p.add_argument("--restitution", type=float, default=None,
                   help="restitution ce, 0 < ce <= 1 (kelvin-voigt: the dashpot c that gives "
                        "it for this mass, instead of --damping)")
    p.add_argument(
        "--damping", type=float, default=None,
        help="damping: c in N s/m (kelvin-voigt) or b (hunt-crossley, instead of ce)",
    )
    p.add_argument("--mass", type=float, required=True, help="mass M of the body, kg")
    p.add_argument("--velocity", type=float, required=True, help="approach speed V0, m/s")
    p.add_argument("--json", action="store_true", help="print a JSON object")
    p.set_defaults(handler=main)


def main(args: argparse.Namespace) -> int:
    params: dict[str, float] = {"stiffness": args.stiffness}
    for name in ("exponent", "restitution", "damping"):
        value = getattr(args, name)
        if value is not None:
            params[name] = value
    if args.law == "kelvin-voigt":
        params.setdefault("exponent", 1.0)
        if "restitution" in params:
            if "damping" in params:
                raise ModelError("law: kelvin-voigt takes one of --restitution or --damping; "
                                 f"got restitution={args.restitution!r}, "
                                 f"damping={args.damping!r}")
            params["damping"] = kelvin_voigt_damping(params.pop("restitution"),
                                                     args.stiffness, args.mass)
    law = law_from_name(args.law, **params)
    out = single_impact(law, mass=args.mass, velocity=args.velocity)
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{args.law} impact, m = {args.mass} kg, v0 = {args.velocity} m/s")
        for key, unit in UNITS.items():
            print(f"  {key:22s} {out[key]:.6e} {unit}")
    return 0
