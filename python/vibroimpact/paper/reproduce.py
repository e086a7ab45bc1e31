"""``vibroimpact reproduce``: the paper's cases (docs/paper-cases.md), its flags and its work.
The command line names the command and hands its arguments to :func:`main`."""

from __future__ import annotations

import argparse
import json
import logging
from collections.abc import Sequence

from vibroimpact.cli.verbosity import add_verbosity_options, configure_logging, log_run
from vibroimpact.paper import cases
from vibroimpact.simulate import simulate

CASES = ("sdof", "two-spheres", "hollow-shaft")
#: ``reproduce all``: every figure and table of the paper our cases cover, and a report.
ALL = "all"


def build_parser() -> argparse.ArgumentParser:
    """The flags of ``vibroimpact reproduce``."""
    p = argparse.ArgumentParser(
        prog="vibroimpact reproduce",
        description=(
            "sdof: the 100 kg block between two walls 5 mm away, leaving at 8 m/s, with the "
            "paper's five contact laws (0.02 s at dt = 1 us); prints per law the peak "
            "displacement and the impact table. two-spheres: the 0.04 kg sphere hitting a "
            "socket at 0.3 m/s; prints per law the separation speed beside the paper's. "
            "hollow-shaft: the tube on three pairs of sliders with 3 mm clearance (§3.2); prints "
            "its first free-free bending frequencies (Euler-Bernoulli and Timoshenko) beside "
            "the paper's, then runs F = 100 sin(20 pi t) N at every node and prints the "
            "displacement, acceleration and impacts at the sliders."
        ),
    )
    p.add_argument("case", choices=(*CASES, ALL),
                   help="which case; all: every figure and table into -o DIR with a report")
    p.add_argument("-o", "--output", metavar="DIR", default=None,
                   help="all: the folder for the figures, tables, report.md and report.html "
                   "(default: paper-figures)")
    p.add_argument("--format", choices=("png", "svg", "pdf"), default="png",
                   help="all: figure format (default png)")
    add_verbosity_options(p)
    p.add_argument(
        "--restitution", type=float, default=None,
        help="restitution ce (default: 0.9 for sdof, 0.5 for two-spheres, as in the paper)",
    )
    p.add_argument("--json", action="store_true", help="print a JSON object keyed by law")
    p.add_argument("--elements", type=int, default=20,
                   help="hollow-shaft: beam elements (default 20)")
    p.add_argument("--t-end", type=float, default=None,
                   help=f"hollow-shaft: simulated time in s (default {cases.HOLLOW_SHAFT_T_END})")
    p.add_argument("--dt", type=float, default=None,
                   help=f"hollow-shaft: time step in s (default {cases.HOLLOW_SHAFT_DT})")
    return p


def _sdof(args: argparse.Namespace) -> dict:
    ce = 0.9 if args.restitution is None else args.restitution
    out = {}
    for law in cases.PAPER_LAWS:
        r = simulate(cases.sdof_model(law, ce), t_end=cases.SDOF_T_END, dt=cases.SDOF_DT)
        out[law] = r.summary()
        log_run(logging.getLogger("vibroimpact.reproduce"), out[law])
        if not (args.json or args.quiet):
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
        if not (args.json or args.quiet):
            paper = res["paper_v_out"]
            note = f" (paper: about {paper} m/s)" if paper is not None else ""
            print(f"{law:20s} separation speed {res['v_out']:.4f} m/s{note}, "
                  f"restitution {res['restitution_effective']:.4f}, "
                  f"delta_max {res['delta_max'] * 1e6:.4f} um")
    return out


