"""``vibroimpact plot RESULT --kind KIND -o FIGURE``: draw a saved result."""

from __future__ import annotations

import argparse
from typing import Any

from vibroimpact.io.results_file import SUFFIXES, load
from vibroimpact.plotting import FIGURE_SUFFIXES, KINDS, plot, save_figure
from vibroimpact.plotting.branch import BRANCH_KINDS
from vibroimpact.sweeps.plot import SWEEP_KINDS

__all__ = ["add_parser", "main"]

_EPILOG = "kinds:\n" + "\n".join(f"  {k:22s} {v.description}" for k, v in KINDS.items()) + "".join(
    f"\n  {k:22s} {d}" for k, d in {**SWEEP_KINDS, **BRANCH_KINDS}.items()) + """

examples:
  vibroimpact run examples/models/sdof_paper_ln.toml -o run.nc
  vibroimpact plot run.nc --kind displacement -o displacement.png
  vibroimpact plot run.nc --kind force-indentation --gap 0 -o loops.svg
  vibroimpact plot run.nc --kind impact-map --x phase --period 0.2 -o map.pdf
  vibroimpact plot run.nc --kind spectrum --quantity acceleration --f-max 5000 -o fft.png
  vibroimpact plot branch.nc --kind branch --sweep sweep.nc -o branch.png
  vibroimpact plot branch.nc --kind multipliers -o multipliers.png
  vibroimpact plot rotor.nc --kind orbit --dof 0 --dof 1 --clearance 1e-3 -o orbit.png
  vibroimpact plot speeds.nc --kind waterfall --dof 0 --dof 1 -o waterfall.png"""


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``plot`` subcommand to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "plot",
        help="plot a saved result (.nc, .h5 or .csv)",
        description="Draw a result written by `vibroimpact run -o` (or Result.save) as a "
        "PNG, SVG or PDF figure; axis labels carry SI units.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("result", metavar="RESULT", help=f"result file ({', '.join(SUFFIXES)})")
    p.add_argument("--kind", default="displacement", choices=[*KINDS, *SWEEP_KINDS, *BRANCH_KINDS],
                   metavar="KIND",
                   help="what to draw (default displacement; see the list below)")
    p.add_argument("-o", "--output", required=True, metavar="FIGURE",
                   help=f"figure file ({', '.join(FIGURE_SUFFIXES)})")
    p.add_argument("--dof", type=int, action="append", dest="dofs", metavar="N",
                   help="recorded DOF to show (repeat for several; default all)")
    p.add_argument("--gap", type=int, action="append", dest="gaps", metavar="G",
                   help="gap to show (repeat for several; default all)")
    p.add_argument("--t-min", type=float, default=None, help="start of the time window, s")
    p.add_argument("--t-max", type=float, default=None, help="end of the time window, s")
    p.add_argument("--x", choices=("time", "phase"), default=None,
                   help="impact-map: against contact start time or forcing phase")
    p.add_argument("--period", type=float, default=None,
                   help="impact-map --x phase: forcing period, s (default: from the model)")
    p.add_argument("--quantity", default=None,
                   help="spectrum: displacement, velocity, acceleration, contact-force or "
                   "penetration (default displacement)")
    p.add_argument("--f-max", type=float, default=None, help="spectrum: highest frequency, Hz")
    p.add_argument("--n-modes", type=int, default=None,
                   help="mode-shapes: elastic modes to draw (default 4)")
    p.add_argument("--node", type=int, default=None, metavar="N",
                   help="orbit: the x and y of this node in the result's DOF map (a beam's, a "
                   "matrices file's, a Jeffcott rotor's node 0)")
    p.add_argument("--clearance", type=float, default=None, metavar="C",
                   help="orbit: draw the stator's clearance circle of radius C, m")
    p.add_argument("--center", type=float, nargs=2, default=None, metavar=("X", "Y"),
                   help="orbit: the stator's centre, m (default 0 0)")
    p.add_argument("--sweep", default=None, metavar="SWEEP.nc",
                   help="branch: draw this sweep's bifurcation diagram (over the branch's "
                   "parameter) under the branch")
    p.add_argument("--title", default=None, help="figure title")
    p.set_defaults(handler=main)
    return p


def main(args: argparse.Namespace) -> int:
    """Load ``args.result``, draw ``args.kind`` and save it atomically to ``args.output``."""
    from pathlib import Path

    from vibroimpact.errors import ModelError

    out = Path(args.output)
    if out.suffix.lower() not in FIGURE_SUFFIXES:
        raise ModelError(f"-o: {args.output!r} is not valid; expected a file name ending in "
                         f"{', '.join(FIGURE_SUFFIXES)}")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise ModelError(f"-o: {args.output!r} is not valid; expected a file in an existing "
                         "folder")
    if args.kind in SWEEP_KINDS:  # files of `vibroimpact sweep`
        from vibroimpact.sweeps.plot import cli_plot

        return cli_plot(args)
    if args.kind in BRANCH_KINDS:  # files of `vibroimpact continue`
        from vibroimpact.plotting.branch import cli_plot as branch_plot

        return branch_plot(args)
    if args.sweep is not None:
        raise ModelError(f"--sweep: not an option of --kind {args.kind}; it is one of "
                         "--kind branch")
    ds = load(args.result)
    kind = KINDS[args.kind]
    options: dict[str, Any] = {"t_min": args.t_min, "t_max": args.t_max}
    for name in ("dofs", "gaps", "x", "period", "quantity", "f_max", "n_modes", "clearance",
                 "center", "node"):
        value = getattr(args, name)
        if value is None:
            continue
        if name not in kind.options:
            flag = "--" + {"dofs": "dof", "gaps": "gap"}.get(name, name).replace("_", "-")
            raise ModelError(f"{flag}: not an option of --kind {args.kind}; it takes "
                             + (", ".join(kind.options) or "no options"))
        options[name] = value
    fig = plot(ds, args.kind, title=args.title, **options)
    try:
        save_figure(fig, out)
    except OSError as e:
        raise ModelError(f"-o: cannot write {args.output!r}: {e.strerror}") from None
    return 0
