"""``vibroimpact reproduce``: the paper's cases (DESIGN.md §7)."""

from __future__ import annotations

import argparse
import json

from vibroimpact import cases
from vibroimpact.simulate import simulate

CASES = ("sdof", "two-spheres")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "reproduce",
        help="reproduce one of the paper's cases",
        description=(
            "sdof: the 100 kg block between two walls 5 mm away, leaving at 8 m/s, with the "
            "paper's five contact laws (0.02 s at dt = 1 us); prints per law the peak "
            "displacement and the impact table. two-spheres: the 0.04 kg sphere hitting a "
            "socket at 0.3 m/s; prints per law the separation speed beside the paper's."
        ),
    )
    p.add_argument("case", choices=CASES, help="which case")
    p.add_argument(
        "--restitution", type=float, default=None,
        help="restitution ce (default: 0.9 for sdof, 0.5 for two-spheres, as in the paper)",
    )
    p.add_argument("--json", action="store_true", help="print a JSON object keyed by law")
    p.set_defaults(handler=main)


def _sdof(args: argparse.Namespace) -> dict:
    ce = 0.9 if args.restitution is None else args.restitution
    out = {}
    for law in cases.PAPER_LAWS:
        r = simulate(cases.sdof_model(law, ce), t_end=cases.SDOF_T_END, dt=cases.SDOF_DT)
        out[law] = r.summary()
        if not args.json:
            print(f"{law}: peak displacement {r.max_abs_displacement[0] * 1e3:.4f} mm, "
                  f"{len(r.impacts)} impacts, {r.stats.wall_time_s * 1e3:.2f} ms")
            print(r.impacts.to_dataframe().to_string(index=False, float_format="%.6g"))
            print()
    return out


def _two_spheres(args: argparse.Namespace) -> dict:
    ce = 0.5 if args.restitution is None else args.restitution
    out = {}
    for law in cases.PAPER_LAWS:
        res = cases.two_spheres(law, ce)
        res["paper_v_out"] = cases.TWO_SPHERES_PAPER_V_OUT[law] if ce == 0.5 else None
        out[law] = res
        if not args.json:
            paper = res["paper_v_out"]
            note = f" (paper: about {paper} m/s)" if paper is not None else ""
            print(f"{law:20s} separation speed {res['v_out']:.4f} m/s{note}, "
                  f"restitution {res['restitution_effective']:.4f}, "
                  f"delta_max {res['delta_max'] * 1e6:.4f} um")
    return out


def main(args: argparse.Namespace) -> int:
    out = _sdof(args) if args.case == "sdof" else _two_spheres(args)
    if args.json:
        print(json.dumps(out))
    return 0