def _hollow_shaft(args: argparse.Namespace) -> dict:
    from vibroimpact.errors import ModelError
    from vibroimpact.fe import modes

    if args.elements < 2 or args.elements % 2:
        raise ModelError(f"--elements: {args.elements!r} is not valid; expected an even "
                         "number >= 2 (a slider sits at the middle node)")
    t_end = cases.HOLLOW_SHAFT_T_END if args.t_end is None else args.t_end
    dt = cases.HOLLOW_SHAFT_DT if args.dt is None else args.dt
    freqs = {}
    for theory in ("euler-bernoulli", "timoshenko"):
        m = modes(cases.hollow_shaft_beam(theory, args.elements), 3)
        freqs[theory] = [float(f) for f in m.elastic_frequencies_hz[:3]]
    model = cases.hollow_shaft_model("timoshenko", args.elements)
    sliders = [g.dof for g in model.gaps]
    r = simulate(model, t_end=t_end, dt=dt, dofs=sliders)
    names = list(cases.HOLLOW_SHAFT_SLIDERS)
    counts = [int((r.impacts.gap == i).sum()) for i in range(len(names))]
    peak_a = [float(a) for a in abs(r.acceleration).max(axis=0)]
    out = {
        "frequencies_hz": freqs,
        "paper_frequencies_hz": list(cases.HOLLOW_SHAFT_PAPER_FREQUENCIES_HZ),
        "sliders": names,
        "max_abs_displacement": [float(x) for x in r.max_abs_displacement],
        "max_abs_acceleration": peak_a,
        "impacts": counts,
        "impact_table": r.impacts.to_records(),
        "contact_stiffness": model.gaps[0].law.contact_stiffness,
        "elements": args.elements,
        "theory": "timoshenko",
        "steps": r.stats.steps,
        "wall_time_s": r.stats.wall_time_s,
        "energy_balance_error": r.energy.balance_error,
        "dt": r.dt,
        "t_end": t_end,
    }
    if not (args.json or args.quiet):
        print(f"hollow shaft: tube 190 x 5 mm x 1000 mm, {args.elements} elements, free-free "
              "bending frequencies [Hz]")
        print(f"  {'mode':>4}  {'Euler-Bernoulli':>15}  {'Timoshenko':>10}  {'paper':>6}")
        for i, paper in enumerate(cases.HOLLOW_SHAFT_PAPER_FREQUENCIES_HZ):
            print(f"  {i + 1:>4}  {freqs['euler-bernoulli'][i]:>15.1f}  "
                  f"{freqs['timoshenko'][i]:>10.1f}  {paper:>6.0f}")
        print(f"forced response (Timoshenko; F = 100 sin(20 pi t) N at every node; clearance "
              f"3 mm; Hertz K = {out['contact_stiffness']:.4g} N/m^1.5): t_end = {t_end:g} s, "
              f"dt = {r.dt:g} s, {r.stats.steps} steps, {r.stats.wall_time_s:.2f} s, energy "
              f"balance error {r.energy.balance_error:.2e}")
        print(f"  {'slider':>6}  {'max|x| [mm]':>11}  {'max|a| [m/s^2]':>14}  {'impacts':>7}")
        for i, name in enumerate(names):
            print(f"  {name:>6}  {r.max_abs_displacement[i] * 1e3:>11.4f}  {peak_a[i]:>14.4g}  "
                  f"{counts[i]:>7}")
        table = r.impacts.to_dataframe()
        table["gap"] = [names[g] for g in table["gap"]]
        print(table.to_string(index=False, float_format="%.6g"))
    return out


def _all(args: argparse.Namespace) -> int:
    import sys
    import time

    from vibroimpact.paper.report import reproduce_all

    start = time.perf_counter()
    out = args.output or "paper-figures"
    numbers = reproduce_all(out, fmt=args.format, quiet=args.quiet)
    if args.json:
        print(json.dumps(numbers))
    elif not args.quiet:
        print(f"wrote {len(numbers['files'])} files to {out}/ in "
              f"{time.perf_counter() - start:.1f} s; open {out}/report.html", file=sys.stderr)
    return 0


def main(argv: Sequence[str]) -> int:
    """Run ``vibroimpact reproduce`` with its arguments ``argv``."""
    args = build_parser().parse_args(argv)
    configure_logging(args)
    if args.case == ALL:
        return _all(args)
    run = {"sdof": _sdof, "two-spheres": _two_spheres, "hollow-shaft": _hollow_shaft}
    out = run[args.case](args)
    if args.json:
        print(json.dumps(out))
    return 0
